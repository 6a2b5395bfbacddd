//! Some rows of a form-factor matrix, each entry with its transpose's value: what a
//! process holds of a solve shared by rows. Nothing here communicates; the caller moves
//! the transposes ([`RowSet::transposes`]) and the vectors between the processes.

use crate::matrix::merge_row;
use crate::Error;
use rad_core::PatchId;
use rayon::prelude::*;

/// Some rows of a square form-factor matrix (any set of rows: one process's share),
/// each entry `(i, j)` holding `F_ij` as computed and, once the transposes are in
/// ([`RowSet::add_transposes`], [`RowSet::finish_transposes`]), `F_ji` too; [`RowSet::make_reciprocal`] then replaces
/// `F_ji` by the reciprocal matrix's `A_i F'_ij` (which is `A_j F'_ji`, bit for bit on the
/// holder of row j), so that the scaling and a Jacobi solve need of the other rows only
/// vectors: the scaling's x, the radiosities.
///
/// The values are those of [`crate::PairMatrix`] (`f32`, the reciprocal one
/// `(½ (A_i F_ij + A_j F_ji) x_i x_j) as f32`, entry `(i, j)` that times `1 / A_i`); every
/// row is summed in column order and rows are independent, so what a `RowSet` gives does
/// not depend on how the rows are shared or on the thread count. 12 bytes an entry.
#[derive(Debug)]
pub struct RowSet {
    n: usize,
    /// The rows held, increasing.
    held: Vec<PatchId>,
    /// Row `held[k]`'s entries: `start[k]..start[k + 1]`.
    start: Vec<usize>,
    column: Vec<PatchId>,
    /// `F_ij` as computed.
    value: Vec<f32>,
    /// `F_ji` (after [`RowSet::add_transposes`]), then `A_i F'_ij` (after
    /// [`RowSet::make_reciprocal`]).
    other: Vec<f32>,
    /// `1 / A_i` of each held row, once reciprocal.
    scale: Option<Vec<f64>>,
    /// Positions only a transpose holds: (held row, column, `F_ji`), merged in once.
    pending: Vec<(u32, PatchId, f32)>,
    transposed: bool,
}

/// Bytes of one transposed entry: row, column, value.
const TRANSPOSE_BYTES: usize = 12;

impl RowSet {
    /// No rows yet, of a matrix of `n_patches`.
    pub fn new(n_patches: usize) -> RowSet {
        RowSet {
            n: n_patches,
            held: Vec::new(),
            start: vec![0],
            column: Vec::new(),
            value: Vec::new(),
            other: Vec::new(),
            scale: None,
            pending: Vec::new(),
            transposed: false,
        }
    }

    /// Adds row `patch`, after every row held so far (rows come in increasing order).
    /// Entries are `(column, F)` in any order; a column may repeat (its values add).
    /// Refuses what [`crate::PairBuilder::push_row`] refuses.
    pub fn push_row(&mut self, patch: PatchId, entries: &[(PatchId, f64)]) -> Result<(), Error> {
        if patch as usize >= self.n {
            return Err(Error::EntryOutOfRange {
                row: patch,
                column: patch,
                n_patches: self.n,
            });
        }
        if self.held.last().is_some_and(|&last| last >= patch) {
            return Err(Error::DuplicateRow { patch });
        }
        if self.transposed || !self.pending.is_empty() {
            return Err(bad_transposes(format!(
                "row {patch} pushed after the transposes"
            )));
        }
        let copy;
        let sorted = if entries.windows(2).all(|w| w[0].0 <= w[1].0) {
            entries
        } else {
            let mut c = entries.to_vec();
            c.sort_by_key(|e| e.0);
            copy = c;
            &copy[..]
        };
        let (column, value) = (&mut self.column, &mut self.value);
        let merged = merge_row(patch, sorted, self.n, |j, f| {
            column.push(j);
            value.push(f as f32);
        });
        if let Err(e) = merged {
            // (A row refused part-way leaves nothing behind.)
            let end = *self.start.last().unwrap_or(&0);
            self.column.truncate(end);
            self.value.truncate(end);
            return Err(e);
        }
        self.other.resize(self.value.len(), 0.0);
        self.held.push(patch);
        self.start.push(self.column.len());
        Ok(())
    }

    /// The rows held, increasing.
    pub fn held(&self) -> &[PatchId] {
        &self.held
    }

    /// Entries held (after the transposes: of `F ∪ Fᵀ`'s pattern in the rows held).
    pub fn n_entries(&self) -> usize {
        self.column.len()
    }

    /// Pairs `i < j` of the pattern whose row `i` is held: summed over a run's sets,
    /// [`crate::PairMatrix::n_pairs`].
    pub fn n_upper(&self) -> usize {
        (0..self.held.len())
            .map(|k| {
                let i = self.held[k];
                self.columns(k).iter().filter(|&&j| j > i).count()
            })
            .sum()
    }

