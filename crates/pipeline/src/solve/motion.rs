//! Radiosity over a motion ([`rad_geometry::Motion`]): each step's exact rows made from
//! the step before's item buffers ([`crate::moving`]: only what may change is cast
//! again; the rows a whole computation of the step gives, to the bit), stored by pairs,
//! made reciprocal as a stored solve makes them, and solved by Gauss-Seidel from the
//! step before's radiosities (a warm start: the same answer within the tolerance, in
//! fewer sweeps where the scene changed little).

use super::config::{SceneSolveConfig, Storage};
use super::solution::{check_finite, solution_file, surfaces, SolutionFile, Solved};
use super::storage::choose;
use super::stored::solve_pairs_from;
use crate::moving::{step_scene_file, MotionRows, StepRows};
use crate::{CasterKind, Error, Progress, RowMethod, SceneFile};
use rad_geometry::{Motion, Scene, SceneDesc};
use rad_hemisphere::{Hemisphere, RecastStats};
use rad_solver::{PairBuilder, Solver};
use std::time::Instant;

/// One step's solution, and what its rows cost.
#[derive(Clone, Debug)]
pub struct StepSolution {
    pub step: usize,
    pub name: String,
    /// The solution file (its `scene` names the step).
    pub file: SolutionFile,
    pub solved: Solved,
    pub recast: RecastStats,
    /// Polygons of the step that moved since the step before (all, for the first).
    pub moved_polygons: usize,
    /// Whether the solve started from the step before's radiosities.
    pub warm: bool,
}

/// Refuses what a solve over a motion cannot do: a storage other than stored (the
/// others make each row anew), progressive refinement on raw rows, and rows that would
/// not fit `opts.memory_limit` stored (judged, as `coherad solve` judges, from 64 sample
/// rows of the scene as written; a step also keeps its item buffers, up to
/// [`crate::viewfactors::MOTION_KEEP_BYTES`]).
pub fn check_motion_solve(
    scene: &Scene,
    hemi: &Hemisphere,
    caster: CasterKind,
    opts: &SceneSolveConfig,
) -> Result<(), Error> {
    if let Some(s) = opts.storage.filter(|&s| s != Storage::Stored) {
        return Err(Error::Parse {
            what: "storage",
            input: s.name().into(),
            reason: "a motion is solved with its rows stored (each step's rows come from \
                     the step before's); use --storage stored or auto"
                .into(),
        });
    }
    if !opts.reciprocal && opts.solver == Solver::Progressive {
        return Err(Error::Parse {
            what: "solver",
            input: "progressive".into(),
            reason: "cannot converge on raw rows; use Gauss-Seidel, or reciprocal rows".into(),
        });
    }
    let method = RowMethod::Exact { caster };
    if choose(scene, hemi, method, opts.memory_limit, None)? != Storage::Stored {
        return Err(Error::Parse {
            what: "memory limit",
            input: format!("{} bytes", opts.memory_limit),
            reason: "a step's rows, stored, would take more (a motion holds each step's rows \
                     in memory, and up to 1.5 GiB of item buffers besides); raise \
                     --memory-limit, or solve fewer patches"
                .into(),
        });
    }
    Ok(())
}

/// Every step of `motion` over `scene` (loaded from `desc`) solved in order, each
/// handed to `each` as it is made (so that a caller may write it before the next is
/// begun). The rows are exact, by `caster` where a patch is cast whole, stored (the
/// other storages are refused: they make each row anew); Gauss-Seidel starts each step
/// after the first from the step before's radiosities. `progress(step, p)` follows the
/// rows of each step.
pub fn solve_over_motion(
    (scene, desc): (&SceneFile, &SceneDesc),
    motion: &Motion,
    hemi: &Hemisphere,
    caster: CasterKind,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(usize, Progress) + Sync),
    each: &mut dyn FnMut(StepSolution) -> Result<(), Error>,
) -> Result<(), Error> {
    check_motion_solve(&scene.scene, hemi, caster, opts)?;
    let mut steps = MotionRows::new(desc, &scene.scene, motion)?;
    let unit = motion.unit(desc);
    let method = RowMethod::Exact { caster };
    let mut start: Option<Vec<[f64; 3]>> = None;
    for k in 0..motion.steps.len() {
        let t = Instant::now();
        let file_scene = step_scene_file((scene, desc), motion, unit, k)?;
        let step_scene = &file_scene.scene;
        let n = step_scene.patches().len();
        let all: Vec<u32> = (0..n as u32).collect();
        let rows_progress = |p: usize| progress(k, Progress::Rows(p));
        let StepRows {
            rows,
            recast,
            moved_polygons,
        } = steps.rows(step_scene, caster, hemi, 1, &all, &rows_progress)?;
        let mut builder = PairBuilder::new(n);
        for r in rows {
            builder.push_row(r.patch, &r.entries)?;
        }
        let raw = builder.finish()?;
        let form_factors_seconds = t.elapsed().as_secs_f64();
        let warm = opts.solver == Solver::GaussSeidel && start.is_some();
        let first = if warm { start.take() } else { None };
        let solved = solve_pairs_from(&raw, &surfaces(step_scene), opts, first)?;
        drop(raw);
        check_finite(&solved)?;
        let file = solution_file(
            &file_scene,
            hemi,
            method,
            opts,
            &solved,
            form_factors_seconds,
        );
        start = Some(solved.solution.radiosity.clone());
        each(StepSolution {
            step: k,
            name: motion.steps[k].name.clone(),
            file,
            solved,
            recast,
            moved_polygons,
            warm,
        })?;
        steps.passed(file_scene.scene);
    }
    Ok(())
}
