//! Form factors from one patch's hemisphere (the report's §2): N_θ × N_φ cells with
//! exact-integral delta form factors, one ray per cell through any [`rad_core::RayCast`],
//! an item buffer, and sparse rows accumulated in f64. All rows of a scene are computed
//! in parallel, deterministically whatever the thread count.
//!
//! [`Hemisphere::scan`] makes the same item buffers, to the bit, polygon by polygon over
//! the cells each can cover instead of ray by ray through a grid (module `scan`).

mod cells;
mod lambert;
mod row;
mod scan;

pub use cells::{delta_form_factors, DeltaRule, Hemisphere, HemisphereConfig, MAX_CELLS};
pub use lambert::point_to_polygon_form_factor;
pub use row::{compute_rows, compute_rows_scan, ItemBuffer, Row, RowAccumulator, BACK, ESCAPED};
pub use scan::{NearestHits, ScanScratch, ScanStats, NO_HIT};

/// Errors from setting up a hemisphere.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("hemisphere resolution {n_theta}x{n_phi} is invalid: {reason}")]
    Resolution {
        n_theta: u64,
        n_phi: u64,
        reason: String,
    },
    #[error("phi shift {shift} must be finite and in [0, 1) sectors")]
    PhiShift { shift: f64 },
    #[error("patch {patch} is out of range (the scene has {n_patches} patches)")]
    PatchOutOfRange { patch: u64, n_patches: usize },
}
