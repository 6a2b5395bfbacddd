//! The sparse form-factor matrix (CSR) and its reciprocal, row-sum-keeping version.

use crate::Error;
use rad_core::PatchId;
use rayon::prelude::*;

/// Rows may sum to this much over 1 (accumulation round-off) before they are refused.
const ROW_SUM_SLACK: f64 = 1e-6;

/// A square sparse matrix of form factors, one row per patch, columns sorted.
///
/// Values are stored as `f32`: that adds a relative error of at most 6e-8 to each
/// entry (so at most 6e-8 to a row's sum); sums and products are taken in `f64`.
/// `F_ij = value · row_scale[i]`: the scale is 1 for rows as given, and `1 / A_i` for
/// [`FormFactors::reciprocal`]'s matrix, whose stored values are the symmetric `A_i F_ij`
/// (so reciprocity survives the rounding to `f32` exactly).
#[derive(Clone, Debug, PartialEq)]
pub struct FormFactors {
    row_start: Vec<usize>,
    column: Vec<PatchId>,
    value: Vec<f32>,
    row_scale: Vec<f64>,
    symmetric: bool,
}

/// What [`FormFactors::reciprocal`] changed, and how well it converged.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reciprocity {
    /// Largest `|A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji)` over pairs of the input
    /// where both are at least 1e-4 (smaller ones are dominated by sampling noise).
    pub max_input_asymmetry: f64,
    /// Median of the same over the same pairs.
    pub median_input_asymmetry: f64,
    /// Sum over rows of `Σ_j |F̃_ij − F_ij|`, divided by the number of rows: the mean L1
    /// change of a row.
    pub mean_row_l1_change: f64,
    /// Largest `|Σ_j F̃_ij − Σ_j F_ij|` after scaling.
    pub max_row_sum_error: f64,
    /// Products by G used (Newton steps and conjugate-gradient iterations).
    pub iterations: usize,
    /// Whether every row reached its sum within the tolerance asked.
    pub converged: bool,
}

