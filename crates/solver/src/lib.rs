//! Radiosity over a sparse form-factor matrix.
//!
//! [`FormFactors`] holds rows in CSR form (`f32` values, `f64` sums). Hemisphere rows
//! are point-to-patch estimates, so `A_i F_ij` and `A_j F_ji` differ by the
//! discretisation error and energy is conserved only to that error;
//! [`FormFactors::reciprocal`] returns the nearest matrix (in the sense of a symmetric
//! diagonal scaling) that is exactly reciprocal and keeps every row's sum, which is what
//! the solvers are meant to run on. [`gauss_seidel`] gathers, [`progressive`] shoots in
//! order of unshot power; both stop on the same residual and reach the same solution.
//! Non-convergence is data ([`SolveReport::converged`]), not an error.
//!
//! - `enclosure`: [`SurfaceMatrix`], surface-to-surface factors under an [`Enclosure`] rule,
//!   and script-F.
//! - `matrix`: [`FormFactors`], the CSR matrix.
//! - `operator`: the [`Operator`] trait, what the solvers need of any storage.
//! - `pairs`: [`PairMatrix`] (`F ∪ Fᵀ` stored once, built by [`PairBuilder`]) and
//!   [`FormFactors::reciprocal`].
//! - `rowset`: [`RowSet`], one process's rows of a solve shared by rows.
//! - `scaling`: [`reciprocal_scaling`] (Newton-CG) and what it changed ([`Reciprocity`]).
//! - `shooting`: [`shoot_matrix_free`], progressive refinement asking for rows as it shoots.
//! - `solve`: [`gauss_seidel`], [`progressive`], [`jacobi`], the residual, the energy balance.
//! - `surfaces`: [`Surfaces`] (area, emission, reflectance of each patch) and their checks.

mod enclosure;
mod matrix;
mod operator;
mod pairs;
mod rowset;
mod scaling;
mod shooting;
mod solve;
mod surfaces;

pub use enclosure::{
    Enclosure, EnclosureErrors, EnclosureReport, ErrorQuantiles, SurfaceMatrix, LEAK_TOLERANCE,
    MAX_SCRIPT_F,
};
pub use matrix::FormFactors;
pub use operator::Operator;
pub use pairs::{median_bin, PairBuilder, PairMatrix};
pub use rowset::RowSet;
pub use scaling::{reciprocal_scaling, Reciprocity};
pub use shooting::{
    shoot_matrix_free, MatrixFreeConfig, MatrixFreeStats, RowSums, ShootProgress, ShotRow,
};
pub use solve::{
    energy_balance, energy_balance_from, gauss_seidel, gauss_seidel_from, jacobi, jacobi_with,
    progressive, residual, residual_from, EnergyBalance, Solution, SolveConfig, SolveReport,
    Solver,
};
pub use surfaces::Surfaces;

use rad_core::PatchId;

/// Invalid inputs to the solver.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("no row for patch {patch} (the matrix needs one row per patch, 0..{n_patches})")]
    MissingRow { patch: PatchId, n_patches: usize },
    #[error("two rows for patch {patch}")]
    DuplicateRow { patch: PatchId },
    #[error("row of patch {row} names patch {column}, but there are {n_patches} patches")]
    EntryOutOfRange {
        row: PatchId,
        column: PatchId,
        n_patches: usize,
    },
    #[error(
        "row of patch {row}: form factor to patch {column} is {value}, not a finite value >= 0"
    )]
    BadValue {
        row: PatchId,
        column: PatchId,
        value: f64,
    },
    #[error("row of patch {row} sums to {sum}, more than 1")]
    RowSumAboveOne { row: PatchId, sum: f64 },
    #[error("{what} has {len} entries but the matrix has {n_patches} patches")]
    LengthMismatch {
        what: &'static str,
        len: usize,
        n_patches: usize,
    },
    #[error("patch {patch}: {what} {value:?} is invalid ({rule})")]
    BadSurface {
        patch: PatchId,
        what: &'static str,
        value: [f64; 3],
        rule: &'static str,
    },
    #[error("{count} rows leak, so the scene is no closed enclosure (over {tolerance} of a row's rays escape the scene); the first (row, what its factors and blocked rays sum to): {first:?}; use --enclosure reciprocal or raw, or close the scene")]
    Leaks {
        count: usize,
        first: Vec<(u32, f64)>,
        tolerance: f64,
    },
    #[error("surface {surface} sees nothing (its row is empty) but surface {seen_by} sees it: no reciprocal matrix keeps the empty row; look for a surface facing away from the scene, or use --enclosure raw")]
    SeenButBlind { surface: u32, seen_by: u32 },
    #[error("the exchange system is singular at surface {surface} (no script-F: is a surface perfectly reflecting, and do the surfaces see each other?)")]
    SingularExchange { surface: u32 },
    #[error("no reciprocal scaling found after {iterations} iterations (the pattern of the form factors admits no symmetric matrix with these row sums)")]
    NoReciprocalScaling { iterations: usize },
    #[error("rows held in parts: {reason}")]
    RowSet { reason: String },
    #[error("solver setting {what} = {value} is invalid ({rule})")]
    BadConfig {
        what: &'static str,
        value: f64,
        rule: &'static str,
    },
}
