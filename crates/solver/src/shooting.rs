//! Progressive refinement without a stored matrix: each shooter's row is asked for when
//! it shoots (and kept while a byte budget allows), shooters taken in batches of the
//! largest unshot power, so that rows can be made in parallel and the answer does not
//! depend on the thread count.

use crate::solve::{SolveConfig, SolveReport, Solver, Surfaces};
use crate::{Error, Solution};
use rad_core::PatchId;
use std::collections::HashMap;

/// One shooter's row as its source gives it: `F_ij` (rounded to `f32`, as the stored
/// matrix holds them), columns increasing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShotRow {
    pub columns: Vec<PatchId>,
    pub values: Vec<f32>,
}

impl ShotRow {
    /// Bytes it takes in the cache.
    fn bytes(&self) -> usize {
        self.columns.len() * 8 + 64
    }
}

/// How matrix-free shooting runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatrixFreeConfig {
    /// Stop once the largest unshot radiosity is at most `tolerance` times the largest
    /// radiosity; `max_iterations` caps the shots.
    pub solve: SolveConfig,
    /// Shooters taken at a time (their rows made together). Fixed, so that the answer
    /// does not depend on the thread count; 1 is classical progressive refinement.
    pub batch: usize,
    /// Bytes of rows kept for shooters that shoot again.
    pub cache_bytes: usize,
}

/// What a matrix-free run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MatrixFreeStats {
    pub shots: usize,
    /// Rows asked of the source (shots whose row was not in the cache).
    pub rows_made: usize,
    /// Rows held in the cache at the end, and their bytes.
    pub cached_rows: usize,
    pub cached_bytes: usize,
    /// `Σ A_i E_i`, power absorbed, escaped (and met from behind), and still unshot, per
    /// channel: emitted = absorbed + escaped + unshot, by construction, to rounding.
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub escaped: [f64; 3],
    pub unshot: [f64; 3],
    /// `max_c |emitted − absorbed − escaped − unshot| / emitted` over emitting channels.
    pub relative_imbalance: f64,
}

