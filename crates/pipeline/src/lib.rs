//! What every coherad user runs, once, for the two front ends (the `coherad` binary and
//! the Python package) and the reproduction: a scene file loaded and fingerprinted, rows
//! made by a named [`RowMethod`], the reciprocal matrix and its solve, solution files
//! written and read back, images written. It computes and writes; it never prints.
//!
//! - `export`: scenes and solutions to glTF 2.0 and PLY, radiosity baked into vertex colours.
//! - `images`: EXR and PNG files, and `render_image`, which picks the renderer's caster.
//! - `matrix_file`: coherad's compact binary sparse-matrix file, written and read back.
//! - `method`: [`RowMethod`] and [`CasterKind`], the ways to make rows, by stable names.
//! - `output`: atomic files, and the JSON of patches and rows.
//! - `parse`: command-line values (resolutions, patch lists, reflectances, sizes).
//! - `request`: what both front ends decide ([`pick_method`], [`SolveRequest`],
//!   [`settle_method`], [`ViewFactorRequest`]).
//! - `row_file`: rows spilled to an unnamed temporary file for out-of-core solving.
//! - `rows`: a scene's rows by a method, whole or streamed; the one place names become casters.
//! - `scene_file`: [`SceneFile`], a scene loaded with its fingerprint.
//! - `share`: a run's rows shared among processes (the `Peers` trait; no MPI here).
//! - `solve`: from a scene to its radiosities: a dispatch over `solve/` (`config`, `solution`,
//!   `storage`, `stored`, `by_rows`, `out_of_core`, `matrix_free`).
//! - `viewfactors`: surface-to-surface view factors and their writers.

pub mod export;
pub mod images;
pub mod matrix_file;
mod method;
mod moving;
pub use moving::step_scene_file;
pub mod output;
mod parse;
mod request;
pub mod row_file;
mod rows;
mod scene_file;
pub mod share;
pub mod solve;
pub mod viewfactors;

pub use method::{CasterKind, RowMethod};
// The vocabulary the front ends need, so that they see the libraries only through
// the pipeline.
pub use glam::Vec3;
pub use parse::{
    parse_patch_list, parse_reflectance, parse_resolution, parse_size, reflectance_of,
};
pub use rad_core::Rgb;
pub use rad_estimator::{EstimateStats, Mode};
pub use rad_geometry::file::{read_motion, LoadConfig, SCENE_EXTENSIONS};
pub use rad_geometry::{Camera, Motion, SceneDesc, Triangulation};
pub use rad_hemisphere::{Hemisphere, HemisphereConfig, RecastStats, Row};
pub use rad_render::{RenderConfig, Shading, View};
pub use rad_solver::{Enclosure, SolveConfig, Solver};
pub use request::{
    pick_method, settle_method, MethodChoice, PickedMethod, SolveRequest, ViewFactorRequest,
};
pub use rows::{rows, rows_streamed, rows_streamed_of, Rows, STREAM_CHUNK};
pub(crate) use rows::{with_caster as rows_with_caster, CasterJob};
pub use scene_file::{LoadNote, SceneFile};
pub use solve::{
    OutOfCoreStats, Progress, Storage, DEFAULT_MEMORY_LIMIT, MATRIX_FREE_BATCH,
    MATRIX_FREE_OVERSHOOT,
};

use rad_accel::VoxelGridConfig;

/// Errors of the pipeline.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] rad_geometry::Error),
    #[error(transparent)]
    Grid(#[from] rad_accel::Error),
    #[error(transparent)]
    Hemisphere(#[from] rad_hemisphere::Error),
    /// A setting a front end was given that cannot be used: the message names it as
    /// the binary's flag does, and what would do.
    #[error("{0}")]
    Setting(String),
    #[error("bad {what} {input:?}: {reason}")]
    Parse {
        what: &'static str,
        input: String,
        reason: String,
    },
    #[error(transparent)]
    Solver(#[from] rad_solver::Error),
    #[error(transparent)]
    Render(#[from] rad_render::Error),
    #[error(transparent)]
    Estimator(#[from] rad_estimator::Error),
    #[error("cannot encode {what}: {reason}")]
    Encode { what: &'static str, reason: String },
    /// A file that could not be read or written (`action`: "read" or "write").
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        action: &'static str,
        path: std::path::PathBuf,
        source: std::io::Error,
    },
    /// A value that is not finite where data was expected: never written, never called
    /// converged.
    #[error("{what} is {value}, not a finite number (it arose in {place}); nothing was written")]
    NonFinite {
        what: String,
        value: f64,
        place: &'static str,
    },
    /// The form factors do not fit the memory limit by any way of solving offered.
    #[error(
        "{what} would need about {need_mib} MiB, over the memory limit of {limit_mib} MiB; {hint}"
    )]
    MemoryLimit {
        what: String,
        need_mib: u64,
        limit_mib: u64,
        hint: &'static str,
    },
    /// The processes sharing a run disagree, or one of them failed (its error).
    #[error("{0}")]
    Peers(String),
    #[error("{}: {reason}", path.display())]
    Solution {
        path: std::path::PathBuf,
        reason: String,
    },
}

/// The voxel grid used everywhere unless told otherwise ([`VoxelGridConfig::DEFAULT`]).
pub fn default_grid() -> VoxelGridConfig {
    VoxelGridConfig::DEFAULT
}

/// The estimator settings used unless told otherwise (by the CLI and the harness):
/// ring-neighbour hole filling, first order where R sinθ > 10 |C1C2| (exact elsewhere),
/// no boundary lists (they help neither mode enough: see results/REPORT.md), and in
/// improved mode polygons guessed on a grid 3 times coarser, and a patch needing real
/// rays for over 5 % of its cells cast exactly.
pub fn default_estimator(mode: rad_estimator::Mode) -> rad_estimator::EstimatorConfig {
    rad_estimator::EstimatorConfig {
        mode,
        fill: rad_estimator::HoleFill::RingNeighbour,
        reprojection: rad_estimator::Reprojection::LATERAL_10,
        boundary_lists: false,
        max_real_ray_share: 0.05,
        // Guesses on a grid 3 times coarser (2 or 1 where 3 does not divide the
        // resolution): as accurate on the loft as per-cell guesses, at about half the
        // instructions (results/REPORT.md).
        guess_stride: 3,
    }
}
