//! The sparse form-factor matrix (CSR) and its reciprocal, row-sum-keeping version.

use crate::operator::{add_scaled, update, Operator};
use crate::surfaces::Surfaces;
use crate::Error;
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
