//! The processes sharing a run under MPI (the `mpi` feature, through rsmpi): MPI is
//! started only when the process was started by an MPI launcher (`mpirun`, `srun`:
//! its environment says so), else the run is one process as without the feature.
//!
//! Protocol: every collective (a gather on rank 0, a gather on every rank, or an
//! exchange: each rank's part for each other rank) begins with every rank's header
//! (status, length, kind) all-gathered. If any rank's status is a failure, every rank
//! gets the first failing rank's error (its text broadcast) and the run's collectives
//! are over; if the ranks called different collectives, every rank gets an "out of
//! step" error. Else the bytes follow in pieces of at most 1 GiB (MPI counts are
//! 32-bit): sent to rank 0, broadcast from each rank in turn, or sent rank to rank.
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
const TO_EACH: u64 = 2;

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

    /// The header step of every collective: every rank's status, length and kind
    /// all-gathered. If any rank failed, every rank gets the first failing rank's error
    /// (its text broadcast: `error` on that rank) and the collectives are over; if the
    /// ranks called different kinds, an "out of step" error. Else every rank's length.
    fn agree(
        &self,
        world: &mpi::topology::SimpleCommunicator,
        kind: u64,
        len: usize,
        error: Option<&[u8]>,
    ) -> Result<Vec<usize>, String> {
        assert!(!self.done.get(), "no collective after the run's last");
        let size = world.size() as usize;
        let header = [u64::from(error.is_some()), len as u64, kind];
        let mut headers = vec![0u64; 3 * size];
        world.all_gather_into(&header[..], &mut headers[..]);
        if let Some(r) = (0..size).find(|&r| headers[3 * r] != 0) {
            self.done.set(true);
            let mut text = match error.filter(|_| r == world.rank() as usize) {
                Some(e) => e.to_vec(),
                None => vec![0u8; headers[3 * r + 1] as usize],
            };
            broadcast_from(world, r, &mut text);
            return Err(format!("rank {r}: {}", String::from_utf8_lossy(&text)));
        }
        if (0..size).any(|r| headers[3 * r + 2] != kind) {
            self.done.set(true);
            return Err(
                "the ranks are out of step (they ran different commands or scenes): start every rank with the same command"
                    .into(),
            );
        }
        Ok((0..size).map(|r| headers[3 * r + 1] as usize).collect())
    }

    /// The collective of `kind` on `part`: every rank's bytes on rank 0 (`TO_ROOT`) or
    /// on every rank (`TO_ALL`), empty where they do not go.
    fn collective(
        &self,
        world: &mpi::topology::SimpleCommunicator,
        kind: u64,
        part: Result<Vec<u8>, String>,
    ) -> Result<Vec<Vec<u8>>, String> {
        let me = world.rank() as usize;
        let mine = match part {
            Ok(b) => b,
            Err(e) => {
                let e = e.into_bytes();
                return Err(self
                    .agree(world, kind, e.len(), Some(&e))
                    .err()
                    .unwrap_or_default());
            }
        };
        let lens = self.agree(world, kind, mine.len(), None)?;
        if kind == TO_ALL {
            // This rank's own bytes handed over, not copied.
            let mut own = Some(mine);
            let parts = (0..lens.len())
                .map(|r| {
                    let mut buf = match own.take_if(|_| r == me) {
                        Some(b) => b,
                        None => vec![0u8; lens[r]],
                    };
                    broadcast_from(world, r, &mut buf);
                    buf
                })
                .collect();
            return Ok(parts);
        }
        self.done.set(true);
        if me != 0 {
            send(world, 0, &mine);
            return Ok(Vec::new());
        }
        let mut parts = vec![mine];
        for (r, &len) in lens.iter().enumerate().skip(1) {
            parts.push(receive(world, r, len));
        }
        Ok(parts)
    }

    /// Each rank's `parts[d]` to rank `d`: the length of each first, then the bytes;
    /// source by source, destination by destination, the same order on every rank (so
    /// that blocking sends always meet their receives).
    fn exchange_parts(
        &self,
        world: &mpi::topology::SimpleCommunicator,
        parts: Result<Vec<Vec<u8>>, String>,
    ) -> Result<Vec<Vec<u8>>, String> {
        let size = world.size() as usize;
        let me = world.rank() as usize;
        let parts = parts.and_then(|p| {
            (p.len() == size)
                .then_some(p)
                .ok_or_else(|| format!("an exchange needs one part for each of {size} ranks"))
        });
        let mut mine = match parts {
            Ok(p) => p,
            Err(e) => {
                let e = e.into_bytes();
                let err = self.agree(world, TO_EACH, e.len(), Some(&e)).err();
                return Err(err.unwrap_or_default());
            }
        };
        let total = mine.iter().map(Vec::len).sum();
        self.agree(world, TO_EACH, total, None)?;
        let mut got: Vec<Vec<u8>> = vec![Vec::new(); size];
        got[me] = std::mem::take(&mut mine[me]);
        for (from, slot) in got.iter_mut().enumerate() {
            for to in (0..size).filter(|&to| to != from) {
                if me == from {
                    let part = std::mem::take(&mut mine[to]);
                    world.process_at_rank(to as i32).send(&(part.len() as u64));
                    send(world, to, &part);
                } else if me == to {
                    let (len, _) = world.process_at_rank(from as i32).receive::<u64>();
                    *slot = receive(world, from, len as usize);
                }
            }
        }
        Ok(got)
    }
}

/// `buf` broadcast from rank `root`, in pieces.
fn broadcast_from(world: &mpi::topology::SimpleCommunicator, root: usize, buf: &mut [u8]) {
    for piece in buf.chunks_mut(PIECE) {
        world.process_at_rank(root as i32).broadcast_into(piece);
    }
}

/// `bytes` sent to rank `to`, in pieces.
fn send(world: &mpi::topology::SimpleCommunicator, to: usize, bytes: &[u8]) {
    let dest = world.process_at_rank(to as i32);
    for piece in bytes.chunks(PIECE) {
        dest.send(piece);
    }
}

/// `len` bytes from rank `from`, in the pieces [`send`] sent, received in place.
fn receive(world: &mpi::topology::SimpleCommunicator, from: usize, len: usize) -> Vec<u8> {
    let source = world.process_at_rank(from as i32);
    let mut bytes = vec![0u8; len];
    for piece in bytes.chunks_mut(PIECE) {
        source.receive_into(piece);
    }
    bytes
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

    fn exchange(&self, parts: Result<Vec<Vec<u8>>, String>) -> Result<Vec<Vec<u8>>, String> {
        match self.world.as_ref().filter(|w| w.size() > 1) {
            None => parts,
            Some(world) => self.exchange_parts(world, parts),
        }
    }
}
