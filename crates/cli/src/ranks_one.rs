//! One process: what the `mpi` feature's ranks are when it is off.

use rad_pipeline::share::{Alone, Peers};

/// The processes sharing this run: here one.
pub struct Ranks;

impl Ranks {
    pub fn init() -> Ranks {
        Ranks
    }
    /// Whether this run's collectives are over (never needed with one process).
    pub fn gathered(&self) -> bool {
        true
    }
}

impl Peers for Ranks {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        Alone.gather(part)
    }
    fn all_gather(&self, part: Result<Vec<u8>, String>) -> Result<Vec<Vec<u8>>, String> {
        Alone.all_gather(part)
    }
    fn exchange(&self, parts: Result<Vec<Vec<u8>>, String>) -> Result<Vec<Vec<u8>>, String> {
        Alone.exchange(parts)
    }
}
