//! From a scene to its radiosities: one entry ([`solve_scene_shared`]) that checks the
//! settings, chooses how to hold the form factors ([`storage::choose`]) and hands the
//! solve to one way of solving, each in a module of its own that does not call back:
//! stored ([`stored`]), by rows under Jacobi sweeps ([`by_rows`]), out of core
//! ([`out_of_core`]) or matrix-free ([`matrix_free`]); over a motion, step by step
//! ([`motion`]). What they share lives below them:
//! the settings and constants ([`config`]), the solve's answer and its file
//! ([`solution`]).

mod by_rows;
mod config;
mod matrix_free;
mod motion;
mod out_of_core;
mod solution;
mod storage;
mod stored;

pub use config::{
    Progress, SceneSolveConfig, Storage, DEFAULT_MEMORY_LIMIT, MATRIX_FREE_BATCH,
    MATRIX_FREE_OVERSHOOT, MATRIX_FREE_TOLERANCE,
};
pub use motion::{check_motion_solve, solve_over_motion, StepSolution};
pub use out_of_core::OutOfCoreStats;
pub use solution::{
    read_solution, surfaces, EnergyJson, MatrixJson, ReciprocityJson, SolutionFile, Solved,
    SolverJson, Timings,
};
pub use storage::{check_by_rows, choose};
pub use stored::{solve, solve_pairs, solve_pairs_from};

use crate::share::{Alone, Peers};
use crate::{Error, RowMethod, SceneFile};
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;
use rad_solver::Solver;

/// Every row of `scene` by `method`, made reciprocal unless told otherwise, solved:
/// the solution file, the solve (its reciprocity and energy balance) and the rows'
/// counts, by one process ([`solve_scene_shared`] alone).
pub fn solve_scene(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(SolutionFile, Solved, EstimateStats), Error> {
    let solved = solve_scene_shared(scene, hemi, method, opts, progress, &Alone)?;
    Ok(solved.expect("one process solves"))
}

/// What a method [`RowMethod::auto_for`] picked becomes for a solve with `opts` among
/// `processes` processes: estimated rows stay where a storage that takes them (stored,
/// out of core) is asked for, or fits the limit and the temporary folder; where
/// matrix-free solving is asked for, or is the only storage that fits, the rows are made
/// exactly (matrix-free solving casts each shooter's row), by the estimate's caster.
/// Returns the method and whether it changed (exact methods never do).
pub fn settle_auto(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    processes: usize,
) -> Result<(RowMethod, bool), Error> {
    let RowMethod::Estimated { centres, .. } = method else {
        return Ok((method, false));
    };
    let exact = RowMethod::Exact { caster: centres };
    match opts.storage {
        Some(Storage::MatrixFree) => Ok((exact, true)),
        Some(_) => Ok((method, false)),
        None if opts.solver == Solver::Jacobi => Ok((method, false)),
        None => {
            let temp = (processes == 1).then(|| opts.temp_dir());
            let (limit, temp) = (opts.memory_limit, temp.as_deref());
            if choose(scene, hemi, method, limit, temp).is_ok() {
                return Ok((method, false));
            }
            Ok(match choose(scene, hemi, exact, limit, temp) {
                Ok(_) => (exact, true),
                Err(_) => (method, false),
            })
        }
    }
}

/// [`solve_scene`] shared among `peers` (MPI ranks, say), the same solution to the bit
/// whatever their number: stored, each makes its share of the rows ([`crate::share`]),
/// gathered on the first, which solves; matrix-free, every process runs the same
/// shooting, each making its share of every batch's rows, which all of them gather.
/// `None` on the processes but the first.
pub fn solve_scene_shared(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<Option<(SolutionFile, Solved, EstimateStats)>, Error> {
    let storage = storage_of(scene, hemi, method, opts, peers.size())?;
    match (opts.solver, storage) {
        (Solver::Jacobi, Storage::Stored) => {
            by_rows::solve_by_rows(scene, hemi, method, opts, progress, peers)
        }
        (Solver::Jacobi, _) => Err(Error::Parse {
            what: "solver",
            input: "jacobi".into(),
            reason: "sweeps stored rows (--storage stored); matrix-free and out-of-core \
                     solving shoot, by progressive refinement"
                .into(),
        }),
        (_, Storage::Stored) => stored::solve_stored(scene, hemi, method, opts, progress, peers),
        (_, Storage::MatrixFree) => {
            matrix_free::solve_matrix_free(scene, hemi, method, opts, progress, peers)
        }
        (_, Storage::OutOfCore) => {
            out_of_core::solve_out_of_core(scene, hemi, method, opts, progress, peers)
        }
    }
}

/// How a solve by `opts` among `processes` holds its form factors: as asked, else as
/// [`choose`] finds (by rows under Jacobi sweeps: each process's share checked against
/// the limit); refuses raw rows under progressive refinement.
fn storage_of(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    processes: usize,
) -> Result<Storage, Error> {
    if !opts.reciprocal && opts.solver == Solver::Progressive {
        return Err(Error::Parse {
            what: "solver",
            input: "progressive".into(),
            reason: "cannot converge on raw rows: shooting takes F_ji from F_ij by \
                     reciprocity, which raw rows hold only to their discretisation error; \
                     use Gauss-Seidel, or reciprocal rows"
                .into(),
        });
    }
    let limit = opts.memory_limit;
    Ok(match opts.storage {
        Some(s) => s,
        // (Its rows are shared by rows: each process's share must fit the limit.)
        None if opts.solver == Solver::Jacobi => {
            check_by_rows(&scene.scene, hemi, method, limit, processes)?;
            Storage::Stored
        }
        None => {
            // (Out of core is one process's: its rows go to its own disk.)
            let temp = (processes == 1).then(|| opts.temp_dir());
            choose(&scene.scene, hemi, method, limit, temp.as_deref())?
        }
    })
}
