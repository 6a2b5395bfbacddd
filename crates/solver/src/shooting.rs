//! Progressive refinement without a stored matrix: each shooter's row is asked for when
//! it shoots (and kept while a byte budget allows), shooters taken in batches of the
//! largest pending power (by size: an overshot patch's is negative), so that rows can be
//! made in parallel and the answer does not depend on the thread count. Each shot
//! overshoots: it sends a little more than the patch's unshot radiosity, which the patch
//! owes back later (over-relaxation; 46 % fewer shots on the loft).
//!
//! Each row is used both ways ("halves"): the patch gathers through half of it, then
//! shoots through the other half by reciprocity. The system solved is then that of the
//! average `(F + A⁻¹FᵀA) / 2`, `A_i F_ij + A_j F_ji` shared equally, without ever
//! holding two rows at once. Shooting alone (`F_ji = F_ij A_i / A_j`) would solve
//! `A⁻¹FᵀA`, which on hemisphere rows differs from the stored solve by the whole
//! reciprocity error of small patches (1.4 % mean image difference on the loft at
//! 180 × 720, against 0.8 % for the average; see the README).
//!
//! The average alone does not conserve power: the power patch `j` sends is its column's
//! area-weighted sum, `(A_j r_j + c_j) / 2` a unit of radiosity (`r_j = Σ_i F_ji` its
//! row's sum, `c_j = Σ_i A_i F_ij` its column's), not `A_j r_j`, and on the loft that
//! made 0.7 % more light than was emitted. So each column is scaled by
//! `d_j = 2 A_j r_j / (A_j r_j + c_j)`: every patch sends exactly what its row says it
//! sees, and what escapes is exactly what the rows miss. That needs every row's sums
//! before the first shot ([`RowSums`]: a pass of the rows, or gathered as they are
//! written).

use crate::operator::add_scaled;
use crate::solve::{SolveConfig, SolveReport, Solver};
use crate::surfaces::Surfaces;
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

/// Every row's sum `r_i = Σ_j F_ij` and every column's area-weighted sum
/// `c_j = Σ_i A_i F_ij`, of the values as shooting reads them (`f32`), added row by row
/// in patch order, so that the same rows give the same bits however they are gathered.
#[derive(Clone, Debug, PartialEq)]
pub struct RowSums {
    row: Vec<f64>,
    column: Vec<f64>,
    next: usize,
}

impl RowSums {
    /// Sums of `n` patches' rows, none added yet.
    pub fn new(n: usize) -> RowSums {
        RowSums {
            row: vec![0.0; n],
            column: vec![0.0; n],
            next: 0,
        }
    }

    /// Adds the row of patch `i` (which must be the next, rows coming in patch order),
    /// of area `area_i`, its entries `(j, F_ij)` by increasing `j`.
    pub fn add(
        &mut self,
        i: PatchId,
        area_i: f64,
        entries: impl IntoIterator<Item = (PatchId, f32)>,
    ) -> Result<(), Error> {
        let n = self.row.len();
        if i as usize != self.next || self.next >= n {
            return Err(Error::RowSet {
                reason: format!(
                    "the row of patch {i} summed where patch {}'s was expected (rows in patch order, 0..{n})",
                    self.next
                ),
            });
        }
        let mut sum = 0.0;
        for (j, f) in entries {
            let Some(c) = self.column.get_mut(j as usize) else {
                return Err(Error::EntryOutOfRange {
                    row: i,
                    column: j,
                    n_patches: n,
                });
            };
            *c += area_i * f as f64;
            sum += f as f64;
        }
        self.row[i as usize] = sum;
        self.next += 1;
        Ok(())
    }

    /// Whether every row has been added.
    pub fn is_complete(&self) -> bool {
        self.next == self.row.len()
    }

    /// Refuses sums not of `n` patches' every row.
    fn check(&self, n: usize) -> Result<(), Error> {
        if self.row.len() != n || !self.is_complete() {
            return Err(Error::RowSet {
                reason: format!(
                    "row sums of {} of {} patches given to shoot {n}",
                    self.next,
                    self.row.len()
                ),
            });
        }
        Ok(())
    }

    /// `d_j = 2 A_j r_j / (A_j r_j + c_j)` (1 where a patch neither sees nor is seen).
    fn column_scale(&self, area: &[f64]) -> Vec<f64> {
        (0..self.row.len())
            .map(|j| {
                let own = area[j] * self.row[j];
                let both = own + self.column[j];
                if both > 0.0 {
                    2.0 * own / both
                } else {
                    1.0
                }
            })
            .collect()
    }
}

