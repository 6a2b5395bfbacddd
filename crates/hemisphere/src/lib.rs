//! Form factors from one patch's hemisphere (the report's §2): N_θ × N_φ cells with
//! exact-integral delta form factors, an item buffer, and sparse rows accumulated in
//! f64. All rows of a scene are computed in parallel, deterministically whatever the
//! thread count.
//!
//! Item buffers come from a [`Caster`], the one interface every way of casting
//! implements: any [`rad_core::RayCast`] (one ray a cell, [`Hemisphere::cast`]), or
//! [`Scan`] ([`Hemisphere::scan`]: polygon by polygon over the cells each can cover).
//! They all give the same item buffers, to the bit.
//!
//! - `caster`: the [`Caster`] trait, its blanket impl for every `RayCast`, and [`Scan`].
//! - `cells`: [`Hemisphere`] cells, [`delta_form_factors`] and ray directions.
//! - `facet_scan`: [`FacetScan`], the scan over a mesh's facets; `facet_scan::rays` holds
//!   [`FacetRays`], single rays at the cost of facets, and `rays::bins` its light buffer.
//! - `hierarchy`: [`Hierarchy`], the scan over a bounding volume hierarchy, and
//!   [`HierarchyRays`].
//! - `incremental`: [`moved_area_rows`], the rows of a scene some of whose polygons moved,
//!   from the last step's item buffers ([`KeptBuffers`]), only what may change cast again.
//! - `item_buffer`: [`ItemBuffer`] (a patch id and a distance a cell) and [`Viewpoint`].
//! - `lambert`: [`point_to_polygon_form_factor`], Lambert's closed form.
//! - `row`: [`Row`]s from item buffers, [`compute_rows`] and [`compute_area_rows`].
//! - `scan`: the polygon scan's kernel, [`NearestHits`] (shared with improved estimation).

mod caster;
mod cells;
mod facet_scan;
mod hierarchy;
mod incremental;
mod item_buffer;
mod lambert;
mod row;
mod scan;

pub use caster::{Caster, Scan};
pub use cells::{delta_form_factors, DeltaRule, Hemisphere, HemisphereConfig, MAX_CELLS};
pub use facet_scan::{
    FacetRays, FacetRaysScratch, FacetScan, FacetScanScratch, FacetScanStats, BIN_RAYS_PER_FACET,
    MIN_BIN_RAYS,
};
pub use hierarchy::{Hierarchy, HierarchyRays, HierarchyScratch, HierarchyStats, TILE};
pub use incremental::{
    moved_area_rows, moved_area_rows_from, moved_polygons, KeptBuffers, RecastStats, WHOLE_FROM,
};
pub use item_buffer::{ItemBuffer, Viewpoint};
pub use lambert::point_to_polygon_form_factor;
pub use rad_core::{BACK, ESCAPED};
pub use row::{compute_area_rows, compute_rows, Row, RowAccumulator, MAX_ORIGINS};
pub use scan::{NearestHits, ScanScratch, ScanStats};

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
    #[error("{origins} origins a patch side is invalid: give 1 to {limit} (origins x origins hemispheres a patch)")]
    Origins { origins: u64, limit: u32 },
}