    /// Bytes of its rows: 12 an entry (column, value, transpose) and 20 a row (its
    /// patch, start and scale), so that the sets of one matrix add up to the same
    /// figure however its rows are shared.
    pub fn bytes(&self) -> usize {
        self.column.len() * 12 + self.held.len() * 20
    }

    /// Bytes on the heap (capacities included).
    pub fn heap_bytes(&self) -> usize {
        self.held.capacity() * 4
            + self.start.capacity() * 8
            + self.column.capacity() * 4
            + (self.value.capacity() + self.other.capacity()) * 4
            + self.scale.as_ref().map_or(0, |s| s.capacity() * 8)
            + self.pending.capacity() * 12
    }

    fn columns(&self, k: usize) -> &[PatchId] {
        &self.column[self.start[k]..self.start[k + 1]]
    }

    /// For each of `parts` holders, the transposes of the entries of held rows
    /// `rows` (places in [`RowSet::held`]; `owner(j)` is the holder of row j), as bytes
    /// for [`RowSet::add_transposes`]: `(j, i, F_ij)` for each entry `(i, j)` whose row
    /// j is held elsewhere (rows held here are matched by
    /// [`RowSet::finish_transposes`]). Sent in rounds of rows, they need little memory.
    pub fn transposes(
        &self,
        rows: std::ops::Range<usize>,
        owner: &dyn Fn(PatchId) -> usize,
        parts: usize,
    ) -> Result<Vec<Vec<u8>>, Error> {
        if rows.start > rows.end || rows.end > self.held.len() {
            return Err(bad_transposes(format!(
                "rows {rows:?} of {} held",
                self.held.len()
            )));
        }
        let here = self.local_index();
        let mut out = vec![Vec::new(); parts];
        for k in rows {
            let i = self.held[k];
            for p in self.start[k]..self.start[k + 1] {
                let j = self.column[p];
                if here[j as usize] == u32::MAX {
                    let to = owner(j);
                    let Some(b) = out.get_mut(to) else {
                        return Err(bad_transposes(format!(
                            "row {j}'s holder is {to}, not one of {parts}"
                        )));
                    };
                    b.extend_from_slice(&j.to_le_bytes());
                    b.extend_from_slice(&i.to_le_bytes());
                    b.extend_from_slice(&self.value[p].to_le_bytes());
                }
            }
        }
        Ok(out)
    }

    /// Each patch's place among the rows held, or `u32::MAX`.
    fn local_index(&self) -> Vec<u32> {
        let mut local = vec![u32::MAX; self.n];
        for (k, &i) in self.held.iter().enumerate() {
            local[i as usize] = k as u32;
        }
        local
    }

    /// Takes in other holders' [`RowSet::transposes`] for this set (`parts`, any
    /// number; as many times as rounds come): each entry `(i, j)` named gets `F_ji`,
    /// and positions where only `F_ji` is non-zero are kept for
    /// [`RowSet::finish_transposes`]. Bytes that are not whole transposes, or that
    /// name a row not held here or a source row held here, are an error.
    pub fn add_transposes(&mut self, parts: &[Vec<u8>]) -> Result<(), Error> {
        if self.transposed {
            return Err(bad_transposes("transposes after the last".into()));
        }
        let local = self.local_index();
        for (from, part) in parts.iter().enumerate() {
            if part.len() % TRANSPOSE_BYTES != 0 {
                return Err(bad_transposes(format!(
                    "part {from}: {} bytes, not whole entries",
                    part.len()
                )));
            }
            for e in part.chunks_exact(TRANSPOSE_BYTES) {
                let word = |a: usize| u32::from_le_bytes(e[a..a + 4].try_into().unwrap());
                let (row, col, v) = (word(0), word(4), f32::from_bits(word(8)));
                let k = local.get(row as usize).copied().unwrap_or(u32::MAX);
                let elsewhere = local.get(col as usize).is_some_and(|&c| c == u32::MAX);
                let problem = if k == u32::MAX {
                    Some("is not of a row held here")
                } else if !elsewhere {
                    Some("comes from a row held here")
                } else if !(v.is_finite() && v >= 0.0) {
                    Some("is not a finite value >= 0")
                } else {
                    None
                };
                if let Some(problem) = problem {
                    return Err(bad_transposes(format!(
                        "part {from}: entry ({row}, {col}) = {v} {problem}"
                    )));
                }
                match find(&self.start, &self.column, k as usize, col) {
                    Some(q) => self.other[q] = v,
                    None => self.pending.push((k, col, v)),
                }
            }
        }
        Ok(())
    }