/// What a long shooting run reports as it goes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShootProgress {
    /// Rows summed so far by the first pass (when the sums were not given).
    Rows(usize),
    /// Shots so far and the pending share of the emitted power.
    Shots { shots: usize, pending: f64 },
}

/// How matrix-free shooting runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatrixFreeConfig {
    /// Stop once the largest pending radiosity `|ΔB + W|` is at most `tolerance` times the
    /// largest radiosity; `max_iterations` caps the shots.
    pub solve: SolveConfig,
    /// Shooters taken at a time (their rows made together). Fixed, so that the answer
    /// does not depend on the thread count; 1 is classical progressive refinement.
    pub batch: usize,
    /// Bytes of rows kept for shooters that shoot again.
    pub cache_bytes: usize,
    /// Each shot sends this many times the patch's unshot radiosity, and the patch keeps
    /// the negative remainder `(1 − overshoot) ΔB` to send back later (over-relaxation of
    /// Southwell's iteration, Gortler et al. 1993; Feda and Purgathofer's overshooting):
    /// light a patch will receive again is sent ahead of its return. 1 is classical
    /// progressive refinement; from 1 up to (not including) 2. (On the loft at 180 × 720,
    /// 1.2 shot 46 % fewer times than 1 to the same tolerance, and came nearer the
    /// converged answer; see the README. Tested up to 1.5.) With 1, the answers are the
    /// classical ones, though not always the bits of before overshooting: pending power
    /// is now recomputed as a patch receives, not added to, so near-ties between
    /// shooters may break otherwise (on the loft they did not: the same bits).
    pub overshoot: f64,
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

