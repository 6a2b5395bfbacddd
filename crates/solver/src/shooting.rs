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
    /// Bytes it takes in the cache (its storage, which a source that reuses rows may
    /// have made larger than its entries need).
    fn bytes(&self) -> usize {
        self.columns.capacity() * 4 + self.values.capacity() * 4 + 64
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
/// not cached; `rows` may take its rows' storage from the spare rows it is handed, rows
/// shot and not kept, rather than allocate afresh), then shoot one after the other in that order, each its unshot
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
    rows: &mut dyn FnMut(&[PatchId], &mut Vec<ShotRow>) -> Result<Vec<ShotRow>, E>,
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
    let mut shades: Vec<Shade> = (0..n)
        .map(|i| Shade {
            b: surfaces.emission[i],
            unshot: surfaces.emission[i],
            rho: rho[i],
            area: area[i],
            power: area[i] * surfaces.emission[i].iter().sum::<f64>(),
        })
        .collect();
    let mut stats = MatrixFreeStats::default();
    for i in 0..n {
        for c in 0..3 {
            stats.emitted[c] += area[i] * surfaces.emission[i][c];
        }
    }
    let total: f64 = stats.emitted.iter().sum();
    let mut cache: HashMap<PatchId, ShotRow> = HashMap::new();
    let mut spare: Vec<ShotRow> = Vec::new();
    let mut order: Vec<usize> = (0..n).collect();
    let mut measure;
    let mut sweep = Sweep::of(&shades);
    loop {
        measure = if sweep.max_b > 0.0 {
            sweep.max_unshot / sweep.max_b
        } else {
            0.0
        };
        if measure <= config.solve.tolerance || stats.shots >= config.solve.max_iterations {
            break;
        }
        let k = config
            .batch
            .min(n)
            .min(config.solve.max_iterations - stats.shots);
        let batch = next_batch(&mut order, &shades, k);
        let missing: Vec<PatchId> = batch
            .iter()
            .map(|&i| i as PatchId)
            .filter(|i| !cache.contains_key(i))
            .collect();
        let made = rows(&missing, &mut spare)?;
        if made.len() != missing.len() {
            return Err(Error::RowSet {
                reason: format!(
                    "{} rows asked of the source to shoot, {} given",
                    missing.len(),
                    made.len()
                ),
            }
            .into());
        }
        stats.rows_made += made.len();
        let mut fresh: HashMap<PatchId, ShotRow> = missing.iter().copied().zip(made).collect();
        for &i in &batch {
            let id = i as PatchId;
            let row = cache
                .get(&id)
                .or_else(|| fresh.get(&id))
                .expect("made above");
            shoot_one(i, row, &mut shades, &mut stats)?;
        }
        // (Kept in the batch's order, so that the rows asked for later, and so those a
        // run shared among processes asks for, do not depend on a map's order.)
        for id in missing {
            let row = fresh.remove(&id).expect("made above");
            if stats.cached_bytes + row.bytes() <= config.cache_bytes {
                stats.cached_bytes += row.bytes();
                cache.insert(id, row);
            } else if spare.len() < config.batch {
                spare.push(row);
            }
        }
        sweep = Sweep::of(&shades);
        progress(
            stats.shots,
            if total > 0.0 {
                sweep.power / total
            } else {
                0.0
            },
        );
    }
    stats.cached_rows = cache.len();
    close_accounts(&mut stats, &shades);
    let b: Vec<[f64; 3]> = shades.iter().map(|s| s.b).collect();
    let unshot: Vec<[f64; 3]> = shades.iter().map(|s| s.unshot).collect();
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

/// Entries a part of a shot takes: a shooter's row is cut into parts of this many
/// entries, shot in parallel (each part's patches are its own: the columns increase);
/// fixed, so that the energy sums, added part by part in order, do not depend on the
/// thread count.
const SHOT_PART: usize = 4096;
/// Parts a shot has at least to be shot in parallel.
const PARALLEL_PARTS: usize = 4;

/// The power left unshot, and the relative imbalance of the energy accounts.
fn close_accounts(stats: &mut MatrixFreeStats, shades: &[Shade]) {
    for s in shades {
        for c in 0..3 {
            stats.unshot[c] += s.area * s.unshot[c];
        }
    }
    stats.relative_imbalance = (0..3)
        .filter(|&c| stats.emitted[c] > 0.0)
        .map(|c| {
            (stats.emitted[c] - stats.absorbed[c] - stats.escaped[c] - stats.unshot[c]).abs()
                / stats.emitted[c]
        })
        .fold(0.0, f64::max);
}

/// The next `k` shooters (those with unshot power): largest power first, ties to the
/// lower index.
fn next_batch(order: &mut [usize], shades: &[Shade], k: usize) -> Vec<usize> {
    let key = |&i: &usize| (std::cmp::Reverse(OrdF64(shades[i].power)), i);
    if k < order.len() {
        order.select_nth_unstable_by_key(k, key);
    }
    let mut batch: Vec<usize> = order[..k]
        .iter()
        .copied()
        .filter(|&i| shades[i].power > 0.0)
        .collect();
    batch.sort_by_key(key);
    batch
}

/// A patch as shooting reads and updates it, in one place (two cache lines at most: a
/// shot touches one patch per entry of its row, scattered over the scene).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Shade {
    b: [f64; 3],
    unshot: [f64; 3],
    rho: [f64; 3],
    area: f64,
    /// `A Σ_c ΔB_c`.
    power: f64,
}