impl FormFactors {
    /// Builds the matrix from one row per patch, `0..n_patches`, in any order. Entries
    /// are `(column, F)`; a column may repeat (its values add).
    ///
    /// Refuses a missing or duplicate row, a column out of range, a negative or
    /// non-finite value, and a row summing to more than `1 + 1e-6`.
    pub fn from_rows<'a, I>(n_patches: usize, rows: I) -> Result<FormFactors, Error>
    where
        I: IntoIterator<Item = (PatchId, &'a [(PatchId, f64)])>,
    {
        let mut by_patch: Vec<Option<&'a [(PatchId, f64)]>> = vec![None; n_patches];
        for (patch, entries) in rows {
            let slot = by_patch
                .get_mut(patch as usize)
                .ok_or(Error::EntryOutOfRange {
                    row: patch,
                    column: patch,
                    n_patches,
                })?;
            if slot.is_some() {
                return Err(Error::DuplicateRow { patch });
            }
            *slot = Some(entries);
        }
        let mut row_start = Vec::with_capacity(n_patches + 1);
        row_start.push(0);
        let mut column = Vec::new();
        let mut value = Vec::new();
        let mut scratch: Vec<(PatchId, f64)> = Vec::new();
        for (i, slot) in by_patch.iter().enumerate() {
            let entries = slot.ok_or(Error::MissingRow {
                patch: i as PatchId,
                n_patches,
            })?;
            scratch.clear();
            scratch.extend_from_slice(entries);
            scratch.sort_by_key(|e| e.0);
            let mut sum = 0.0;
            let mut k = 0;
            while k < scratch.len() {
                let (j, mut f) = scratch[k];
                let bad = |value| Error::BadValue {
                    row: i as PatchId,
                    column: j,
                    value,
                };
                if j as usize >= n_patches {
                    return Err(Error::EntryOutOfRange {
                        row: i as PatchId,
                        column: j,
                        n_patches,
                    });
                }
                if !(f.is_finite() && f >= 0.0) {
                    return Err(bad(f));
                }
                k += 1;
                while k < scratch.len() && scratch[k].0 == j {
                    let g = scratch[k].1;
                    if !(g.is_finite() && g >= 0.0) {
                        return Err(bad(g));
                    }
                    f += g;
                    k += 1;
                }
                sum += f;
                if f > 0.0 {
                    column.push(j);
                    value.push(f as f32);
                }
            }
            if sum > 1.0 + ROW_SUM_SLACK {
                return Err(Error::RowSumAboveOne {
                    row: i as PatchId,
                    sum,
                });
            }
            row_start.push(column.len());
        }
        Ok(FormFactors {
            row_start,
            column,
            value,
            row_scale: vec![1.0; n_patches],
            symmetric: false,
        })
    }

    /// Number of patches (rows).
    pub fn n_patches(&self) -> usize {
        self.row_start.len() - 1
    }

    /// Stored (non-zero) entries.
    pub fn n_entries(&self) -> usize {
        self.value.len()
    }

    /// Row `i`: sorted columns and their stored values (`F_ij = value · row_scale(i)`).
    ///
    /// # Panics
    /// If `i` is out of range.
    pub fn row(&self, i: PatchId) -> (&[PatchId], &[f32]) {
        let (a, b) = (self.row_start[i as usize], self.row_start[i as usize + 1]);
        (&self.column[a..b], &self.value[a..b])
    }

    /// The factor of row `i`'s stored values.
    pub fn row_scale(&self, i: PatchId) -> f64 {
        self.row_scale[i as usize]
    }

    /// Whether the stored values are symmetric (`A_i F_ij`, from
    /// [`FormFactors::reciprocal`]), so that `F_ji = value_ij · row_scale(j)` exactly.
    pub fn is_symmetric(&self) -> bool {
        self.symmetric
    }

    /// `F_ij`, zero where nothing is stored.
    pub fn get(&self, i: PatchId, j: PatchId) -> f64 {
        let (c, v) = self.row(i);
        c.binary_search(&j)
            .map_or(0.0, |k| v[k] as f64 * self.row_scale[i as usize])
    }

    /// `Σ_j F_ij` in `f64`.
    pub fn row_sum(&self, i: PatchId) -> f64 {
        self.row(i).1.iter().map(|&v| v as f64).sum::<f64>() * self.row_scale[i as usize]
    }

    /// `Σ_j |F_ij − G_ij|` of row `i` of two matrices of the same size.
    ///
    /// # Panics
    /// If `i` is out of range of either.
    pub fn row_l1_distance(&self, other: &FormFactors, i: PatchId) -> f64 {
        let (ca, va) = self.row(i);
        let (cb, vb) = other.row(i);
        let (sa, sb) = (self.row_scale(i), other.row_scale(i));
        let (mut x, mut y, mut total) = (0, 0, 0.0);
        while x < ca.len() || y < cb.len() {
            let ja = ca.get(x).copied().unwrap_or(PatchId::MAX);
            let jb = cb.get(y).copied().unwrap_or(PatchId::MAX);
            let j = ja.min(jb);
            let fa = if ja == j {
                x += 1;
                va[x - 1] as f64 * sa
            } else {
                0.0
            };
            let fb = if jb == j {
                y += 1;
                vb[y - 1] as f64 * sb
            } else {
                0.0
            };
            total += (fa - fb).abs();
        }
        total
    }

    /// `y = F x` for RGB vectors, rows in parallel (each row summed in order, so the
    /// result does not depend on the thread count).
    pub fn apply(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        (0..self.n_patches())
            .into_par_iter()
            .map(|i| self.row_dot(i as PatchId, x))
            .collect()
    }

    #[inline]
    pub(crate) fn row_dot(&self, i: PatchId, x: &[[f64; 3]]) -> [f64; 3] {
        let (c, v) = self.row(i);
        let mut s = [0.0f64; 3];
        for (&j, &f) in c.iter().zip(v) {
            let b = x[j as usize];
            let f = f as f64;
            s[0] += f * b[0];
            s[1] += f * b[1];
            s[2] += f * b[2];
        }
        let k = self.row_scale[i as usize];
        [s[0] * k, s[1] * k, s[2] * k]
    }

    /// The transpose's pattern and values of `A_i F_ij` (row j holds column i).
    fn weighted_transpose(&self, area: &[f64]) -> (Vec<usize>, Vec<PatchId>, Vec<f64>) {
        let n = self.n_patches();
        let mut count = vec![0usize; n + 1];
        for &j in &self.column {
            count[j as usize + 1] += 1;
        }
        for k in 0..n {
            count[k + 1] += count[k];
        }
        let start = count.clone();
        let mut fill = count;
        let mut col = vec![0 as PatchId; self.column.len()];
        let mut val = vec![0.0f64; self.column.len()];
        for i in 0..n {
            let (c, v) = self.row(i as PatchId);
            for (&j, &f) in c.iter().zip(v) {
                let at = fill[j as usize];
                col[at] = i as PatchId;
                val[at] = area[i] * f as f64 * self.row_scale[i];
                fill[j as usize] += 1;
            }
        }
        (start, col, val)
    }

    /// The exactly reciprocal matrix closest to this one that keeps each row's sum.
    ///
    /// `G = (A_i F_ij + A_j F_ji) / 2` is symmetric; a symmetric diagonal scaling
    /// `x_i G_ij x_j` (found by Newton's method with conjugate-gradient steps on
    /// `x ∘ (G x) = t`, `t_i = A_i Σ_j F_ij`) makes its rows sum to `t_i` while keeping
    /// it symmetric. Then `F̃_ij = x_i G_ij x_j / A_i` satisfies
    /// `A_i F̃_ij = A_j F̃_ji` exactly and `Σ_j F̃_ij = Σ_j F_ij` to `tolerance`: in a
    /// closed scene rows still sum to 1, and the solvers conserve energy exactly.
    ///
    /// `area` has one positive, finite area per patch.
    pub fn reciprocal(
        &self,
        area: &[f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<(FormFactors, Reciprocity), Error> {
        let n = self.n_patches();
        check_areas(area, n)?;
        let rows = self.symmetric_part(area);
        let target: Vec<f64> = (0..n)
            .map(|i| area[i] * self.row_sum(i as PatchId))
            .collect();
        let (x, iterations, worst) = balance(&rows, &target, tolerance, max_iterations);
        let active: Vec<bool> = target.iter().map(|&t| t > 0.0).collect();
        if x.iter()
            .zip(&active)
            .any(|(v, &a)| !v.is_finite() || (a && *v <= 0.0))
        {
            return Err(Error::NoReciprocalScaling { iterations });
        }
        let (row_start, column, value, change, max_row_sum_error) = self.scaled(&rows, &x, area);
        let mut asym: Vec<f64> = rows.into_iter().flat_map(|r| r.2).collect();
        asym.sort_by(f64::total_cmp);
        let report = Reciprocity {
            max_input_asymmetry: asym.last().copied().unwrap_or(0.0),
            median_input_asymmetry: asym.get(asym.len() / 2).copied().unwrap_or(0.0),
            mean_row_l1_change: change / n.max(1) as f64,
            max_row_sum_error,
            iterations,
            converged: worst <= tolerance,
        };
        Ok((
            FormFactors {
                row_start,
                column,
                value,
                row_scale: area.iter().map(|a| 1.0 / a).collect(),
                symmetric: true,
            },
            report,
        ))
    }

    /// G's rows, `(A_i F_ij + A_j F_ji) / 2`, each with the input's relative
    /// asymmetries of its resolved pairs (j > i, both terms at least 1e-4 of the smaller
    /// area): (columns, values, asymmetries).
    fn symmetric_part(&self, area: &[f64]) -> Vec<GRow> {
        let n = self.n_patches();
        let (t_start, t_col, t_val) = self.weighted_transpose(area);
        // G, row by row: the merge of row i of (A F) and of (A F)^T, halved.
        (0..n)
            .into_par_iter()
            .map(|i| {
                let (c, v) = self.row(i as PatchId);
                let scale = self.row_scale[i];
                let (tc, tv) = (
                    &t_col[t_start[i]..t_start[i + 1]],
                    &t_val[t_start[i]..t_start[i + 1]],
                );
                let mut cols = Vec::with_capacity(c.len().max(tc.len()));
                let mut vals = Vec::with_capacity(cols.capacity());
                let mut asym = Vec::new();
                let (mut a, mut b) = (0, 0);
                while a < c.len() || b < tc.len() {
                    let ja = c.get(a).copied().unwrap_or(PatchId::MAX);
                    let jb = tc.get(b).copied().unwrap_or(PatchId::MAX);
                    let j = ja.min(jb);
                    let x = if ja == j {
                        a += 1;
                        area[i] * v[a - 1] as f64 * scale
                    } else {
                        0.0
                    };
                    let y = if jb == j {
                        b += 1;
                        tv[b - 1]
                    } else {
                        0.0
                    };
                    let m = x.max(y);
                    if (j as usize) > i && x.min(y) >= 1e-4 * area[i].min(area[j as usize]) {
                        asym.push((x - y).abs() / m);
                    }
                    cols.push(j);
                    vals.push(0.5 * (x + y));
                }
                (cols, vals, asym)
            })
            .collect()
    }

    /// The rows of `x_i G_ij x_j / A_i` (stored as f32: symmetric bit for bit), with the
    /// total change from this matrix and the largest row-sum error: (row_start, column,
    /// value, change, max_row_sum_error).
    fn scaled(&self, rows: &[GRow], x: &[f64], area: &[f64]) -> Scaled {
        let n = self.n_patches();
        let mut row_start = Vec::with_capacity(n + 1);
        row_start.push(0);
        let mut column = Vec::new();
        let mut value = Vec::new();
        let mut change = 0.0;
        let mut max_row_sum_error: f64 = 0.0;
        for (i, (cols, vals, _)) in rows.iter().enumerate() {
            let mut sum = 0.0;
            // G's pattern holds F's row: walk both in column order.
            let (fc, fv) = self.row(i as PatchId);
            let scale = self.row_scale[i];
            let mut k = 0;
            for (&j, &g) in cols.iter().zip(vals) {
                // x_i x_j commutes exactly, so the stored value is symmetric bit for bit.
                let stored = (g * (x[i] * x[j as usize])) as f32;
                let f = stored as f64 / area[i];
                sum += f;
                let old = if k < fc.len() && fc[k] == j {
                    k += 1;
                    fv[k - 1] as f64 * scale
                } else {
                    0.0
                };
                change += (f - old).abs();
                column.push(j);
                value.push(stored);
            }
            max_row_sum_error = max_row_sum_error.max((sum - self.row_sum(i as PatchId)).abs());
            row_start.push(column.len());
        }
        (row_start, column, value, change, max_row_sum_error)
    }
}

/// A row of G: columns, values, and the input's asymmetries there.
type GRow = (Vec<PatchId>, Vec<f64>, Vec<f64>);
/// The scaled matrix's rows, its total change and largest row-sum error.
type Scaled = (Vec<usize>, Vec<PatchId>, Vec<f32>, f64, f64);

/// The scaling x with `x ∘ (G x) = target` (to `tolerance` relative, at most
/// `max_iterations` products by G), G given by its `rows`: (x, products made, the
/// largest relative error left).
fn balance(
    rows: &[GRow],
    target: &[f64],
    tolerance: f64,
    max_iterations: usize,
) -> (Vec<f64>, usize, f64) {
    let n = rows.len();
    let g_dot = |i: usize, x: &[f64]| -> f64 {
        rows[i]
            .0
            .iter()
            .zip(&rows[i].1)
            .map(|(&j, &g)| g * x[j as usize])
            .sum()
    };
    // Newton's method on x ∘ (G x) = t, each step solved by preconditioned conjugate
    // gradients (Knight & Ruiz's balancing idea): the Jacobian divided by x,
    // diag(Gx / x) + G, is symmetric positive semi-definite. Patches with t = 0 keep
    // x = 0. `iterations` counts products by G.
    let active: Vec<bool> = target.iter().map(|&t| t > 0.0).collect();
    let mut x: Vec<f64> = active.iter().map(|&a| if a { 1.0 } else { 0.0 }).collect();
    let spmv = |v: &[f64]| -> Vec<f64> { (0..n).into_par_iter().map(|i| g_dot(i, v)).collect() };
    let dot = |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(p, q)| p * q).sum() };
    let mut iterations = 0;
    let mut worst;
    loop {
        let gx = spmv(&x);
        iterations += 1;
        worst = (0..n)
            .filter(|&i| active[i])
            .map(|i| (x[i] * gx[i] - target[i]).abs() / target[i])
            .fold(0.0, f64::max);
        if worst <= tolerance || iterations >= max_iterations || !worst.is_finite() {
            break;
        }
        let d: Vec<f64> = (0..n)
            .map(|i| {
                if active[i] && x[i] > 0.0 {
                    gx[i] / x[i]
                } else {
                    1.0
                }
            })
            .collect();
        let r: Vec<f64> = (0..n)
            .map(|i| {
                if active[i] {
                    (target[i] - x[i] * gx[i]) / x[i]
                } else {
                    0.0
                }
            })
            .collect();
        let r_norm = dot(&r, &r).sqrt();
        let eta = worst.sqrt().min(0.5);
        let mut delta = vec![0.0; n];
        let mut res = r;
        let mut z: Vec<f64> = res.iter().zip(&d).map(|(a, b)| a / b).collect();
        let mut p = z.clone();
        let mut rz = dot(&res, &z);
        for _ in 0..200 {
            let gp = spmv(&p);
            iterations += 1;
            let q: Vec<f64> = (0..n)
                .map(|i| if active[i] { d[i] * p[i] + gp[i] } else { 0.0 })
                .collect();
            let pq = dot(&p, &q);
            if !(pq > 0.0) {
                break;
            }
            let alpha = rz / pq;
            for i in 0..n {
                delta[i] += alpha * p[i];
                res[i] -= alpha * q[i];
            }
            if dot(&res, &res).sqrt() <= eta * r_norm || iterations >= max_iterations {
                break;
            }
            z = res.iter().zip(&d).map(|(a, b)| a / b).collect();
            let rz_new = dot(&res, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..n {
                p[i] = z[i] + beta * p[i];
            }
        }
        // Stay positive: at most 90 % of the way to the boundary.
        let mut step: f64 = 1.0;
        for i in 0..n {
            if active[i] && delta[i] < 0.0 {
                step = step.min(0.9 * x[i] / -delta[i]);
            }
        }
        for i in 0..n {
            if active[i] {
                x[i] += step * delta[i];
            }
        }
    }
    (x, iterations, worst)
}

pub(crate) fn check_areas(area: &[f64], n: usize) -> Result<(), Error> {
    if area.len() != n {
        return Err(Error::LengthMismatch {
            what: "areas",
            len: area.len(),
            n_patches: n,
        });
    }
    if let Some((i, &a)) = area
        .iter()
        .enumerate()
        .find(|(_, a)| !(a.is_finite() && **a > 0.0))
    {
        return Err(Error::BadSurface {
            patch: i as PatchId,
            what: "area",
            value: [a; 3],
            rule: "must be finite and > 0",
        });
    }
    Ok(())
}