/// Solves `B = E + ρ K B`, `K = (F + A⁻¹FᵀA) D / 2` (`D` the column scaling
/// `d_j = 2 A_j r_j / (A_j r_j + c_j)` of [`RowSums`], so that `Σ_i A_i K_ij = A_j r_j`:
/// power conserved), without a matrix. First, unless `sums` are given, every row is
/// asked for, in batches in patch order, and summed (kept in the cache while it has
/// room, so that a cache that holds every row makes each row once). Then the batch of
/// patches of largest pending power `A_i Σ_c |ΔB_{i,c} + W_{i,c}|` (unshot radiosity and
/// the estimate of what its next gather brings; ties to the lower index) have their rows
/// made by `rows` (those not cached; `rows` may take its rows' storage from the spare rows
/// it is handed, rows shot and not kept, rather than allocate afresh). Then, one after
/// the other in that order, each
/// - gathers `½ Σ_j F_ij d_j S_j` (`S` the radiosity shot so far by each patch), adding to
///   its radiosity and unshot radiosity what this brings beyond its last gather;
/// - shoots `ω ΔB_i` (`ω` the config's `overshoot`, `ΔB_i` its unshot radiosity, which
///   becomes `(1 − ω) ΔB_i`), giving each `j` in its row `ρ_j ½ F_ij d_i ω ΔB_i A_i / A_j`
///   (the other half of `K_ji`); what `j` receives this way also estimates what `j`'s
///   next gather of `i`'s shot will bring (`½ F_ji ≈ ½ F_ij A_i / A_j`), so it is added
///   to `W_j` as well. Pending power is `A_i Σ_c |ΔB_{i,c} + W_{i,c}|`.
///
/// Once the largest `|ΔB + W|` is `tolerance` of the largest radiosity, every patch that
/// reflects gathers (and shoots) again, in patch order, in rounds interleaved with the
/// shooting they set off, until a round brings no patch more than `tolerance` of the
/// largest radiosity: `W` misses what a patch sees that does not see it back.
/// `progress` after each batch of the first pass and of shots. Energy is accounted shot
/// by shot and gather by gather: emitted = absorbed + escaped + unshot, where unshot
/// counts `ΔB + W` and escaped is what the rows miss (`A_i (1 − r_i)` a unit shot) and
/// what was sent to be gathered that no gather took.
///
/// The report's residual is the stopping measure (computing the true residual would need
/// every row).
pub fn shoot_matrix_free<E: From<Error>>(
    surfaces: &Surfaces,
    config: &MatrixFreeConfig,
    sums: Option<RowSums>,
    rows: &mut dyn FnMut(&[PatchId], &mut Vec<ShotRow>) -> Result<Vec<ShotRow>, E>,
    progress: &mut dyn FnMut(ShootProgress),
) -> Result<(Solution, MatrixFreeStats), E> {
    let n = surfaces.area.len();
    surfaces.validate(n)?;
    config.solve.validate()?;
    check_config(config)?;
    let (area, rho) = (&surfaces.area, &surfaces.reflectance);
    let mut stats = MatrixFreeStats::default();
    let mut cache: HashMap<PatchId, ShotRow> = HashMap::new();
    let mut spare: Vec<ShotRow> = Vec::new();
    let sums = match sums {
        Some(sums) => sums,
        None => {
            let keep = Keep {
                cache: &mut cache,
                spare: &mut spare,
                stats: &mut stats,
                config,
            };
            sum_rows(surfaces, keep, rows, progress)?
        }
    };
    sums.check(n)?;
    let mut state = State::new(surfaces, &sums);
    drop(sums);
    stats.emitted =
        std::array::from_fn(|c| (0..n).map(|i| area[i] * surfaces.emission[i][c]).sum());
    let total: f64 = stats.emitted.iter().sum();
    let mut order: Vec<usize> = (0..n).collect();
    // Once converged, every patch that reflects gathers again, in rounds in patch order,
    // until a round's gathers bring nothing beyond the tolerance: a gather's estimate `W`
    // misses what a patch sees that does not see it (an entry whose transpose is zero).
    let (mut round, mut round_change) = (0, 0.0f64);
    let mut measure;
    let mut sweep = Sweep::of(&state.shades);
    loop {
        measure = if sweep.max_b > 0.0 {
            sweep.max_pending / sweep.max_b
        } else {
            0.0
        };
        if stats.shots >= config.solve.max_iterations {
            break;
        }
        let k = config
            .batch
            .min(n)
            .min(config.solve.max_iterations - stats.shots);
        let verifying = measure <= config.solve.tolerance;
        let batch = if verifying {
            let batch = state.reflecting(&mut round, rho, k);
            if batch.is_empty() {
                if round_change <= config.solve.tolerance * sweep.max_b {
                    break;
                }
                (round, round_change) = (0, 0.0);
                continue;
            }
            batch
        } else {
            next_batch(&mut order, &state.shades, k)
        };
        let missing: Vec<PatchId> = batch
            .iter()
            .map(|&i| i as PatchId)
            .filter(|i| !cache.contains_key(i))
            .collect();
        let made = rows(&missing, &mut spare)?;
        check_count(missing.len(), made.len())?;
        stats.rows_made += made.len();
        let fresh: HashMap<PatchId, ShotRow> = missing.iter().copied().zip(made).collect();
        for &i in &batch {
            let id = i as PatchId;
            let row = cache
                .get(&id)
                .or_else(|| fresh.get(&id))
                .expect("made above");
            check_row(i, row, n)?;
            let brought = state.gather(i, row, &mut stats);
            if verifying {
                round_change = round_change.max(brought);
            }
            state.shoot(i, row, config.overshoot, &mut stats);
        }
        let keep = Keep {
            cache: &mut cache,
            spare: &mut spare,
            stats: &mut stats,
            config,
        };
        keep.rows(missing, fresh);
        sweep = Sweep::of(&state.shades);
        progress(ShootProgress::Shots {
            shots: stats.shots,
            pending: if total > 0.0 {
                sweep.power / total
            } else {
                0.0
            },
        });
    }
    stats.cached_rows = cache.len();
    let tolerance = config.solve.tolerance;
    Ok(state.finish(surfaces, stats, measure, tolerance))
}

/// Refuses a batch of 0 and an overshoot outside [1, 2).
fn check_config(config: &MatrixFreeConfig) -> Result<(), Error> {
    if config.batch == 0 {
        return Err(Error::BadConfig {
            what: "batch",
            value: 0.0,
            rule: "must be at least 1",
        });
    }
    if !(1.0..2.0).contains(&config.overshoot) {
        return Err(Error::BadConfig {
            what: "overshoot",
            value: config.overshoot,
            rule: "must be at least 1 and below 2",
        });
    }
    Ok(())
}

/// Entries a part of a shot or a gather takes: a row is cut into parts of this many
/// entries, taken in parallel (each part's patches are its own: the columns increase);
/// fixed, so that the sums, added part by part in order, do not depend on the thread
/// count.
const SHOT_PART: usize = 4096;
/// Parts a row has at least to be taken in parallel.
const PARALLEL_PARTS: usize = 4;

