//! The out-of-core way: every row (exact or estimated) made once and written compact to
//! an unnamed temporary file, then shot from there as matrix-free solving shoots. One
//! process only.

use super::config::{Progress, SceneSolveConfig, Storage};
use super::config::{MATRIX_FREE_BATCH, MATRIX_FREE_OVERSHOOT};
use super::solution::{check_finite, solution_file, surfaces, Answer, Solved};
use super::storage::BYTES_PER_PATCH;
use crate::row_file::RowFile;
use crate::share::Peers;
use crate::{Error, RowMethod, SceneFile};
use rad_core::PatchId;
use rad_estimator::EstimateStats;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;
use rad_solver::{
    shoot_matrix_free, MatrixFreeConfig, MatrixFreeStats, RowSums, ShotRow, Solution, Surfaces,
};
use rayon::prelude::*;

/// Solves `scene` out of core ([`write_and_shoot`]): one process only.
pub(crate) fn solve_out_of_core(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
    peers: &dyn Peers,
) -> Result<Answer, Error> {
    let storage = Storage::OutOfCore;
    if peers.size() > 1 {
        return Err(Error::Parse {
            what: "storage",
            input: storage.name().into(),
            reason: "out-of-core solving runs in one process (its rows go to that \
                     process's disk); shared among processes, use --storage stored or \
                     matrix-free"
                .into(),
        });
    }
    let surfaces = surfaces(&scene.scene);
    let (solution, m, stats, out) =
        write_and_shoot(&scene.scene, hemi, method, &surfaces, opts, progress)?;
    let solved = Solved::shot(storage, solution, m, out.shoot_seconds, out.file_bytes);
    check_finite(&solved)?;
    Ok(Some((
        solution_file(scene, hemi, method, opts, &solved, out.rows_seconds),
        solved,
        stats,
    )))
}

/// What out-of-core solving wrote and did.
#[derive(Clone, Copy, Debug, Default)]
pub struct OutOfCoreStats {
    /// The rows' file: its bytes and entries.
    pub file_bytes: u64,
    pub entries: u64,
    /// Seconds making and writing every row, then shooting.
    pub rows_seconds: f64,
    pub shoot_seconds: f64,
}

/// Out-of-core solving: every row of `scene` by `method` (exact or estimated) made once,
/// streamed ([`crate::rows_streamed`]) into an unnamed temporary file in `temp`, then
/// shot from there as matrix-free solving shoots ([`shoot_matrix_free`]: the same
/// batches, the same answer whatever the threads; with exact rows, matrix-free solving's
/// answer to the bit), rows kept in memory while the limit allows. The file is gone when
/// this returns, or when the process ends however it ends.
fn write_and_shoot(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    surfaces: &Surfaces,
    opts: &SceneSolveConfig,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(Solution, MatrixFreeStats, EstimateStats, OutOfCoreStats), Error> {
    let n = scene.patches().len();
    let t = std::time::Instant::now();
    let temp = opts.temp_dir();
    let mut file = RowFile::create_in(&temp, n)?;
    let rows_progress = |k| progress(Progress::Rows(k));
    // (The sums shooting needs, of the values as the file holds them, as the rows pass:
    // they come in patch order.)
    let mut sums = RowSums::new(n);
    let stats = crate::rows_streamed(scene, hemi, method, &rows_progress, &mut |made| {
        for r in &made.rows {
            file.push(r.patch, &r.entries)?;
            let area = surfaces.area[r.patch as usize];
            sums.add(r.patch, area, r.entries.iter().map(|&(j, f)| (j, f as f32)))?;
        }
        Ok(())
    })?;
    file.finish()?;
    let mut out = OutOfCoreStats {
        file_bytes: file.bytes(),
        entries: file.entries(),
        rows_seconds: t.elapsed().as_secs_f64(),
        ..OutOfCoreStats::default()
    };
    let t = std::time::Instant::now();
    let config = MatrixFreeConfig {
        solve: opts.matrix_free,
        batch: MATRIX_FREE_BATCH,
        overshoot: MATRIX_FREE_OVERSHOOT,
        cache_bytes: (opts.memory_limit as f64 - n as f64 * (BYTES_PER_PATCH + 12.0)).max(0.0)
            as usize,
    };
    let mut rows = |ids: &[PatchId], spare: &mut Vec<ShotRow>| -> Result<Vec<ShotRow>, Error> {
        // (Into the storage of rows shot and dropped: fresh storage costs its pages.)
        let reuse = spare.len().saturating_sub(ids.len());
        let mut into: Vec<ShotRow> = spare.drain(reuse..).collect();
        into.resize_with(ids.len(), ShotRow::default);
        ids.par_iter()
            .zip(into)
            .map(|(&p, mut row)| file.read_into(p, &mut row).map(|()| row))
            .collect()
    };
    let mut shots = |p| progress(Progress::of(p));
    let (solution, m) = shoot_matrix_free(surfaces, &config, Some(sums), &mut rows, &mut shots)?;
    out.shoot_seconds = t.elapsed().as_secs_f64();
    Ok((solution, m, stats, out))
}
