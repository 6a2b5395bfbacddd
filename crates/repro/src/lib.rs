//! The report's experiments, run on our scenes, and the writers of what they produce:
//! form-factor and patch JSON for the `coherad` binary, the tables of `cargo xtask
//! reproduce` (JSON and Markdown). It computes and writes; it never prints.

pub mod accuracy;
pub mod closed_form;
pub mod estimation;
pub mod images;
pub mod loft;
pub mod output;
mod parse;
pub mod radiosity;
pub mod reciprocity;
pub mod reproduce;
pub mod speedup;
pub mod stats;

pub use parse::{parse_patch_list, parse_resolution};

use rad_accel::VoxelGridConfig;

/// Errors of the experiments and writers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] rad_geometry::Error),
    #[error(transparent)]
    Grid(#[from] rad_accel::Error),
    #[error(transparent)]
    Hemisphere(#[from] rad_hemisphere::Error),
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
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: std::path::PathBuf,
        source: std::io::Error,
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
        reprojection: rad_estimator::Reprojection::FirstOrder {
            test: rad_estimator::ThresholdTest::Lateral,
            threshold: 10.0,
        },
        boundary_lists: false,
        max_real_ray_share: 0.05,
        // Guesses on a grid 3 times coarser (2 or 1 where 3 does not divide the
        // resolution): as accurate on the loft as per-cell guesses, at about half the
        // instructions (results/REPORT.md).
        guess_stride: 3,
    }
}

/// A pool of one thread, for timings.
pub(crate) fn one_thread() -> Result<rayon::ThreadPool, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| Error::Parse {
            what: "thread pool",
            input: "1".into(),
            reason: e.to_string(),
        })
}

/// Where a figure comes from: filled in by the harness (the library reads no
/// environment) and written into every JSON result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Provenance {
    pub git_revision: String,
    pub cpu_model: String,
    pub nproc: usize,
    pub threads: usize,
    pub profile: String,
    pub command: String,
}
