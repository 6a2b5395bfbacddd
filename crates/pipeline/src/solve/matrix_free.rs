//! The matrix-free way: progressive refinement making each shooter's (exact) row when it
//! shoots, keeping rows while the memory limit allows. Shared among processes, every
//! process runs the same shooting and makes its share of each batch's rows.

use super::config::{solve_key, Progress, SceneSolveConfig, Storage};
use super::config::{MATRIX_FREE_BATCH, MATRIX_FREE_OVERSHOOT};
use super::solution::{check_finite, solution_file, surfaces, Answer, Solved};
use super::storage::matrix_free_floor;
use crate::share::{shared_rows, Peers, SharedRun};
use crate::{rows_with_caster, CasterJob, Error, RowMethod, Rows, SceneFile};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Caster, Hemisphere};
use rad_solver::{
    shoot_matrix_free, MatrixFreeConfig, MatrixFreeStats, ShotRow, Solution, Surfaces,
};
use std::time::Instant;

/// Solves `scene` matrix-free: `None` on the processes but the first.
pub(crate) fn solve_matrix_free(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<Answer, Error> {
    let t = Instant::now();
    let surfaces = surfaces(&scene.scene);
    let (solution, m) = shoot(scene, hemi, method, &surfaces, opts, progress, peers)?;
    if peers.rank() > 0 {
        return Ok(None);
    }
    let seconds = t.elapsed().as_secs_f64();
    let solved = Solved::shot(Storage::MatrixFree, solution, m, seconds, 0);
    check_finite(&solved)?;
    let stats = EstimateStats {
        exact: m.rows_made,
        ..EstimateStats::default()
    };
    let file = solution_file(scene, hemi, method, opts, &solved, 0.0);
    Ok(Some((file, solved, stats)))
}

/// Matrix-free shooting of `scene`'s exact rows through `method`'s caster, rows kept in
/// what the memory limit leaves. Shared among `peers`, every process runs the same
/// shooting and each batch's rows are made in shares ([`crate::share::shared_rows`]) and
/// gathered by every process: the same shots, to the bit, whatever their number.
fn shoot(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    surfaces: &Surfaces,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<(Solution, MatrixFreeStats), Error> {
    if !method.is_exact() {
        return Err(Error::Parse {
            what: "method",
            input: method.name(),
            reason: "matrix-free solving casts each shooter's row exactly: use --method exact"
                .into(),
        });
    }
    struct Job<'a> {
        scene: &'a SceneFile,
        hemi: &'a Hemisphere,
        method: RowMethod,
        surfaces: &'a Surfaces,
        config: MatrixFreeConfig,
        progress: &'a (dyn Fn(Progress) + Sync),
        peers: &'a dyn Peers,
        key: String,
    }
    impl CasterJob for Job<'_> {
        type Out = (Solution, MatrixFreeStats);
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Self::Out, Error> {
            let mut make = |ids: &[PatchId]| -> Result<Rows, Error> {
                let rows = compute_rows(scene, caster, self.hemi, ids, &|_| {})?;
                Ok(Rows {
                    method: self.method,
                    sources: vec![None; rows.len()],
                    stats: EstimateStats {
                        exact: rows.len(),
                        ..EstimateStats::default()
                    },
                    rows,
                })
            };
            let mut rows = |ids: &[PatchId], _: &mut Vec<ShotRow>| -> Result<Vec<ShotRow>, Error> {
                let made = if self.peers.size() == 1 {
                    make(ids)?
                } else {
                    let run = SharedRun {
                        scene,
                        scene_hash: self.scene.hash,
                        method: self.method,
                        what: self.key.as_bytes(),
                    };
                    shared_rows(run, ids, self.peers, true, &mut make)?
                        .rows
                        .expect("gathered by every process")
                };
                Ok(made.rows.into_iter().map(shot_row).collect())
            };
            let mut progress = |p| (self.progress)(Progress::of(p));
            // (The rows' sums first, by a pass of rows: kept while the limit allows.)
            shoot_matrix_free(self.surfaces, &self.config, None, &mut rows, &mut progress)
        }
    }
    let n = scene.scene.patches().len();
    let cache_bytes = (opts.memory_limit as f64 - matrix_free_floor(n, 0.0)).max(0.0) as usize;
    rows_with_caster(
        &scene.scene,
        method.caster(),
        Job {
            scene,
            hemi,
            method,
            surfaces,
            config: MatrixFreeConfig {
                solve: opts.matrix_free,
                batch: MATRIX_FREE_BATCH,
                overshoot: MATRIX_FREE_OVERSHOOT,
                cache_bytes,
            },
            progress,
            peers,
            key: solve_key(hemi, method, opts),
        },
    )
}

/// A row as shooting takes it: values rounded to `f32`, as the stored matrix holds them
/// (non-finite values are refused where rows are made).
fn shot_row(r: rad_hemisphere::Row) -> ShotRow {
    ShotRow {
        columns: r.entries.iter().map(|e| e.0).collect(),
        values: r.entries.iter().map(|e| e.1 as f32).collect(),
    }
}
