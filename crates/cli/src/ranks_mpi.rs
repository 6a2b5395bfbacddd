//! The processes sharing a run under MPI (the `mpi` feature, through rsmpi): MPI is
//! started only when the process was started by an MPI launcher (`mpirun`, `srun`:
//! its environment says so), else the run is one process as without the feature.
//!
//! Protocol: every rank gathers exactly once (`gather`, from the subcommand, or from
//! `main` with the error that ended the run early), sending rank 0 a status, a length
//! and its bytes in pieces of at most 1 GiB (MPI counts are 32-bit); rank 0 takes them
//! in rank order. A rank that dies makes the launcher end every rank, so rank 0 never
//! writes a partial output.

use mpi::traits::*;
use std::cell::Cell;

/// The processes sharing this run.
pub struct Ranks {
    // (Dropped last: MPI is finalised when the universe goes.)
    world: Option<mpi::topology::SimpleCommunicator>,
    _universe: Option<mpi::environment::Universe>,
    gathered: Cell<bool>,
}

/// Pieces of a message: MPI counts are i32.
const PIECE: usize = 1 << 30;

/// Whether an MPI launcher started this process (Open MPI, MPICH/Hydra, PMIx, Slurm).
fn launched_by_mpi() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

impl Ranks {
    pub fn init() -> Ranks {
        let universe = if launched_by_mpi() {
            mpi::initialize()
        } else {
            None
        };
        let world = universe.as_ref().map(|u| u.world());
        Ranks {
            world,
            _universe: universe,
            gathered: Cell::new(false),
        }
    }

    pub fn rank(&self) -> usize {
        self.world.as_ref().map_or(0, |w| w.rank() as usize)
    }

    pub fn size(&self) -> usize {
        self.world.as_ref().map_or(1, |w| w.size() as usize)
    }

    /// Whether this rank has gathered (sent its part, or taken everyone's).
    pub fn gathered(&self) -> bool {
        self.gathered.get() || self.size() == 1
    }

    /// Every rank's part, in rank order, on rank 0 (`None` on the others); an error on
    /// rank 0 if any rank's part is one (the first, by rank, named), after taking them
    /// all, so that no rank is left waiting.
    pub fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        let Some(world) = self.world.as_ref().filter(|w| w.size() > 1) else {
            return part.map(|p| Some(vec![p]));
        };
        assert!(!self.gathered.replace(true), "a rank gathers once");
        if world.rank() != 0 {
            let (status, bytes) = match part {
                Ok(b) => (0u64, b),
                Err(e) => (1u64, e.into_bytes()),
            };
            let root = world.process_at_rank(0);
            root.send(&[status, bytes.len() as u64][..]);
            for piece in bytes.chunks(PIECE) {
                root.send(piece);
            }
            return Ok(None);
        }
        let mut first_error = part.as_ref().err().map(|e| format!("rank 0: {e}"));
        let mut parts = vec![part.unwrap_or_default()];
        for r in 1..world.size() {
            let from = world.process_at_rank(r);
            let (head, _) = from.receive_vec::<u64>();
            let (status, len) = (head[0], head[1] as usize);
            let mut bytes = Vec::with_capacity(len);
            while bytes.len() < len {
                let (piece, _) = from.receive_vec::<u8>();
                bytes.extend_from_slice(&piece);
            }
            if status != 0 && first_error.is_none() {
                first_error = Some(format!("rank {r}: {}", String::from_utf8_lossy(&bytes)));
            }
            parts.push(bytes);
        }
        match first_error {
            Some(e) => Err(e),
            None => Ok(Some(parts)),
        }
    }
}