/// Shoots to convergence without a matrix: the batch of patches of largest unshot power
/// `A_i Σ_c ΔB_{i,c}` (ties to the lower index) have their rows made by `rows` (those
/// not cached), then shoot one after the other in that order, each its unshot
/// radiosity at that moment, giving each `j` in its row `ρ_j F_ij ΔB_i A_i / A_j`
/// (`F_ji` by reciprocity: the power that leaves `i` towards `j` arrives there, so
/// energy is conserved whatever the rows' reciprocity error). `progress(shots, unshot)`
/// after each batch, with the unshot share of the emitted power.
///
/// The report's residual is the stopping measure, the largest unshot radiosity over the
/// largest radiosity (computing the true residual would need every row).
pub fn shoot_matrix_free<E: From<Error>>(
    surfaces: &Surfaces,
    config: &MatrixFreeConfig,
    rows: &mut dyn FnMut(&[PatchId]) -> Result<Vec<ShotRow>, E>,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<(Solution, MatrixFreeStats), E> {
    let n = surfaces.area.len();
    surfaces.validate(n)?;
    config.solve.validate()?;
    if config.batch == 0 {
        return Err(Error::BadConfig {
            what: "batch",
            value: 0.0,
            rule: "must be at least 1",
        }
        .into());
    }
    let (area, rho) = (&surfaces.area, &surfaces.reflectance);
    let mut b = surfaces.emission.clone();
    let mut unshot = surfaces.emission.clone();
    let mut power: Vec<f64> = (0..n)
        .map(|i| area[i] * unshot[i].iter().sum::<f64>())
        .collect();
    let mut stats = MatrixFreeStats::default();
    for i in 0..n {
        for c in 0..3 {
            stats.emitted[c] += area[i] * surfaces.emission[i][c];
        }
    }
    let total: f64 = stats.emitted.iter().sum();
    let mut cache: HashMap<PatchId, ShotRow> = HashMap::new();
    let mut order: Vec<usize> = (0..n).collect();
    let mut measure;
    loop {
        let max_b = b.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        let max_unshot = unshot.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        measure = if max_b > 0.0 { max_unshot / max_b } else { 0.0 };
        if measure <= config.solve.tolerance || stats.shots >= config.solve.max_iterations {
            break;
        }
        // The batch: largest power first, ties to the lower index.
        let k = config
            .batch
            .min(n)
            .min(config.solve.max_iterations - stats.shots);
        let key = |&i: &usize| (std::cmp::Reverse(OrdF64(power[i])), i);
        if k < n {
            order.select_nth_unstable_by_key(k, key);
        }
        let mut batch: Vec<usize> = order[..k]
            .iter()
            .copied()
            .filter(|&i| power[i] > 0.0)
            .collect();
        batch.sort_by_key(key);
        let missing: Vec<PatchId> = batch
            .iter()
            .map(|&i| i as PatchId)
            .filter(|i| !cache.contains_key(i))
            .collect();
        let made = rows(&missing)?;
        stats.rows_made += made.len();
        let mut fresh: HashMap<PatchId, ShotRow> = missing.into_iter().zip(made).collect();
        for &i in &batch {
            let id = i as PatchId;
            let row = cache
                .get(&id)
                .or_else(|| fresh.get(&id))
                .expect("made above");
            shoot_one(
                i,
                row,
                surfaces,
                &mut b,
                &mut unshot,
                &mut power,
                &mut stats,
            );
        }
        for (id, row) in fresh.drain() {
            if stats.cached_bytes + row.bytes() <= config.cache_bytes {
                stats.cached_bytes += row.bytes();
                cache.insert(id, row);
            }
        }
        let left: f64 = power.iter().sum();
        progress(stats.shots, if total > 0.0 { left / total } else { 0.0 });
    }
    stats.cached_rows = cache.len();
    for i in 0..n {
        for c in 0..3 {
            stats.unshot[c] += area[i] * unshot[i][c];
        }
    }
    stats.relative_imbalance = (0..3)
        .filter(|&c| stats.emitted[c] > 0.0)
        .map(|c| {
            (stats.emitted[c] - stats.absorbed[c] - stats.escaped[c] - stats.unshot[c]).abs()
                / stats.emitted[c]
        })
        .fold(0.0, f64::max);
    let ambient = crate::solve::ambient_term(area, rho, &unshot);
    Ok((
        Solution {
            radiosity: b,
            ambient,
            report: SolveReport {
                solver: Solver::Progressive,
                iterations: stats.shots,
                residual: measure,
                converged: measure <= config.solve.tolerance,
            },
        },
        stats,
    ))
}

/// Patch `i` shoots its unshot radiosity along `row`.
fn shoot_one(
    i: usize,
    row: &ShotRow,
    surfaces: &Surfaces,
    b: &mut [[f64; 3]],
    unshot: &mut [[f64; 3]],
    power: &mut [f64],
    stats: &mut MatrixFreeStats,
) {
    let (area, rho) = (&surfaces.area, &surfaces.reflectance);
    let shot = unshot[i];
    unshot[i] = [0.0; 3];
    power[i] = 0.0;
    stats.shots += 1;
    let mut sum = 0.0;
    for (&j, &f) in row.columns.iter().zip(&row.values) {
        let j = j as usize;
        let f = f as f64;
        sum += f;
        let k = f * area[i] / area[j];
        let mut add_power = 0.0;
        for c in 0..3 {
            let arriving = k * shot[c];
            let d = rho[j][c] * arriving;
            stats.absorbed[c] += area[j] * (arriving - d);
            b[j][c] += d;
            unshot[j][c] += d;
            add_power += d;
        }
        power[j] += area[j] * add_power;
    }
    for c in 0..3 {
        stats.escaped[c] += area[i] * shot[c] * (1.0 - sum);
    }
}

/// `f64` ordered by `total_cmp` (powers are finite and >= 0).
#[derive(Clone, Copy, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}
