//! The compact form-factor matrix: the pattern of `F ∪ Fᵀ` stored once, as its upper
//! triangle, each position holding both `F_ij` and `F_ji`, built row by row as rows are
//! made (the rows themselves need not be kept), and its reciprocal scaling, which shares
//! the pattern and stores one value a pair.

use crate::matrix::{merge_row, FormFactors};
use crate::operator::{add_scaled, update, Operator};
use crate::scaling::{balance, Reciprocity};
use crate::surfaces::{check_areas, Surfaces};
use crate::Error;
use rad_core::PatchId;
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

/// Where the median (the upper one of an even count) of values counted in a histogram
/// of their leading bits lies: its bin and its place among that bin's values, or `None`
/// when nothing was counted. The median of the reciprocity reports, exactly, without
/// holding every value ([`PairMatrix::reciprocal`], and rows held in parts).
pub fn median_bin(count: &[u64]) -> Option<(usize, usize)> {
    let total: u64 = count.iter().sum();
    if total == 0 {
        return None;
    }
    let rank = total / 2;
    let (mut bin, mut below) = (0, 0);
    while below + count[bin] <= rank {
        below += count[bin];
        bin += 1;
    }
    Some((bin, (rank - below) as usize))
}

/// Row blocks of the reciprocal scaling's parallel products: fixed, so that the sums
/// (each block's, then the blocks' in order) do not depend on the thread count.
const PRODUCT_BLOCKS: usize = 16;

/// The positions: for row `i`, the columns `j > i` where `F_ij` or `F_ji` is stored,
/// increasing.
#[derive(Debug, PartialEq)]
struct Pattern {
    row_start: Vec<usize>,
    column: Vec<PatchId>,
}

impl Pattern {
    #[inline]
    fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.row_start[i]..self.row_start[i + 1]
    }
}

/// For each column `c`, the pairs `(r, c)`, `r < c`, of the pattern: their rows
/// (increasing) and positions. Built on first use (by shooting, which needs whole rows).
#[derive(Debug)]
struct ColumnIndex {
    start: Vec<usize>,
    row: Vec<PatchId>,
    pos: Vec<usize>,
}

/// A square sparse form-factor matrix stored by pairs: for every `i < j` where `F_ij`
/// or `F_ji` is non-zero, one position holding the column `j` (4 bytes) and both values
/// (`f32`, 4 bytes each), or one value when the matrix is symmetric (the reciprocal
/// scaling's `A_i F_ij`); the diagonal apart. Entry `(r, c)` is `value · row_scale[r]`.
///
/// On the loft at 180 × 720 that is 12 bytes a pair for the rows as computed and 4 more
/// for their reciprocal scaling, against 16 bytes an entry (two a pair) for rows as
/// `(PatchId, f64)` and 8 for [`FormFactors`].
///
/// Sums follow [`FormFactors`]' order (each row in column order, the part left of the
/// diagonal gathered from earlier rows as they are passed), so a Gauss-Seidel sweep,
/// a product and a shot give the same bits on either storage of the same values.
#[derive(Debug)]
pub struct PairMatrix {
    pattern: Arc<Pattern>,
    /// Entry `(i, column[p])`, `p` in row `i`'s range.
    upper: Vec<f32>,
    /// Entry `(column[p], i)`; `None`: symmetric, the same as `upper`.
    lower: Option<Vec<f32>>,
    diagonal: Vec<f32>,
    row_scale: Vec<f64>,
    columns: OnceLock<ColumnIndex>,
}

/// Builds a [`PairMatrix`] from rows given in patch order, without keeping them.
#[derive(Debug)]
pub struct PairBuilder {
    n: usize,
    row_start: Vec<usize>,
    column: Vec<PatchId>,
    upper: Vec<f32>,
    lower: Vec<f32>,
    diagonal: Vec<f32>,
    /// Per finished row, the first position whose column has not yet been passed by
    /// the rows being pushed (rows come in order, so each only moves forwards).
    cursor: Vec<usize>,
    /// `(row, column, value)` of lower entries whose pair row `row` does not hold
    /// (`F_{column,row} > 0` where `F_{row,column} = 0`), merged in at the end.
    extra: Vec<(PatchId, PatchId, f32)>,
    scratch: Vec<(PatchId, f64)>,
}

