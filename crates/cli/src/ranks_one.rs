//! One process: what the `mpi` feature's ranks are when it is off.

/// The processes sharing this run: here one.
pub struct Ranks;

impl Ranks {
    pub fn init() -> Ranks {
        Ranks
    }
    pub fn rank(&self) -> usize {
        0
    }
    pub fn size(&self) -> usize {
        1
    }
    /// Whether this run's parts were already gathered (never needed with one process).
    pub fn gathered(&self) -> bool {
        true
    }
    /// Every rank's part, in rank order, on rank 0 (here this one's).
    pub fn gather(&self, part: Result<Vec<u8>, String>) -> Result<Option<Vec<Vec<u8>>>, String> {
        part.map(|p| Some(vec![p]))
    }
}
