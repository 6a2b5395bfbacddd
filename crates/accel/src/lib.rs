//! Ray casting against a scene's polygons (not patches): a uniform voxel grid traversed
//! by 3D-DDA (Amanatides and Woo) with mailboxing, and a brute-force reference. Both
//! implement [`rad_core::RayCast`], and nothing else.

mod brute;
mod grid;
mod wide;

pub use brute::BruteForce;
pub use grid::{GridResolution, GridScratch, VoxelGrid, VoxelGridConfig, MAX_VOXELS};
pub use wide::{WideBvh, WideTree};

/// Errors from building an accelerator.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("voxel grid resolution {dims:?} is invalid: {reason}")]
    Resolution {
        dims: [u64; 3],
        reason: &'static str,
    },
    #[error("voxel grid density {density} must be finite and > 0")]
    Density { density: f64 },
}