impl PairBuilder {
    pub fn new(n_patches: usize) -> PairBuilder {
        let mut row_start = Vec::with_capacity(n_patches + 1);
        row_start.push(0);
        PairBuilder {
            n: n_patches,
            row_start,
            column: Vec::new(),
            upper: Vec::new(),
            lower: Vec::new(),
            diagonal: vec![0.0; n_patches],
            cursor: Vec::with_capacity(n_patches),
            extra: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// The next row's patch (rows are pushed in order, `0..n_patches`).
    pub fn next_row(&self) -> PatchId {
        (self.row_start.len() - 1) as PatchId
    }

    /// Adds row `patch`, which must be [`PairBuilder::next_row`]. Entries are
    /// `(column, F)` in any order; a column may repeat (its values add). Refuses what
    /// [`FormFactors::from_rows`] refuses, and a row out of order.
    pub fn push_row(&mut self, patch: PatchId, entries: &[(PatchId, f64)]) -> Result<(), Error> {
        let i = self.next_row();
        if patch != i || i as usize >= self.n {
            return Err(if patch < i {
                Error::DuplicateRow { patch }
            } else if (patch as usize) < self.n {
                Error::MissingRow {
                    patch: i,
                    n_patches: self.n,
                }
            } else {
                Error::EntryOutOfRange {
                    row: patch,
                    column: patch,
                    n_patches: self.n,
                }
            });
        }
        let sorted = entries.windows(2).all(|w| w[0].0 < w[1].0);
        let mut scratch = std::mem::take(&mut self.scratch);
        let entries = if sorted {
            entries
        } else {
            scratch.clear();
            scratch.extend_from_slice(entries);
            scratch.sort_by_key(|e| e.0);
            &scratch[..]
        };
        let result = self.push_sorted(i, entries);
        self.scratch = scratch;
        result?;
        self.end_row();
        Ok(())
    }

    fn push_sorted(&mut self, i: PatchId, entries: &[(PatchId, f64)]) -> Result<(), Error> {
        merge_row(i, entries, self.n, |j, f| self.place(i, j, f as f32))
    }

    /// Closes the row being pushed.
    fn end_row(&mut self) {
        self.row_start.push(self.column.len());
        let i = self.cursor.len();
        self.cursor.push(self.row_start[i]);
    }

    /// Stores entry `(i, j)`; row `i` is the one being pushed.
    #[inline]
    fn place(&mut self, i: PatchId, j: PatchId, v: f32) {
        use std::cmp::Ordering::*;
        match j.cmp(&i) {
            Greater => {
                self.column.push(j);
                self.upper.push(v);
                self.lower.push(0.0);
            }
            Equal => self.diagonal[i as usize] = v,
            Less => {
                let (end, cursor) = (self.row_start[j as usize + 1], &mut self.cursor[j as usize]);
                while *cursor < end && self.column[*cursor] < i {
                    *cursor += 1;
                }
                if *cursor < end && self.column[*cursor] == i {
                    self.lower[*cursor] = v;
                } else {
                    self.extra.push((j, i, v));
                }
            }
        }
    }

    /// The matrix, once every row has been pushed.
    pub fn finish(mut self) -> Result<PairMatrix, Error> {
        let next = self.next_row() as usize;
        if next < self.n {
            return Err(Error::MissingRow {
                patch: next as PatchId,
                n_patches: self.n,
            });
        }
        self.cursor = Vec::new();
        self.merge_extra();
        Ok(PairMatrix {
            pattern: Arc::new(Pattern {
                row_start: self.row_start,
                column: self.column,
            }),
            upper: self.upper,
            lower: Some(self.lower),
            diagonal: self.diagonal,
            row_scale: vec![1.0; self.n],
            columns: OnceLock::new(),
        })
    }

    /// Inserts the lower-only entries into their rows, in place (back to front: each
    /// row only moves towards the end).
    fn merge_extra(&mut self) {
        if self.extra.is_empty() {
            return;
        }
        let mut extra = std::mem::take(&mut self.extra);
        extra.sort_unstable_by_key(|e| (e.0, e.1));
        // before[r]: extra entries in rows before r.
        let mut before = vec![0usize; self.n + 1];
        for e in &extra {
            before[e.0 as usize + 1] += 1;
        }
        for r in 0..self.n {
            before[r + 1] += before[r];
        }
        let new_len = self.column.len() + extra.len();
        self.column.resize(new_len, 0);
        self.upper.resize(new_len, 0.0);
        self.lower.resize(new_len, 0.0);
        let mut e = extra.len();
        for row in (0..self.n).rev() {
            let (s, mut r) = (self.row_start[row], self.row_start[row + 1]);
            let mut w = r + before[row + 1];
            while r > s || (e > 0 && extra[e - 1].0 as usize == row) {
                let from_extra = e > 0
                    && extra[e - 1].0 as usize == row
                    && (r == s || extra[e - 1].1 > self.column[r - 1]);
                w -= 1;
                if from_extra {
                    e -= 1;
                    self.column[w] = extra[e].1;
                    self.upper[w] = 0.0;
                    self.lower[w] = extra[e].2;
                } else {
                    r -= 1;
                    self.column[w] = self.column[r];
                    self.upper[w] = self.upper[r];
                    self.lower[w] = self.lower[r];
                }
            }
        }
        for r in 0..=self.n {
            self.row_start[r] += before[r];
        }
    }
}

// (`FormFactors::reciprocal` is made through the pair storage, so it lives here:
// the CSR matrix knows nothing of pairs.)
impl FormFactors {
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
}

impl PairMatrix {
    /// The same matrix, stored by pairs (values and row scales as they are).
    pub fn from_form_factors(ff: &FormFactors) -> PairMatrix {
        let n = ff.n_patches();
        let mut b = PairBuilder::new(n);
        for i in 0..n as PatchId {
            let (c, v) = ff.row(i);
            for (&j, &f) in c.iter().zip(v) {
                b.place(i, j, f);
            }
            b.end_row();
        }
        b.cursor = Vec::new();
        b.merge_extra();
        let symmetric = ff.is_symmetric();
        let mut m = PairMatrix {
            pattern: Arc::new(Pattern {
                row_start: b.row_start,
                column: b.column,
            }),
            upper: b.upper,
            lower: Some(b.lower),
            diagonal: b.diagonal,
            row_scale: (0..n as PatchId).map(|i| ff.row_scale(i)).collect(),
            columns: OnceLock::new(),
        };
        if symmetric {
            m.lower = None;
        }
        m
    }

    /// The same matrix as [`FormFactors`] rows (every stored entry, zeros of a pair's
    /// missing half left out).
    pub fn to_form_factors(&self) -> FormFactors {
        let n = self.n_patches();
        let mut row_start = Vec::with_capacity(n + 1);
        row_start.push(0);
        let mut column = Vec::new();
        let mut value = Vec::new();
        let index = self.column_index();
        let lower = self.lower_values();
        for i in 0..n {
            let (a, b) = (index.start[i], index.start[i + 1]);
            for k in a..b {
                if lower[index.pos[k]] > 0.0 {
                    column.push(index.row[k]);
                    value.push(lower[index.pos[k]]);
                }
            }
            if self.diagonal[i] > 0.0 {
                column.push(i as PatchId);
                value.push(self.diagonal[i]);
            }
            for p in self.pattern.range(i) {
                if self.upper[p] > 0.0 {
                    column.push(self.pattern.column[p]);
                    value.push(self.upper[p]);
                }
            }
            row_start.push(column.len());
        }
        FormFactors::from_parts(
            row_start,
            column,
            value,
            self.row_scale.clone(),
            self.lower.is_none(),
        )
    }

    pub fn n_patches(&self) -> usize {
        self.row_scale.len()
    }

    /// Positions (pairs `i < j` with `F_ij` or `F_ji` stored).
    pub fn n_pairs(&self) -> usize {
        self.pattern.column.len()
    }

    /// Whether the stored values are symmetric ([`PairMatrix::reciprocal`]'s).
    pub fn is_symmetric(&self) -> bool {
        self.lower.is_none()
    }

    /// Bytes of the values and the per-row arrays (the pattern apart: a matrix and its
    /// reciprocal scaling share it).
    pub fn heap_bytes(&self) -> usize {
        let values = if self.lower.is_some() { 8 } else { 4 };
        self.n_pairs() * values + self.n_patches() * (4 + 8)
    }

    /// Bytes of the pattern (columns and row starts).
    pub fn pattern_bytes(&self) -> usize {
        self.n_pairs() * 4 + (self.n_patches() + 1) * 8
    }

    fn lower_values(&self) -> &[f32] {
        self.lower.as_deref().unwrap_or(&self.upper)
    }

    /// `F_ij`, zero where nothing is stored.
    pub fn get(&self, i: PatchId, j: PatchId) -> f64 {
        let (r, c) = (i.min(j) as usize, i.max(j));
        let v = if i == j {
            self.diagonal[i as usize]
        } else {
            let range = self.pattern.range(r);
            match self.pattern.column[range.clone()].binary_search(&c) {
                Ok(k) if i < j => self.upper[range.start + k],
                Ok(k) => self.lower_values()[range.start + k],
                Err(_) => 0.0,
            }
        };
        v as f64 * self.row_scale[i as usize]
    }

    fn column_index(&self) -> &ColumnIndex {
        self.columns.get_or_init(|| {
            let n = self.n_patches();
            let mut start = vec![0usize; n + 1];
            for &c in &self.pattern.column {
                start[c as usize + 1] += 1;
            }
            for k in 0..n {
                start[k + 1] += start[k];
            }
            let mut fill = start.clone();
            let mut row = vec![0 as PatchId; self.n_pairs()];
            let mut pos = vec![0usize; self.n_pairs()];
            for r in 0..n {
                for p in self.pattern.range(r) {
                    let c = self.pattern.column[p] as usize;
                    row[fill[c]] = r as PatchId;
                    pos[fill[c]] = p;
                    fill[c] += 1;
                }
            }
            ColumnIndex { start, row, pos }
        })
    }

    /// Passes the rows in order, each summed in column order: `row(i, s)` gets row i's
    /// part right of and on the diagonal added to `s`, which already holds the part
    /// left of it (what earlier rows' `scatter` gave); `scatter(i)` is the value that
    /// row i's pairs carry down to later rows (`x_i`).
    fn ordered_pass<T: Copy + Default>(
        &self,
        mut gather: impl FnMut(usize, &mut T, f64, usize),
        mut finish: impl FnMut(usize, T) -> T,
        mut scatter: impl FnMut(&mut T, f64, &T),
    ) {
        let n = self.n_patches();
        let lower = self.lower_values();
        let mut acc = vec![T::default(); n];
        for i in 0..n {
            let mut s = acc[i];
            gather(i, &mut s, self.diagonal[i] as f64, i);
            for p in self.pattern.range(i) {
                gather(
                    i,
                    &mut s,
                    self.upper[p] as f64,
                    self.pattern.column[p] as usize,
                );
            }
            let out = finish(i, s);
            for p in self.pattern.range(i) {
                let c = self.pattern.column[p] as usize;
                scatter(&mut acc[c], lower[p] as f64, &out);
            }
        }
    }
}

impl Operator for PairMatrix {
    fn n_patches(&self) -> usize {
        self.row_scale.len()
    }

    fn row_sums(&self) -> Vec<f64> {
        let mut sums = vec![0.0; self.n_patches()];
        self.ordered_pass(
            |_, s: &mut f64, f, _| *s += f,
            |i, s| {
                sums[i] = s * self.row_scale[i];
                1.0
            },
            |a, f, one| *a += f * one,
        );
        sums
    }

    fn apply(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut y = vec![[0.0; 3]; self.n_patches()];
        self.ordered_pass(
            |_, s: &mut [f64; 3], f, j| add_scaled(s, f, &x[j]),
            |i, s| {
                let k = self.row_scale[i];
                y[i] = [s[0] * k, s[1] * k, s[2] * k];
                x[i]
            },
            |a, f, xi| add_scaled(a, f, xi),
        );
        y
    }

    fn sweep(&self, surfaces: &Surfaces, b: &mut [[f64; 3]]) -> (f64, f64) {
        let (mut change, mut scale) = (0.0f64, 0.0f64);
        let n = self.n_patches();
        let lower = self.lower_values();
        let mut acc = vec![[0.0f64; 3]; n];
        for i in 0..n {
            let mut s = acc[i];
            add_scaled(&mut s, self.diagonal[i] as f64, &b[i]);
            let range = self.pattern.range(i);
            for p in range.clone() {
                add_scaled(
                    &mut s,
                    self.upper[p] as f64,
                    &b[self.pattern.column[p] as usize],
                );
            }
            let k = self.row_scale[i];
            let h = [s[0] * k, s[1] * k, s[2] * k];
            update(surfaces, i, h, &mut b[i], &mut change, &mut scale);
            let bi = b[i];
            for p in range {
                add_scaled(
                    &mut acc[self.pattern.column[p] as usize],
                    lower[p] as f64,
                    &bi,
                );
            }
        }
        (change, scale)
    }

    fn shoot<F: FnMut(usize, f64)>(&self, i: PatchId, area: &[f64], mut f: F) {
        let i = i as usize;
        let index = self.column_index();
        let lower = self.lower_values();
        let symmetric = self.is_symmetric();
        let scale_i = self.row_scale[i];
        let mut give = |j: usize, v: f32| {
            let k = if symmetric {
                v as f64 * self.row_scale[j]
            } else {
                v as f64 * scale_i * area[i] / area[j]
            };
            f(j, k)
        };
        for k in index.start[i]..index.start[i + 1] {
            let v = lower[index.pos[k]];
            if v > 0.0 {
                give(index.row[k] as usize, v);
            }
        }
        if self.diagonal[i] > 0.0 {
            give(i, self.diagonal[i]);
        }
        for p in self.pattern.range(i) {
            if self.upper[p] > 0.0 {
                give(self.pattern.column[p] as usize, self.upper[p]);
            }
        }
    }
}

impl PairMatrix {
    /// The exactly reciprocal matrix closest to this one that keeps each row's sum:
    /// what [`FormFactors::reciprocal`] gives (it calls this), stored by pairs with one
    /// `f32` a pair, sharing this matrix's pattern.
    ///
    /// `G_ij = (A_i F_ij + A_j F_ji) / 2` is formed pair by pair as it is needed, never
    /// stored; its products run on fixed row blocks, so the scaling does not depend on
    /// the thread count.
    pub fn reciprocal(
        &self,
        area: &[f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<(PairMatrix, Reciprocity), Error> {
        let n = self.n_patches();
        check_areas(area, n)?;
        let sums = self.row_sums();
        let target: Vec<f64> = (0..n).map(|i| area[i] * sums[i]).collect();
        let blocks = self.blocks(PRODUCT_BLOCKS);
        let (x, iterations, worst) = balance(
            n,
            |x| self.g_product(area, x, &blocks),
            &target,
            tolerance,
            max_iterations,
        );
        if x.iter()
            .zip(&target)
            .any(|(v, &t)| !v.is_finite() || (t > 0.0 && *v <= 0.0))
        {
            return Err(Error::NoReciprocalScaling { iterations });
        }
        let row_scale: Vec<f64> = area.iter().map(|a| 1.0 / a).collect();
        let lower = self.lower_values();
        // x_i x_j commutes exactly, so the stored value is symmetric bit for bit.
        let mut value = vec![0.0f32; self.n_pairs()];
        let mut per_row: Vec<&mut [f32]> = Vec::with_capacity(n);
        let mut rest = &mut value[..];
        for i in 0..n {
            let (head, tail) = rest.split_at_mut(self.pattern.range(i).len());
            per_row.push(head);
            rest = tail;
        }
        // Each row: its stored values and its total change.
        let changes: Vec<f64> = per_row
            .into_par_iter()
            .enumerate()
            .map(|(i, out)| {
                let mut change = 0.0;
                for (k, p) in self.pattern.range(i).enumerate() {
                    let j = self.pattern.column[p] as usize;
                    let (a, b) = self.g_terms(area, i, p, lower);
                    let s = (0.5 * (a + b) * (x[i] * x[j])) as f32;
                    out[k] = s;
                    change += (s as f64 * row_scale[i] - self.upper[p] as f64 * self.row_scale[i])
                        .abs()
                        + (s as f64 * row_scale[j] - lower[p] as f64 * self.row_scale[j]).abs();
                }
                change
            })
            .collect();
        let diagonal: Vec<f32> = (0..n)
            .map(|i| {
                let g = area[i] * self.diagonal[i] as f64 * self.row_scale[i];
                (g * (x[i] * x[i])) as f32
            })
            .collect();
        let m = PairMatrix {
            pattern: Arc::clone(&self.pattern),
            upper: value,
            lower: None,
            diagonal,
            row_scale,
            columns: OnceLock::new(),
        };
        let mut change = 0.0;
        for (i, c) in changes.into_iter().enumerate() {
            change += c
                + (m.diagonal[i] as f64 * m.row_scale[i]
                    - self.diagonal[i] as f64 * self.row_scale[i])
                    .abs();
        }
        let (max_input_asymmetry, median_input_asymmetry) = self.asymmetry(area);
        let new_sums = m.row_sums();
        let max_row_sum_error = new_sums
            .iter()
            .zip(&sums)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let report = Reciprocity {
            max_input_asymmetry,
            median_input_asymmetry,
            mean_row_l1_change: change / n.max(1) as f64,
            max_row_sum_error,
            iterations,
            converged: worst <= tolerance,
        };
        Ok((m, report))
    }

    /// The largest and the median (the upper one of an even count) relative asymmetry
    /// `|A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji)` over the pairs where both are at
    /// least 1e-4 of the smaller area, exactly, without holding them: a histogram of
    /// their leading bits finds the median's bin, whose values alone are then sorted.
    fn asymmetry(&self, area: &[f64]) -> (f64, f64) {
        const SHIFT: u32 = 48;
        let lower = self.lower_values();
        let each = |i: usize, f: &mut dyn FnMut(f64)| {
            for p in self.pattern.range(i) {
                let j = self.pattern.column[p] as usize;
                let (a, b) = self.g_terms(area, i, p, lower);
                if a.min(b) >= 1e-4 * area[i].min(area[j]) {
                    f((a - b).abs() / a.max(b));
                }
            }
        };
        let n = self.n_patches();
        let bins = 1usize << (64 - SHIFT);
        let (count, max) = (0..n)
            .into_par_iter()
            .fold(
                || (vec![0u64; bins], 0.0f64),
                |(mut h, mut m), i| {
                    each(i, &mut |v| {
                        h[(v.to_bits() >> SHIFT) as usize] += 1;
                        m = m.max(v);
                    });
                    (h, m)
                },
            )
            .reduce(
                || (vec![0u64; bins], 0.0),
                |(mut a, ma), (b, mb)| {
                    a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
                    (a, ma.max(mb))
                },
            );
        let Some((bin, k)) = median_bin(&count) else {
            return (0.0, 0.0);
        };
        let mut inside = Vec::with_capacity(count[bin] as usize);
        for i in 0..n {
            each(i, &mut |v| {
                if (v.to_bits() >> SHIFT) as usize == bin {
                    inside.push(v);
                }
            });
        }
        let (_, median, _) = inside.select_nth_unstable_by(k, f64::total_cmp);
        (max, *median)
    }

    /// The two halves of `2 G` at position `p` of row `i`: `(A_i F_ij, A_j F_ji)`.
    #[inline(always)]
    fn g_terms(&self, area: &[f64], i: usize, p: usize, lower: &[f32]) -> (f64, f64) {
        let j = self.pattern.column[p] as usize;
        (
            area[i] * self.upper[p] as f64 * self.row_scale[i],
            area[j] * lower[p] as f64 * self.row_scale[j],
        )
    }

    /// `count` ranges of rows holding about as many pairs each.
    fn blocks(&self, count: usize) -> Vec<std::ops::Range<usize>> {
        let n = self.n_patches();
        let total = self.n_pairs() + n;
        let mut out = Vec::with_capacity(count);
        let mut start = 0;
        for b in 1..=count {
            let want = total * b / count;
            let mut end = start;
            while end < n && self.pattern.row_start[end] + end < want {
                end += 1;
            }
            if b == count {
                end = n;
            }
            out.push(start..end);
            start = end;
        }
        out
    }

    /// `G x`, G symmetric from both halves of every pair: each block of rows gathers
    /// its rows' upper parts and scatters their transposes into a buffer of its own;
    /// the buffers are added in block order.
    fn g_product(&self, area: &[f64], x: &[f64], blocks: &[std::ops::Range<usize>]) -> Vec<f64> {
        let n = self.n_patches();
        let lower = self.lower_values();
        let unit_scales = self.row_scale.iter().all(|&s| s == 1.0);
        let parts: Vec<(Vec<f64>, Vec<f64>)> = blocks
            .par_iter()
            .map(|rows| {
                let mut gathered = Vec::with_capacity(rows.len());
                let mut scattered = vec![0.0f64; n];
                for i in rows.clone() {
                    let g_ii = area[i] * self.diagonal[i] as f64 * self.row_scale[i];
                    let xi = x[i];
                    let range = self.pattern.range(i);
                    // Four partial sums (a fixed order: the same whatever the threads).
                    let mut s = [g_ii * xi, 0.0, 0.0, 0.0];
                    if unit_scales {
                        // (A_i F_ij) · 1 is A_i F_ij: the same g as `g_terms` gives.
                        let (ai, cols) = (area[i], &self.pattern.column[range.clone()]);
                        let (up, lo) = (&self.upper[range.clone()], &lower[range]);
                        for k in 0..cols.len() {
                            let j = cols[k] as usize;
                            let g = 0.5 * (ai * up[k] as f64 + area[j] * lo[k] as f64);
                            s[k & 3] += g * x[j];
                            scattered[j] += g * xi;
                        }
                    } else {
                        for (k, p) in range.enumerate() {
                            let j = self.pattern.column[p] as usize;
                            let (a, b) = self.g_terms(area, i, p, lower);
                            let g = 0.5 * (a + b);
                            s[k & 3] += g * x[j];
                            scattered[j] += g * xi;
                        }
                    }
                    gathered.push((s[0] + s[1]) + (s[2] + s[3]));
                }
                (gathered, scattered)
            })
            .collect();
        let mut y: Vec<f64> = parts.iter().flat_map(|p| p.0.iter().copied()).collect();
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            for (_, scattered) in &parts {
                *yi += scattered[i];
            }
        });
        y
    }
}
