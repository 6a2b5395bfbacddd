//! Hemispheres estimated from a neighbour's by a small motion (the report's §3, with the
//! formulas (1) of docs/design.md, "Motion and reprojection"), and an improvement that
//! estimates visibility instead of patch ids.
//!
//! - [`SourceHemisphere`]: an exact hemisphere H1 kept for estimation: ids, distances,
//!   and the boundary lists of §3.5.2.
//! - [`reproject_exact`], [`reproject_first_order`]: where a point seen from C1 lands in H2.
//! - [`Estimator::faithful`]: the report's method: z-buffered splats, then hole filling.
//! - [`Estimator::improved`]: splat polygons, then resolve each cell with its own ray
//!   against the polygons guessed for it and its 8 neighbours.
//! - [`windows`], [`Schedule`]: the 3 × 3 window schedule of §3.6 (and windows across a
//!   mesh's one-patch polygons of one plane); [`estimate_rows`] runs it all.
//!
//! Modules, one a concept:
//! - `cell_trig`: per-cell trigonometry and the splat's f32 cell lookups.
//! - `config`: [`EstimatorConfig`] and its choices ([`Mode`], [`HoleFill`], [`Reprojection`]).
//! - `driver`: [`estimate_rows`] and [`estimate_windows`], exact centres and estimates.
//! - `estimator`: the [`Estimator`], its per-resolution tables, and the motion ([`frame_turn`]).
//! - `faithful`: faithful mode ([`Estimate`]): splat, then fill holes.
//! - `holes`: hole filling, by cells and by runs.
//! - `improved`: improved mode ([`ImprovedEstimate`], [`Outcome`]).
//! - `reproject`: the f64 formulas ([`reproject_exact`], [`reproject_first_order`]).
//! - `schedule`: the windows, within and across polygons ([`windows`], [`Schedule`]).
//! - `source`: [`SourceHemisphere`], H1.
//! - `splat`: the ring pass and the z-buffered splat.
//! - `zbuffer`: the splat's keys, and its AVX-512 writes.

mod cell_trig;
mod config;
mod driver;
mod estimator;
mod faithful;
mod holes;
mod improved;
mod reproject;
mod schedule;
mod source;
mod splat;
mod zbuffer;

pub use config::{EstimatorConfig, HoleFill, Mode, Reprojection, ThresholdTest, MAX_GUESS_STRIDE};
pub use driver::{
    estimate_rows, estimate_windows, EstimateStats, EstimatedRow, Source, WindowsJob,
};
pub use estimator::{frame_turn, Estimator, MAX_TILT};
pub use faithful::Estimate;
pub use improved::{ImprovedEstimate, Outcome};
pub use reproject::{reproject_exact, reproject_first_order, Motion, Reprojected};
pub use schedule::{windows, Schedule, Window, MAX_WINDOW};
pub use source::SourceHemisphere;

/// Errors of estimation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Hemisphere(#[from] rad_hemisphere::Error),
    #[error("estimator setting {name} = {value} is invalid: {rule}")]
    Config {
        name: &'static str,
        value: f64,
        rule: &'static str,
    },
    #[error("a schedule of {schedule} patches was given for a scene of {scene}: a schedule is made for its scene (Schedule::of)")]
    ScheduleMismatch { schedule: usize, scene: usize },
    #[error("window {window} does not exist: the schedule has {windows}")]
    WindowOutOfRange { window: usize, windows: usize },
    #[error("patch {patch}'s window made no row for it (a bug: please report it)")]
    Unmade { patch: u32 },
}

/// A small deterministic generator (xorshift) for the unit tests: uniform in [0, 1).
#[cfg(test)]
pub(crate) fn test_rng(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}