    /// Once every holder's transposes are in: matches the entries between rows held
    /// here (each entry `(i, j)` gets `F_ji`) and adds, in place, every position only a
    /// transpose holds (with `F_ij = 0`).
    pub fn finish_transposes(&mut self) -> Result<(), Error> {
        if self.transposed {
            return Err(bad_transposes("finished twice".into()));
        }
        let local = self.local_index();
        // Rows held here, pulled in parallel, in place: row j's entry (j, i) takes F_ij
        // from row i; an entry (i, j) whose row j lacks i is a position row j gains.
        let (column, value, start, held) = (&self.column, &self.value, &self.start, &self.held);
        let mut rows: Vec<&mut [f32]> = Vec::with_capacity(held.len());
        let mut rest = &mut self.other[..];
        for k in 0..held.len() {
            let (head, tail) = rest.split_at_mut(start[k + 1] - start[k]);
            rows.push(head);
            rest = tail;
        }
        let extras: Vec<Vec<(u32, PatchId, f32)>> = rows
            .into_par_iter()
            .enumerate()
            .map(|(k, other)| {
                let j = held[k];
                let mut extra = Vec::new();
                for (o, p) in other.iter_mut().zip(start[k]..start[k + 1]) {
                    let ki = local[column[p] as usize];
                    if ki == u32::MAX {
                        continue;
                    }
                    match find(start, column, ki as usize, j) {
                        Some(q) => *o = value[q],
                        None => extra.push((ki, j, value[p])),
                    }
                }
                extra
            })
            .collect();
        let mut extra = std::mem::take(&mut self.pending);
        extra.extend(extras.into_iter().flatten());
        self.transposed = true;
        if !extra.is_empty() {
            self.merge_extra(extra)?;
        }
        Ok(())
    }

    /// Inserts the positions only the transposes hold, in place (back to front: each
    /// row only moves towards the end), each row staying in column order.
    fn merge_extra(&mut self, mut extra: Vec<(u32, PatchId, f32)>) -> Result<(), Error> {
        extra.sort_unstable_by_key(|e| (e.0, e.1));
        if let Some(w) = extra
            .windows(2)
            .find(|w| (w[0].0, w[0].1) == (w[1].0, w[1].1))
        {
            return Err(bad_transposes(format!(
                "the transpose of ({}, {}) came twice",
                w[0].1, self.held[w[0].0 as usize]
            )));
        }
        let rows = self.held.len();
        let mut before = vec![0usize; rows + 1];
        for e in &extra {
            before[e.0 as usize + 1] += 1;
        }
        for k in 0..rows {
            before[k + 1] += before[k];
        }
        let new_len = self.column.len() + extra.len();
        self.column.resize(new_len, 0);
        self.value.resize(new_len, 0.0);
        self.other.resize(new_len, 0.0);
        let mut e = extra.len();
        for k in (0..rows).rev() {
            let (s, mut r) = (self.start[k], self.start[k + 1]);
            let mut w = r + before[k + 1];
            while r > s || (e > 0 && extra[e - 1].0 as usize == k) {
                let from_extra = e > 0
                    && extra[e - 1].0 as usize == k
                    && (r == s || extra[e - 1].1 > self.column[r - 1]);
                w -= 1;
                if from_extra {
                    e -= 1;
                    (self.column[w], self.value[w], self.other[w]) = (extra[e].1, 0.0, extra[e].2);
                } else {
                    r -= 1;
                    (self.column[w], self.value[w], self.other[w]) =
                        (self.column[r], self.value[r], self.other[r]);
                }
            }
        }
        for (s, b) in self.start.iter_mut().zip(&before) {
            *s += b;
        }
        Ok(())
    }

    /// `Σ_j F_ij` of each held row as computed, in column order.
    pub fn row_sums(&self) -> Vec<f64> {
        self.per_row(|k| {
            let r = self.start[k]..self.start[k + 1];
            self.value[r].iter().map(|&v| v as f64).sum()
        })
    }

    /// `(G x)_i` of each held row, `G_ij = ½ (A_i F_ij + A_j F_ji)` (the symmetric matrix
    /// the reciprocal scaling balances), in column order.
    pub fn g_product(&self, area: &[f64], x: &[f64]) -> Result<Vec<f64>, Error> {
        self.check_len("areas", area.len())?;
        self.check_len("a scaling", x.len())?;
        Ok(self.per_row(|k| {
            let ai = area[self.held[k] as usize];
            let mut s = 0.0;
            for p in self.start[k]..self.start[k + 1] {
                let j = self.column[p] as usize;
                let g = 0.5 * (ai * self.value[p] as f64 + area[j] * self.other[p] as f64);
                s += g * x[j];
            }
            s
        }))
    }

