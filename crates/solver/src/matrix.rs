//! The sparse form-factor matrix (CSR) and its reciprocal, row-sum-keeping version.

use crate::operator::{add_scaled, update, Operator};
use crate::solve::Surfaces;
use crate::{Error, PairMatrix};
use rad_core::PatchId;
use rayon::prelude::*;

/// Rows may sum to this much over 1 (accumulation round-off) before they are refused.
pub(crate) const ROW_SUM_SLACK: f64 = 1e-6;

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
            merge_row(i as PatchId, &scratch, n_patches, |j, f| {
                column.push(j);
                value.push(f as f32);
            })?;
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
            add_scaled(&mut s, f as f64, &x[j as usize]);
        }
        let k = self.row_scale[i as usize];
        [s[0] * k, s[1] * k, s[2] * k]
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
        let (m, report) =
            PairMatrix::from_form_factors(self).reciprocal(area, tolerance, max_iterations)?;
        Ok((m.to_form_factors(), report))
    }

    /// A matrix from its arrays (their invariants hold: the pair storage's conversion).
    pub(crate) fn from_parts(
        row_start: Vec<usize>,
        column: Vec<PatchId>,
        value: Vec<f32>,
        row_scale: Vec<f64>,
        symmetric: bool,
    ) -> FormFactors {
        FormFactors {
            row_start,
            column,
            value,
            row_scale,
            symmetric,
        }
    }
}

impl Operator for FormFactors {
    fn n_patches(&self) -> usize {
        FormFactors::n_patches(self)
    }

    fn row_sums(&self) -> Vec<f64> {
        (0..self.n_patches() as PatchId)
            .map(|i| self.row_sum(i))
            .collect()
    }

    fn apply(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        FormFactors::apply(self, x)
    }

    fn sweep(&self, surfaces: &Surfaces, b: &mut [[f64; 3]]) -> (f64, f64) {
        let (mut change, mut scale) = (0.0f64, 0.0f64);
        for i in 0..self.n_patches() {
            let h = self.row_dot(i as PatchId, b);
            update(surfaces, i, h, &mut b[i], &mut change, &mut scale);
        }
        (change, scale)
    }

    fn shoot<F: FnMut(usize, f64)>(&self, i: PatchId, area: &[f64], mut f: F) {
        let (cols, vals) = self.row(i);
        let row_scale = self.row_scale(i);
        let i = i as usize;
        for (&j, &v) in cols.iter().zip(vals) {
            let j = j as usize;
            // F_ji: exact from symmetric storage, else by reciprocity from F_ij.
            let k = if self.symmetric {
                v as f64 * self.row_scale[j]
            } else {
                v as f64 * row_scale * area[i] / area[j]
            };
            f(j, k);
        }
    }
}

/// Walks row `i`'s entries, sorted by column, adding the values of a repeated column:
/// refuses a column out of range, a negative or non-finite value and a row summing to
/// more than `1 + ROW_SUM_SLACK`; calls `keep(j, F_ij)` for every positive sum, in
/// column order (the rows as [`FormFactors::from_rows`] and the pair builder take them).
pub(crate) fn merge_row(
    i: PatchId,
    sorted: &[(PatchId, f64)],
    n_patches: usize,
    mut keep: impl FnMut(PatchId, f64),
) -> Result<(), Error> {
    let mut sum = 0.0;
    let mut k = 0;
    while k < sorted.len() {
        let (j, mut f) = sorted[k];
        let bad = |value| Error::BadValue {
            row: i,
            column: j,
            value,
        };
        if j as usize >= n_patches {
            return Err(Error::EntryOutOfRange {
                row: i,
                column: j,
                n_patches,
            });
        }
        if !(f.is_finite() && f >= 0.0) {
            return Err(bad(f));
        }
        k += 1;
        while k < sorted.len() && sorted[k].0 == j {
            let g = sorted[k].1;
            if !(g.is_finite() && g >= 0.0) {
                return Err(bad(g));
            }
            f += g;
            k += 1;
        }
        sum += f;
        if f > 0.0 {
            keep(j, f);
        }
    }
    if sum > 1.0 + ROW_SUM_SLACK {
        return Err(Error::RowSumAboveOne { row: i, sum });
    }
    Ok(())
}

/// The scaling x with `x ∘ (G x) = target` (to `tolerance` relative, at most
/// `max_iterations` products by G), G given by its product `spmv`: (x, products made, the
/// largest relative error left).
pub(crate) fn balance(
    n: usize,
    spmv: impl Fn(&[f64]) -> Vec<f64>,
    target: &[f64],
    tolerance: f64,
    max_iterations: usize,
) -> (Vec<f64>, usize, f64) {
    let product = |x: &[f64]| Ok::<_, std::convert::Infallible>(spmv(x));
    match reciprocal_scaling(n, product, target, tolerance, max_iterations) {
        Ok(done) => done,
        Err(never) => match never {},
    }
}

/// The scaling x with `x ∘ (G x) = target`, G given by a product that may fail (one
/// made by several processes, say, each its rows): what [`FormFactors::reciprocal`]
/// and [`crate::PairMatrix::reciprocal`] solve, for callers that hold G in parts
/// ([`crate::RowSet`]). `(x, products made, the largest relative error left)`; every
/// sum in a fixed order, so the same products give the same x.
pub fn reciprocal_scaling<E>(
    n: usize,
    mut spmv: impl FnMut(&[f64]) -> Result<Vec<f64>, E>,
    target: &[f64],
    tolerance: f64,
    max_iterations: usize,
) -> Result<(Vec<f64>, usize, f64), E> {
    // Newton's method on x ∘ (G x) = t, each step solved by preconditioned conjugate
    // gradients (Knight & Ruiz's balancing idea): the Jacobian divided by x,
    // diag(Gx / x) + G, is symmetric positive semi-definite. Patches with t = 0 keep
    // x = 0. `iterations` counts products by G.
    let active: Vec<bool> = target.iter().map(|&t| t > 0.0).collect();
    let mut x: Vec<f64> = active.iter().map(|&a| if a { 1.0 } else { 0.0 }).collect();
    let dot = |a: &[f64], b: &[f64]| -> f64 { a.iter().zip(b).map(|(p, q)| p * q).sum() };
    let mut iterations = 0;
    let mut worst;
    loop {
        let gx = spmv(&x)?;
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
        // Solve only as far as the step can use: to a tenth of the tolerance at the end.
        let eta = worst.sqrt().max(0.1 * tolerance / worst).min(0.5);
        let mut delta = vec![0.0; n];
        let mut res = r;
        let mut z: Vec<f64> = res.iter().zip(&d).map(|(a, b)| a / b).collect();
        let mut p = z.clone();
        let mut rz = dot(&res, &z);
        for _ in 0..200 {
            let gp = spmv(&p)?;
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
    Ok((x, iterations, worst))
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
