//! The processes sharing a run under MPI (the `mpi` feature, through rsmpi): MPI is
//! started only when the process was started by an MPI launcher (`mpirun`, `srun`:
//! its environment says so), else the run is one process as without the feature.
//!
//! Protocol: every collective (a gather on rank 0, or a gather on every rank) begins
//! with every rank's header (status, length, kind) all-gathered. If any rank's status is
//! a failure, every rank gets the first failing rank's error (its text broadcast) and
//! the run's collectives are over; if the ranks called different collectives, every
//! rank gets an "out of step" error. Else the bytes follow in pieces of at most 1 GiB
//! (MPI counts are 32-bit): sent to rank 0, or broadcast from each rank in turn.
//! Every run ends with a gather on rank 0 (from the subcommand, or from `main` with the
//! result or the error that ended the run), unless an error already ended the
//! collectives. A rank that dies makes the launcher end every rank, so rank 0 never
//! writes a partial output.

use mpi::traits::*;
use rad_pipeline::share::Peers;
use std::cell::Cell;

/// The processes sharing this run.
pub struct Ranks {
    // (Dropped last: MPI is finalised when the universe goes.)
    world: Option<mpi::topology::SimpleCommunicator>,
    _universe: Option<mpi::environment::Universe>,
    done: Cell<bool>,
}

/// Pieces of a message: MPI counts are i32.
const PIECE: usize = 1 << 30;

/// The kinds of collective, in a header.
const TO_ROOT: u64 = 0;
const TO_ALL: u64 = 1;

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
            done: Cell::new(false),
        }
    }

    /// Whether this run's collectives are over (its final gather made, or an error
    /// shared by every rank).
    pub fn gathered(&self) -> bool {
        self.done.get() || self.size() == 1
    }

    /// The collective of `kind` on `part`: every rank's bytes on rank 0 (`TO_ROOT`) or
    /// on every rank (`TO_ALL`), empty where they do not go.
    fn collective(
        &self,
        world: &mpi::topology::SimpleCommunicator,
        kind: u64,
        part: Result<Vec<u8>, String>,
    ) -> Result<Vec<Vec<u8>>, String> {
        assert!(!self.done.get(), "no collective after the run's last");
        let size = world.size() as usize;
        let me = world.rank() as usize;
        let (status, mine) = match part {
            Ok(b) => (0u64, b),
            Err(e) => (1u64, e.into_bytes()),
        };
        let header = [status, mine.len() as u64, kind];
        let mut headers = vec![0u64; 3 * size];
        world.all_gather_into(&header[..], &mut headers[..]);
        let head = |r: usize| {
            (
                headers[3 * r],
                headers[3 * r + 1] as usize,
                headers[3 * r + 2],
            )
        };
        let receive = |r: usize, mine: &[u8]| -> Vec<u8> {
            let mut buf = if r == me {
                mine.to_vec()
            } else {
                vec![0u8; head(r).1]
            };
            for piece in buf.chunks_mut(PIECE) {
                world.process_at_rank(r as i32).broadcast_into(piece);
            }
            buf
        };
        if let Some(r) = (0..size).find(|&r| head(r).0 != 0) {
            self.done.set(true);
            let text = receive(r, &mine);
            return Err(format!("rank {r}: {}", String::from_utf8_lossy(&text)));
        }
        if (0..size).any(|r| head(r).2 != kind) {
            self.done.set(true);
            return Err(
                "the ranks are out of step (they ran different commands or scenes): start every rank with the same command"
                    .into(),
            );
        }
        if kind == TO_ALL {
            return Ok((0..size).map(|r| receive(r, &mine)).collect());
        }
        self.done.set(true);
        if me != 0 {
            let root = world.process_at_rank(0);
            for piece in mine.chunks(PIECE) {
                root.send(piece);
            }
            return Ok(Vec::new());
        }
        let mut parts = vec![mine];
        for r in 1..size {
            let from = world.process_at_rank(r as i32);
            let len = head(r).1;
            let mut bytes = Vec::with_capacity(len);
            while bytes.len() < len {
                let (piece, _) = from.receive_vec::<u8>();
                bytes.extend_from_slice(&piece);
            }
            parts.push(bytes);
        }
        Ok(parts)
    }
}

impl Peers for Ranks {
    fn rank(&self) -> usize {
        self.world.as_ref().map_or(0, |w| w.rank() as usize)
    }

    fn size(&self) -> usize {
        self.world.as_ref().map_or(1, |w| w.size() as usize)
    }

    /// Every rank's part, in rank order, on rank 0 (`None` on the others): the run's
    /// last collective.
    fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        match self.world.as_ref().filter(|w| w.size() > 1) {
            None => part.map(|p| Some(vec![p])),
            Some(world) => {
                let parts = self.collective(world, TO_ROOT, part)?;
                Ok((world.rank() == 0).then_some(parts))
            }
        }
    }

    fn all_gather(&self, part: Result<Vec<u8>, String>) -> Result<Vec<Vec<u8>>, String> {
        match self.world.as_ref().filter(|w| w.size() > 1) {
            None => part.map(|p| vec![p]),
            Some(world) => self.collective(world, TO_ALL, part),
        }
    }
}
