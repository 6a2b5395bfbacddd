//! Ray casting against a scene's polygons (not patches): a uniform voxel grid traversed
//! by 3D-DDA (Amanatides and Woo) with mailboxing, a wide BVH for single rays, and a
//! brute-force reference. All implement [`rad_core::RayCast`], and nothing else.
//!
//! - `brute`: [`BruteForce`], every ray against every polygon: the reference.
//! - `grid`: [`VoxelGrid`] and its settings ([`VoxelGridConfig`]), per-thread [`GridScratch`].
//! - `wide`: [`WideBvh`], single rays through `obvhs`'s eight-wide BVH, and [`WideTree`], the
//!   same tree over any boxes (a [`rad_core::BoxTree`]).

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