/// `f` over `parts`, in parallel only when there are [`PARALLEL_PARTS`] at least (waking a
/// thread for a short row costs more than it saves); the results in order either way.
fn in_parts<P: Send, T: Send>(parts: Vec<P>, f: impl Fn(P) -> T + Sync + Send) -> Vec<T> {
    use rayon::prelude::*;
    if parts.len() >= PARALLEL_PARTS {
        parts.into_par_iter().map(f).collect()
    } else {
        parts.into_iter().map(f).collect()
    }
}

/// The next `k` shooters (those with pending power): largest power first, ties to the
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

/// A patch as shooting reads and updates it, in one place (a shot touches one patch per
/// entry of its row, scattered over the scene).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Shade {
    b: [f64; 3],
    unshot: [f64; 3],
    /// What the patch's next gather is expected to bring (`W`): what it received from
    /// the shots since its last gather.
    pending: [f64; 3],
    rho: [f64; 3],
    area: f64,
    /// `A Σ_c |ΔB_c + W_c|` (an overshot patch's unshot radiosity is negative).
    power: f64,
}

impl Shade {
    /// `ΔB_c + W_c`: the radiosity of channel `c` still to be sent (negative when the
    /// patch owes light after an overshot shot) or expected of its next gather.
    fn outstanding(&self, c: usize) -> f64 {
        self.unshot[c] + self.pending[c]
    }

    /// `A Σ_c |ΔB_c + W_c|`: what picks the next shooters.
    fn pending_power(&self) -> f64 {
        self.area * (0..3).map(|c| self.outstanding(c).abs()).sum::<f64>()
    }
}

/// Shooting's state: the patches, and what the gathers read and keep.
struct State {
    shades: Vec<Shade>,
    /// `S`: radiosity shot so far by each patch.
    shot: Vec<[f64; 3]>,
    /// `½ Σ_j F_ij S_j` at each patch's last gather.
    gathered: Vec<[f64; 3]>,
    /// Power the shots have sent to be gathered that no gather has taken yet.
    to_gather: [f64; 3],
    /// The column scaling `d_j`, and the columns' area-weighted sums `c_j`.
    scale: Vec<f64>,
    column: Vec<f64>,
}

impl State {
    fn new(surfaces: &Surfaces, sums: &RowSums) -> State {
        let n = surfaces.area.len();
        let shades = (0..n)
            .map(|i| Shade {
                b: surfaces.emission[i],
                unshot: surfaces.emission[i],
                pending: [0.0; 3],
                rho: surfaces.reflectance[i],
                area: surfaces.area[i],
                power: surfaces.area[i] * surfaces.emission[i].iter().sum::<f64>(),
            })
            .collect();
        State {
            shades,
            shot: vec![[0.0; 3]; n],
            gathered: vec![[0.0; 3]; n],
            to_gather: [0.0; 3],
            scale: sums.column_scale(&surfaces.area),
            column: sums.column.clone(),
        }
    }

    /// Up to `k` patches from `*from` on, in order, that reflect; `*from` moves past
    /// those looked at.
    fn reflecting(&self, from: &mut usize, rho: &[[f64; 3]], k: usize) -> Vec<usize> {
        let mut batch = Vec::with_capacity(k);
        while batch.len() < k && *from < self.shades.len() {
            if rho[*from].iter().any(|&r| r > 0.0) {
                batch.push(*from);
            }
            *from += 1;
        }
        batch
    }

    /// Patch `i` gathers `½ Σ_j F_ij d_j S_j` along its (checked) row: what this brings
    /// beyond its last gather is added to its radiosity and unshot radiosity. Returns
    /// the largest channel of what it added.
    fn gather(&mut self, i: usize, row: &ShotRow, stats: &mut MatrixFreeStats) -> f64 {
        let (columns, shot) = (&row.columns, &self.shot);
        let part = |range: std::ops::Range<usize>| {
            let mut h = [0.0f64; 3];
            for k in range {
                add_scaled(&mut h, row.values[k] as f64, &shot[columns[k] as usize]);
            }
            h
        };
        let m = columns.len();
        let ranges: Vec<_> = (0..m)
            .step_by(SHOT_PART)
            .map(|s| s..(s + SHOT_PART).min(m))
            .collect();
        let mut h = [0.0f64; 3];
        for p in in_parts(ranges, part) {
            add_scaled(&mut h, 0.5, &p);
        }
        let s = &mut self.shades[i];
        let mut brought = 0.0f64;
        for c in 0..3 {
            let arriving = h[c] - self.gathered[i][c];
            let d = s.rho[c] * arriving;
            brought = brought.max(d.abs());
            stats.absorbed[c] += s.area * (arriving - d);
            self.to_gather[c] -= s.area * arriving;
            s.b[c] += d;
            s.unshot[c] += d;
            s.pending[c] = 0.0;
        }
        self.gathered[i] = h;
        s.power = s.pending_power();
        brought
    }

