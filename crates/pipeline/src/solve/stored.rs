//! The stored way: every row made once (by this process, or shared among processes and
//! gathered on the first), streamed into the pair storage, made reciprocal and solved
//! by Gauss-Seidel, progressive refinement or Jacobi sweeps.

use super::config::{solve_key, Progress, SceneSolveConfig, Storage};
use super::config::{SCALING_ITERATIONS, SCALING_TOLERANCE};
use super::solution::{check_finite, solution_file, surfaces, Answer, MatrixJson, Solved};
use crate::share::{shared_rows, Peers, SharedRun};
use crate::{Error, RowMethod, SceneFile};
use rad_core::PatchId;
use rad_hemisphere::Hemisphere;
use rad_solver::{
    energy_balance, gauss_seidel, gauss_seidel_from, jacobi, progressive, FormFactors, PairBuilder,
    PairMatrix, Solver, Surfaces,
};
use std::time::Instant;

/// Solves `ff` (rows as computed) for `surfaces`: [`solve_pairs`] on the same values.
pub fn solve(
    ff: &FormFactors,
    surfaces: &Surfaces,
    opts: &SceneSolveConfig,
) -> Result<Solved, Error> {
    solve_pairs(&PairMatrix::from_form_factors(ff), surfaces, opts)
}

/// Solves `ff` (rows as computed, stored by pairs) for `surfaces`.
pub fn solve_pairs(
    ff: &PairMatrix,
    surfaces: &Surfaces,
    opts: &SceneSolveConfig,
) -> Result<Solved, Error> {
    solve_pairs_from(ff, surfaces, opts, None)
}

/// [`solve_pairs`], Gauss-Seidel starting from the radiosities `start` where given (a
/// warm start; the other solvers start from the emission whatever is given).
pub fn solve_pairs_from(
    ff: &PairMatrix,
    surfaces: &Surfaces,
    opts: &SceneSolveConfig,
    start: Option<Vec<[f64; 3]>>,
) -> Result<Solved, Error> {
    let t = Instant::now();
    let (matrix, reciprocity) = if opts.reciprocal {
        let (m, r) = ff.reciprocal(&surfaces.area, SCALING_TOLERANCE, SCALING_ITERATIONS)?;
        (Some(m), Some(r))
    } else {
        (None, None)
    };
    let scaling_seconds = t.elapsed().as_secs_f64();
    let m = matrix.as_ref().unwrap_or(ff);
    let t = Instant::now();
    let solution = match opts.solver {
        Solver::GaussSeidel => match start {
            Some(b) => gauss_seidel_from(m, surfaces, &opts.config, b)?,
            None => gauss_seidel(m, surfaces, &opts.config)?,
        },
        Solver::Progressive => progressive(m, surfaces, &opts.config)?,
        Solver::Jacobi => jacobi(m, surfaces, &opts.config)?,
    };
    let solve_seconds = t.elapsed().as_secs_f64();
    let balance = energy_balance(m, surfaces, &solution.radiosity);
    let raw_balance = if matrix.is_some() {
        energy_balance(ff, surfaces, &solution.radiosity)
    } else {
        balance
    };
    Ok(Solved {
        solution,
        reciprocity,
        balance,
        raw_balance,
        scaling_seconds,
        solve_seconds,
        matrix: MatrixJson {
            storage: Storage::Stored.name(),
            rows_made: ff.n_patches(),
            cached_rows: 0,
            disk_bytes: 0,
            pairs: ff.n_pairs(),
            bytes: ff.pattern_bytes()
                + ff.heap_bytes()
                + matrix.as_ref().map_or(0, |m| m.heap_bytes()),
        },
    })
}

/// Every row of `scene` by `method`, made once and stored by pairs, solved: rows
/// streamed into the pair storage as they are made ([`crate::rows_streamed`]), never
/// held as rows; shared among `peers`, each makes its share ([`crate::share`]), gathered
/// on the first, which solves.
pub(crate) fn solve_stored(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<Answer, Error> {
    let t = Instant::now();
    let n = scene.scene.patches().len();
    let mut builder = PairBuilder::new(n);
    let rows_progress = |k| progress(Progress::Rows(k));
    let stats = if peers.size() == 1 {
        crate::rows_streamed(&scene.scene, hemi, method, &rows_progress, &mut |made| {
            for r in &made.rows {
                builder.push_row(r.patch, &r.entries)?;
            }
            Ok(())
        })?
    } else {
        let all: Vec<PatchId> = (0..n as PatchId).collect();
        let what = solve_key(hemi, method, opts);
        let run = SharedRun {
            scene: &scene.scene,
            scene_hash: scene.hash,
            method,
            what: what.as_bytes(),
        };
        let shared = shared_rows(run, &all, peers, false, &mut |ids| {
            crate::rows(&scene.scene, hemi, method, ids, &rows_progress)
        })?;
        let Some(made) = shared.rows else {
            return Ok(None);
        };
        // (Each row dropped once pushed.)
        for r in made.rows {
            builder.push_row(r.patch, &r.entries)?;
        }
        made.stats
    };
    let raw = builder.finish()?;
    let form_factors_seconds = t.elapsed().as_secs_f64();
    let solved = solve_pairs(&raw, &surfaces(&scene.scene), opts)?;
    drop(raw);
    check_finite(&solved)?;
    let file = solution_file(scene, hemi, method, opts, &solved, form_factors_seconds);
    Ok(Some((file, solved, stats)))
}