/// What a pass over the patches finds after a batch: the largest radiosity and unshot
/// radiosity (the stopping measure), and the unshot power (summed in patch order).
struct Sweep {
    max_b: f64,
    max_unshot: f64,
    power: f64,
}

impl Sweep {
    fn of(shades: &[Shade]) -> Sweep {
        let mut s = Sweep {
            max_b: 0.0,
            max_unshot: 0.0,
            power: 0.0,
        };
        for p in shades {
            for c in 0..3 {
                s.max_b = s.max_b.max(p.b[c]);
                s.max_unshot = s.max_unshot.max(p.unshot[c]);
            }
            s.power += p.power;
        }
        s
    }
}

/// Patch `i` shoots its unshot radiosity along `row` (checked: columns increasing and
/// below the patch count, one value each).
fn shoot_one(
    i: usize,
    row: &ShotRow,
    shades: &mut [Shade],
    stats: &mut MatrixFreeStats,
) -> Result<(), Error> {
    use rayon::prelude::*;
    let n = shades.len();
    let columns = &row.columns;
    let increasing = columns.windows(2).all(|w| w[0] < w[1]);
    // (Increasing, the last column is the largest.)
    let last = if increasing {
        columns.last()
    } else {
        columns.iter().max()
    };
    if let Some(&bad) = last.filter(|&&j| j as usize >= n) {
        return Err(Error::EntryOutOfRange {
            row: i as PatchId,
            column: bad,
            n_patches: n,
        });
    }
    if !increasing || row.values.len() != columns.len() {
        return Err(Error::RowSet {
            reason: format!(
                "the row of patch {i} to shoot has {} columns{} and {} values",
                columns.len(),
                if increasing { "" } else { " not increasing" },
                row.values.len()
            ),
        });
    }
    let shot = shades[i].unshot;
    shades[i].unshot = [0.0; 3];
    shades[i].power = 0.0;
    stats.shots += 1;
    let area_i = shades[i].area;
    // Each part with the patches from its first column to the next part's first.
    let m = columns.len();
    let mut parts = Vec::with_capacity(m.div_ceil(SHOT_PART));
    let mut rest = shades;
    let mut base = 0usize;
    for start in (0..m).step_by(SHOT_PART) {
        let end = (start + SHOT_PART).min(m);
        let split = if end < m { columns[end] as usize } else { n };
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(split - base);
        parts.push((start..end, base, head));
        (rest, base) = (tail, split);
    }
    let shoot = |(range, base, shades): (std::ops::Range<usize>, usize, &mut [Shade])| {
        let mut absorbed = [0.0f64; 3];
        let mut sum = 0.0;
        for k in range {
            let j = columns[k] as usize;
            let f = row.values[k] as f64;
            sum += f;
            let p = &mut shades[j - base];
            let kf = f * area_i / p.area;
            let mut add_power = 0.0;
            for c in 0..3 {
                let arriving = kf * shot[c];
                let d = p.rho[c] * arriving;
                absorbed[c] += p.area * (arriving - d);
                p.b[c] += d;
                p.unshot[c] += d;
                add_power += d;
            }
            p.power += p.area * add_power;
        }
        (absorbed, sum)
    };
    // (In parallel only when there is enough to share: waking a thread for a short row
    // costs more than it saves. The sums are the same either way.)
    let sums: Vec<([f64; 3], f64)> = if parts.len() >= PARALLEL_PARTS {
        parts.into_par_iter().map(shoot).collect()
    } else {
        parts.into_iter().map(shoot).collect()
    };
    let mut sum = 0.0;
    for (absorbed, part_sum) in sums {
        for c in 0..3 {
            stats.absorbed[c] += absorbed[c];
        }
        sum += part_sum;
    }
    for c in 0..3 {
        stats.escaped[c] += area_i * shot[c] * (1.0 - sum);
    }
    Ok(())
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