    /// Patch `i` shoots `overshoot` times its unshot radiosity along its (checked) row,
    /// scaled by `d_i`: half to be gathered, half given now to each `j` by reciprocity;
    /// it keeps what it sent beyond its unshot radiosity as negative unshot radiosity.
    fn shoot(&mut self, i: usize, row: &ShotRow, overshoot: f64, stats: &mut MatrixFreeStats) {
        let (n, columns) = (self.shades.len(), &row.columns);
        // (`overshoot` 1 leaves exactly 0: x − 1·x.)
        let sent: [f64; 3] = std::array::from_fn(|c| overshoot * self.shades[i].unshot[c]);
        let area_i = self.shades[i].area;
        let shot: [f64; 3] = std::array::from_fn(|c| self.scale[i] * sent[c]);
        {
            let s = &mut self.shades[i];
            for c in 0..3 {
                s.unshot[c] -= sent[c];
            }
            s.power = s.pending_power();
        }
        for c in 0..3 {
            // (`d_j S_j`, as the gathers take it.)
            self.shot[i][c] += shot[c];
            self.to_gather[c] += 0.5 * self.column[i] * shot[c];
        }
        stats.shots += 1;
        // Each part with the patches from its first column to the next part's first.
        let m = columns.len();
        let mut parts = Vec::with_capacity(m.div_ceil(SHOT_PART));
        let mut rest = &mut self.shades[..];
        let mut base = 0usize;
        for start in (0..m).step_by(SHOT_PART) {
            let end = (start + SHOT_PART).min(m);
            let split = if end < m { columns[end] as usize } else { n };
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(split - base);
            parts.push((start..end, base, head));
            (rest, base) = (tail, split);
        }
        let give = |(range, base, shades): (std::ops::Range<usize>, usize, &mut [Shade])| {
            let mut absorbed = [0.0f64; 3];
            let mut sum = 0.0;
            for k in range {
                let j = columns[k] as usize;
                let f = row.values[k] as f64;
                sum += f;
                let p = &mut shades[j - base];
                let kf = 0.5 * f * area_i / p.area;
                for c in 0..3 {
                    let arriving = kf * shot[c];
                    let d = p.rho[c] * arriving;
                    absorbed[c] += p.area * (arriving - d);
                    p.b[c] += d;
                    p.unshot[c] += d;
                    p.pending[c] += d;
                }
                p.power = p.pending_power();
            }
            (absorbed, sum)
        };
        let mut sum = 0.0;
        for (absorbed, part_sum) in in_parts(parts, give) {
            for c in 0..3 {
                stats.absorbed[c] += absorbed[c];
            }
            sum += part_sum;
        }
        for c in 0..3 {
            stats.escaped[c] +=
                area_i * sent[c] - 0.5 * self.column[i] * shot[c] - 0.5 * area_i * shot[c] * sum;
        }
    }

    /// The solution reached (`measure` the stopping measure at the end), its accounts
    /// closed.
    fn finish(
        self,
        surfaces: &Surfaces,
        mut stats: MatrixFreeStats,
        measure: f64,
        tolerance: f64,
    ) -> (Solution, MatrixFreeStats) {
        self.close_accounts(&mut stats);
        let b: Vec<[f64; 3]> = self.shades.iter().map(|s| s.b).collect();
        let pending: Vec<[f64; 3]> = self
            .shades
            .iter()
            .map(|s| std::array::from_fn(|c| s.outstanding(c)))
            .collect();
        // (Overshooting can leave the patches owing light on the whole, a negative
        // pending sum: the ambient term shows light still to come, so none then.)
        let ambient = crate::solve::ambient_term(&surfaces.area, &surfaces.reflectance, &pending)
            .map(|a| if a < 0.0 { 0.0 } else { a });
        let report = SolveReport {
            solver: Solver::Progressive,
            iterations: stats.shots,
            residual: measure,
            converged: measure <= tolerance,
        };
        let solution = Solution {
            radiosity: b,
            ambient,
            report,
        };
        (solution, stats)
    }