    fn check_len(&self, what: &'static str, len: usize) -> Result<(), Error> {
        if len != self.n {
            return Err(Error::LengthMismatch {
                what,
                len,
                n_patches: self.n,
            });
        }
        Ok(())
    }

    /// Calls `f` with `|A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji)` of each pair
    /// `i < j` whose row `i` is held, where both are at least 1e-4 of the smaller area:
    /// the values [`crate::PairMatrix::reciprocal`] reports the median and largest of.
    pub fn for_each_asymmetry(&self, area: &[f64], f: &mut dyn FnMut(f64)) -> Result<(), Error> {
        self.check_len("areas", area.len())?;
        for (k, &i) in self.held.iter().enumerate() {
            let i = i as usize;
            for p in self.start[k]..self.start[k + 1] {
                let j = self.column[p] as usize;
                if j > i {
                    let a = area[i] * self.value[p] as f64;
                    let b = area[j] * self.other[p] as f64;
                    if a.min(b) >= 1e-4 * area[i].min(area[j]) {
                        f((a - b).abs() / a.max(b));
                    }
                }
            }
        }
        Ok(())
    }

    /// Makes the held rows those of the reciprocal matrix of scaling `x` (from
    /// [`crate::reciprocal_scaling`] on [`RowSet::g_product`]): each row's change, the
    /// sum of `|F'_ij − F_ij|` over its entries.
    pub fn make_reciprocal(&mut self, area: &[f64], x: &[f64]) -> Result<Vec<f64>, Error> {
        if !self.transposed || self.scale.is_some() {
            return Err(bad_transposes(
                "the reciprocal rows need the transposes, once".into(),
            ));
        }
        self.check_len("areas", area.len())?;
        self.check_len("a scaling", x.len())?;
        let scale: Vec<f64> = self.held.iter().map(|&i| 1.0 / area[i as usize]).collect();
        let mut change = vec![0.0; self.held.len()];
        for (k, &i) in self.held.iter().enumerate() {
            let i = i as usize;
            for p in self.start[k]..self.start[k + 1] {
                let j = self.column[p] as usize;
                let (a, b) = (
                    area[i] * self.value[p] as f64,
                    area[j] * self.other[p] as f64,
                );
                let s = (0.5 * (a + b) * (x[i] * x[j])) as f32;
                self.other[p] = s;
                change[k] += (s as f64 * scale[k] - self.value[p] as f64).abs();
            }
        }
        self.scale = Some(scale);
        Ok(change)
    }

    /// `(F b)_i` of each held row: the rows as computed, or (`reciprocal`) the
    /// reciprocal ones, in column order.
    pub fn apply(&self, b: &[[f64; 3]], reciprocal: bool) -> Result<Vec<[f64; 3]>, Error> {
        let scale = self.reciprocal_scale(reciprocal)?;
        self.check_len("radiosities", b.len())?;
        let values = if reciprocal { &self.other } else { &self.value };
        Ok(self.per_row(|k| {
            let mut s = [0.0f64; 3];
            for p in self.start[k]..self.start[k + 1] {
                let (f, bj) = (values[p] as f64, &b[self.column[p] as usize]);
                s[0] += f * bj[0];
                s[1] += f * bj[1];
                s[2] += f * bj[2];
            }
            let m = scale.map_or(1.0, |s| s[k]);
            [s[0] * m, s[1] * m, s[2] * m]
        }))
    }

    /// `Σ_j F'_ij` of each held reciprocal row, in column order.
    pub fn reciprocal_row_sums(&self) -> Result<Vec<f64>, Error> {
        let scale = self.reciprocal_scale(true)?.unwrap_or(&[]);
        Ok(self.per_row(|k| {
            let r = self.start[k]..self.start[k + 1];
            self.other[r].iter().map(|&v| v as f64).sum::<f64>() * scale[k]
        }))
    }

    fn reciprocal_scale(&self, reciprocal: bool) -> Result<Option<&[f64]>, Error> {
        match (reciprocal, &self.scale) {
            (false, _) => Ok(None),
            (true, Some(s)) => Ok(Some(s)),
            (true, None) => Err(bad_transposes("no reciprocal rows yet".into())),
        }
    }

    /// `f(k)` of each held row `k`, in parallel (each row on its own: the same whatever
    /// the threads).
    fn per_row<T: Send>(&self, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
        (0..self.held.len()).into_par_iter().map(&f).collect()
    }
}

/// Position of column `c` in row `k` of `(start, column)`, if the row holds it.
fn find(start: &[usize], column: &[PatchId], k: usize, c: PatchId) -> Option<usize> {
    let r = start[k]..start[k + 1];
    let q = column[r.clone()].binary_search(&c).ok()?;
    Some(r.start + q)
}

fn bad_transposes(reason: String) -> Error {
    Error::RowSet { reason }
}
