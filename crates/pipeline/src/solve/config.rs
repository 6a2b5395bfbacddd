//! How a scene is solved: the settings ([`SceneSolveConfig`]), the ways to hold the form
//! factors ([`Storage`]), what a long solve reports ([`Progress`]), and the constants
//! the ways of solving share.

use crate::RowMethod;
use rad_hemisphere::Hemisphere;
use rad_solver::{ShootProgress, SolveConfig, Solver};

/// The default of `--memory-limit`: 1.5 GiB for the form factors, so that a solve
/// (scene, caster and per-patch arrays on top) stays within 2 GiB on a 100k-patch mesh.
pub const DEFAULT_MEMORY_LIMIT: usize = 1536 << 20;

/// Shooters taken at a time by matrix-free solving (their rows made in parallel).
pub const MATRIX_FREE_BATCH: usize = 64;

/// How far matrix-free and out-of-core shooting overshoot
/// ([`rad_solver::MatrixFreeConfig::overshoot`]): on the loft at 180 × 720 (out of core,
/// exact rows, against a solve to 1e-7), 1.2 took 65,280 shots to the default tolerance
/// against 120,064 without overshooting, its radiosities nearer the converged ones
/// (mean relative difference 5.4e-4 against 7.0e-4); 1.1, 1.3 and 1.4 took 83,840,
/// 77,632 and 108,864.
pub const MATRIX_FREE_OVERSHOOT: f64 = 1.2;

/// How the form factors are held during a solve.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// Every row made once, streamed into the pair storage, made reciprocal, solved.
    Stored,
    /// No matrix: matrix-free progressive refinement (exact rows only).
    MatrixFree,
    /// Every row made once (exact or estimated) and written compact to an unnamed
    /// temporary file ([`crate::row_file::RowFile`]), then the matrix-free shooting read
    /// from there (rows kept in memory while the limit allows). One process only.
    OutOfCore,
}

impl Storage {
    pub fn name(self) -> &'static str {
        match self {
            Storage::Stored => "stored",
            Storage::MatrixFree => "matrix-free",
            Storage::OutOfCore => "out-of-core",
        }
    }
}

/// What a long solve reports as it goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Progress {
    /// Rows made so far (the stored path).
    Rows(usize),
    /// Shots so far and the share of the emitted power still unshot (matrix-free).
    Shots { shots: usize, unshot: f64 },
    /// Jacobi sweeps so far and the residual of the radiosities they reached.
    Sweeps { sweeps: usize, residual: f64 },
}

impl Progress {
    /// Shooting's report as a solve's.
    pub(crate) fn of(p: ShootProgress) -> Progress {
        match p {
            ShootProgress::Rows(k) => Progress::Rows(k),
            ShootProgress::Shots { shots, pending } => Progress::Shots {
                shots,
                unshot: pending,
            },
        }
    }
}

/// How to solve.
#[derive(Clone, Debug)]
pub struct SceneSolveConfig {
    pub solver: Solver,
    pub config: SolveConfig,
    /// Make the matrix reciprocal first ([`FormFactors::reciprocal`]); without it the
    /// energy balance holds only to the reciprocity error of the rows.
    pub reciprocal: bool,
    /// How to hold the form factors; `None`: by [`super::storage::choose`] within
    /// `memory_limit`.
    pub storage: Option<Storage>,
    /// Bytes the form factors may take (the stored matrix, or matrix-free solving's
    /// rows): [`DEFAULT_MEMORY_LIMIT`].
    pub memory_limit: usize,
    /// When matrix-free solving stops: the largest unshot radiosity over the largest
    /// radiosity at most `tolerance` ([`MATRIX_FREE_TOLERANCE`] by default), or
    /// `max_iterations` shots.
    pub matrix_free: SolveConfig,
    /// Where out-of-core solving writes its rows (an unnamed file, gone when the process
    /// ends); `None`: the system's temporary folder (`TMPDIR`, else `/tmp`).
    pub temp_dir: Option<std::path::PathBuf>,
}

impl SceneSolveConfig {
    /// The folder out-of-core solving writes to.
    pub fn temp_dir(&self) -> std::path::PathBuf {
        self.temp_dir.clone().unwrap_or_else(std::env::temp_dir)
    }
}

/// The default stopping point of matrix-free solving (its measure: the largest unshot
/// radiosity over the largest radiosity).
pub const MATRIX_FREE_TOLERANCE: f64 = 1e-4;

impl Default for SceneSolveConfig {
    fn default() -> Self {
        SceneSolveConfig {
            solver: Solver::GaussSeidel,
            config: SolveConfig::default(),
            reciprocal: true,
            storage: None,
            memory_limit: DEFAULT_MEMORY_LIMIT,
            matrix_free: SolveConfig {
                tolerance: MATRIX_FREE_TOLERANCE,
                ..SolveConfig::default()
            },
            temp_dir: None,
        }
    }
}

/// Tolerance and iteration cap of the reciprocal scaling.
pub(crate) const SCALING_TOLERANCE: f64 = 1e-9;
pub(crate) const SCALING_ITERATIONS: usize = 5_000;

/// What processes sharing a solve must agree on besides the scene (for
/// [`crate::share::run_fingerprint`]).
pub(crate) fn solve_key(hemi: &Hemisphere, method: RowMethod, opts: &SceneSolveConfig) -> String {
    format!(
        "solve {}x{} {} {opts:?}",
        hemi.n_theta(),
        hemi.n_phi(),
        method.name()
    )
}