    /// The power left pending (unshot, or expected of the next gathers), what was sent to
    /// be gathered beyond that counted as escaped, and the relative imbalance of the
    /// accounts.
    fn close_accounts(&self, stats: &mut MatrixFreeStats) {
        let mut expected = [0.0f64; 3];
        for s in &self.shades {
            for c in 0..3 {
                stats.unshot[c] += s.area * s.outstanding(c);
                expected[c] += s.area * s.pending[c];
            }
        }
        for c in 0..3 {
            stats.escaped[c] += self.to_gather[c] - expected[c];
        }
        stats.relative_imbalance = (0..3)
            .filter(|&c| stats.emitted[c] > 0.0)
            .map(|c| {
                (stats.emitted[c] - stats.absorbed[c] - stats.escaped[c] - stats.unshot[c]).abs()
                    / stats.emitted[c]
            })
            .fold(0.0, f64::max);
    }
}

/// What a pass over the patches finds after a batch: the largest radiosity and pending
/// radiosity `ΔB + W` (the stopping measure), and the pending power (summed in patch
/// order).
struct Sweep {
    max_b: f64,
    max_pending: f64,
    power: f64,
}

impl Sweep {
    fn of(shades: &[Shade]) -> Sweep {
        let mut s = Sweep {
            max_b: 0.0,
            max_pending: 0.0,
            power: 0.0,
        };
        for p in shades {
            for c in 0..3 {
                s.max_b = s.max_b.max(p.b[c]);
                s.max_pending = s.max_pending.max(p.outstanding(c).abs());
            }
            s.power += p.power;
        }
        s
    }
}

/// Where rows just made go: the cache, while its bytes allow, the others (up to a batch)
/// spare storage for the source.
struct Keep<'a> {
    cache: &'a mut HashMap<PatchId, ShotRow>,
    spare: &'a mut Vec<ShotRow>,
    stats: &'a mut MatrixFreeStats,
    config: &'a MatrixFreeConfig,
}

impl Keep<'_> {
    /// Keeps `fresh`, the rows of `made` (in its order, so that the rows asked for
    /// later, and so those a run shared among processes asks for, do not depend on a
    /// map's order).
    fn rows(mut self, made: Vec<PatchId>, mut fresh: HashMap<PatchId, ShotRow>) {
        for id in made {
            let row = fresh.remove(&id).expect("made above");
            self.one(id, row);
        }
    }

    fn one(&mut self, id: PatchId, row: ShotRow) {
        if self.stats.cached_bytes + row.bytes() <= self.config.cache_bytes {
            self.stats.cached_bytes += row.bytes();
            self.cache.insert(id, row);
        } else if self.spare.len() < self.config.batch {
            self.spare.push(row);
        }
    }
}

/// The first pass: every row asked of `rows` (checked) in batches in patch order and
/// summed, kept as `keep` allows.
fn sum_rows<E: From<Error>>(
    surfaces: &Surfaces,
    mut keep: Keep<'_>,
    rows: &mut dyn FnMut(&[PatchId], &mut Vec<ShotRow>) -> Result<Vec<ShotRow>, E>,
    progress: &mut dyn FnMut(ShootProgress),
) -> Result<RowSums, E> {
    let n = surfaces.area.len();
    let mut sums = RowSums::new(n);
    let step = keep.config.batch;
    for start in (0..n).step_by(step) {
        let ids: Vec<PatchId> = (start..(start + step).min(n))
            .map(|i| i as PatchId)
            .collect();
        let made = rows(&ids, keep.spare)?;
        check_count(ids.len(), made.len())?;
        keep.stats.rows_made += made.len();
        for (&id, row) in ids.iter().zip(made) {
            let i = id as usize;
            check_row(i, &row, n)?;
            let entries = row.columns.iter().copied().zip(row.values.iter().copied());
            sums.add(id, surfaces.area[i], entries)?;
            keep.one(id, row);
        }
        progress(ShootProgress::Rows(sums.next));
    }
    Ok(sums)
}

/// Refuses a source that gave another number of rows than asked.
fn check_count(asked: usize, given: usize) -> Result<(), Error> {
    if given != asked {
        return Err(Error::RowSet {
            reason: format!("{asked} rows asked of the source to shoot, {given} given"),
        });
    }
    Ok(())
}

/// Refuses a row whose columns do not increase, reach past the patch count, or do not
/// have one value each.
fn check_row(i: usize, row: &ShotRow, n: usize) -> Result<(), Error> {
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
