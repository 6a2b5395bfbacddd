//! The report's experiments, run on our scenes, and the writers of what they produce:
//! form-factor and patch JSON for the `coherad` binary, the tables of `cargo xtask
//! reproduce` (JSON and Markdown). It computes and writes; it never prints.

pub mod accuracy;
pub mod closed_form;
pub mod loft;
pub mod output;
mod parse;
pub mod reciprocity;
pub mod reproduce;
pub mod stats;

pub use parse::{parse_patch_list, parse_resolution};

use rad_accel::{GridResolution, VoxelGridConfig};

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
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: std::path::PathBuf,
        source: std::io::Error,
    },
}

/// The voxel grid used everywhere unless told otherwise: about 4 voxels per polygon
/// (measured best on the loft at 180 × 720; see ARCHITECTURE.md).
pub fn default_grid() -> VoxelGridConfig {
    VoxelGridConfig {
        resolution: GridResolution::Auto {
            density: 4.0,
            max_per_axis: 256,
        },
    }
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
