//! Enclosure rules on a surface-to-surface view-factor matrix (f64, any size): raw
//! rows, reciprocity enforced keeping each row's sum, or reciprocity with unit row sums
//! for a closed enclosure (what View3D's `encl=1` and EnergyPlus's view-factor fixing
//! ask for), with the largest change each made and the distribution of the raw errors.

use crate::scaling::balance;
use crate::Error;

/// How a view-factor matrix is made to obey the enclosure rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Enclosure {
    /// As computed.
    Raw,
    /// `A_I F_IJ = A_J F_JI` exactly, each row keeping its sum: F' = X G X / A with G
    /// the symmetric part of `A_I F_IJ` and X diagonal (the solver's reciprocal scaling).
    Reciprocal,
    /// Reciprocity and every row summing to 1: the same scaling with unit targets. Only
    /// for a closed scene: a row whose raw sum (with what is blocked, see
    /// [`SurfaceMatrix::enforce_blocked`]) is below `1 − LEAK_TOLERANCE` leaks.
    Closed,
}

impl Enclosure {
    pub const ALL: [Enclosure; 3] = [Enclosure::Raw, Enclosure::Reciprocal, Enclosure::Closed];

    /// Its stable name: `raw`, `reciprocal` or `closed`.
    pub fn name(self) -> &'static str {
        match self {
            Enclosure::Raw => "raw",
            Enclosure::Reciprocal => "reciprocal",
            Enclosure::Closed => "closed",
        }
    }
}

/// A row of a closed enclosure sums to 1 up to the hemisphere's rounding; one that
/// misses more than this (rays escaping, or meeting the backs of polygons) leaks.
pub const LEAK_TOLERANCE: f64 = 1e-3;

/// Relative tolerance of the scaling's row sums (reached in a few Newton steps).
const SCALING_TOLERANCE: f64 = 1e-13;
const SCALING_MAX_PRODUCTS: usize = 5000;

/// A surface-to-surface matrix: `rows[I]` holds `(J, F_IJ)` sorted by J, each surface
/// with its area.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceMatrix {
    pub area: Vec<f64>,
    pub rows: Vec<Vec<(u32, f64)>>,
}

/// Quantiles of an error over rows or pairs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorQuantiles {
    pub count: usize,
    pub median: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl ErrorQuantiles {
    /// The quantiles of `values` (the value at the rounded index q·(n − 1) of the sorted
    /// values).
    pub fn of(mut values: Vec<f64>) -> ErrorQuantiles {
        if values.is_empty() {
            return ErrorQuantiles::default();
        }
        values.sort_by(f64::total_cmp);
        let q = |f: f64| values[((values.len() - 1) as f64 * f).round() as usize];
        ErrorQuantiles {
            count: values.len(),
            median: q(0.5),
            p90: q(0.9),
            p99: q(0.99),
            max: values[values.len() - 1],
        }
    }
}

/// How far a matrix is from the enclosure rules: |1 − Σ_J F_IJ| per row, and
/// |A_I F_IJ − A_J F_JI| / max(A_I F_IJ, A_J F_JI) per pair that either side sees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnclosureErrors {
    pub row_sum: ErrorQuantiles,
    pub reciprocity: ErrorQuantiles,
}

/// What [`SurfaceMatrix::enforce`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnclosureReport {
    /// The errors of the matrix as computed...
    pub raw: EnclosureErrors,
    /// ...and as returned.
    pub fixed: EnclosureErrors,
    /// The largest |F'_IJ − F_IJ| the rule made.
    pub max_change: f64,
    /// Products by the symmetric part the scaling took (0 for raw).
    pub products: usize,
}

impl SurfaceMatrix {
    pub fn n(&self) -> usize {
        self.rows.len()
    }

    pub fn row_sum(&self, i: usize) -> f64 {
        self.rows[i].iter().map(|e| e.1).sum()
    }

    /// F_IJ, 0 where I does not see J.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let row = &self.rows[i];
        row.binary_search_by_key(&(j as u32), |e| e.0)
            .map_or(0.0, |k| row[k].1)
    }

    /// The distribution of the row-sum and reciprocity errors.
    pub fn errors(&self) -> EnclosureErrors {
        let row_sum = (0..self.n())
            .map(|i| (1.0 - self.row_sum(i)).abs())
            .collect();
        let mut reciprocity = Vec::new();
        for (i, row) in self.rows.iter().enumerate() {
            for &(j, f) in row {
                let j = j as usize;
                // Each pair once: from the lower index, or from the upper when the lower
                // does not see it.
                if j > i || (j < i && self.get(j, i) == 0.0) {
                    let (a, b) = (self.area[i] * f, self.area[j] * self.get(j, i));
                    reciprocity.push((a - b).abs() / a.max(b));
                }
            }
        }
        EnclosureErrors {
            row_sum: ErrorQuantiles::of(row_sum),
            reciprocity: ErrorQuantiles::of(reciprocity),
        }
    }

    /// Checks the matrix: one row a surface, columns in range and increasing, values
    /// finite and ≥ 0, areas finite and > 0.
    fn check(&self) -> Result<(), Error> {
        let n = self.n();
        crate::surfaces::check_areas(&self.area, n)?;
        for (i, row) in self.rows.iter().enumerate() {
            let mut last = None;
            for &(j, f) in row {
                if j as usize >= n || last.is_some_and(|l| l >= j) {
                    return Err(Error::EntryOutOfRange {
                        row: i as u32,
                        column: j,
                        n_patches: n,
                    });
                }
                if !(f.is_finite() && f >= 0.0) {
                    return Err(Error::BadValue {
                        row: i as u32,
                        column: j,
                        value: f,
                    });
                }
                last = Some(j);
            }
        }
        Ok(())
    }

    /// The matrix under `rule`, with what it changed. `Closed` on rows that leak (raw
    /// sum below 1 − [`LEAK_TOLERANCE`]) is [`Error::Leaks`], naming them.
    pub fn enforce(&self, rule: Enclosure) -> Result<(SurfaceMatrix, EnclosureReport), Error> {
        self.enforce_blocked(rule, &[])
    }

    /// [`SurfaceMatrix::enforce_blocked`], taking the matrix: `Raw` returns it as it is,
    /// without a copy (a surface matrix of a large scene may hold tens of millions of
    /// entries).
    pub fn into_enforced(
        self,
        rule: Enclosure,
        blocked: &[f64],
    ) -> Result<(SurfaceMatrix, EnclosureReport), Error> {
        if rule != Enclosure::Raw {
            return self.enforce_blocked(rule, blocked);
        }
        self.check()?;
        let mut m = self;
        m.rows.iter_mut().for_each(|r| r.retain(|e| e.1 > 0.0));
        let raw = m.errors();
        let report = EnclosureReport {
            raw,
            fixed: raw,
            max_change: 0.0,
            products: 0,
        };
        Ok((m, report))
    }

    /// [`SurfaceMatrix::enforce`] where `blocked[I]` of row I's rays met obstructions
    /// (no surface of the matrix): they do not leak, and `Closed` spreads them over the
    /// row as View3D's `encl=1` does. An empty `blocked` is all zeros.
    pub fn enforce_blocked(
        &self,
        rule: Enclosure,
        blocked: &[f64],
    ) -> Result<(SurfaceMatrix, EnclosureReport), Error> {
        self.check()?;
        if !blocked.is_empty() && blocked.len() != self.n() {
            return Err(Error::LengthMismatch {
                what: "obstructed shares",
                len: blocked.len(),
                n_patches: self.n(),
            });
        }
        if self.rows.iter().any(|r| r.iter().any(|e| e.1 == 0.0)) {
            // Explicit zeros are no entries: drop them, then go on.
            let mut clean = self.clone();
            clean.rows.iter_mut().for_each(|r| r.retain(|e| e.1 > 0.0));
            return clean.enforce_blocked(rule, blocked);
        }
        let raw = self.errors();
        let n = self.n();
        if rule == Enclosure::Raw {
            let report = EnclosureReport {
                raw,
                fixed: raw,
                max_change: 0.0,
                products: 0,
            };
            return Ok((self.clone(), report));
        }
        let sums: Vec<f64> = (0..n).map(|i| self.row_sum(i)).collect();
        if rule == Enclosure::Closed {
            let seen = |i: usize| sums[i] + blocked.get(i).copied().unwrap_or(0.0);
            let leaks: Vec<(u32, f64)> = (0..n)
                .filter(|&i| seen(i) < 1.0 - LEAK_TOLERANCE)
                .map(|i| (i as u32, sums[i]))
                .collect();
            if !leaks.is_empty() {
                return Err(Error::Leaks {
                    count: leaks.len(),
                    first: leaks.into_iter().take(5).collect(),
                    tolerance: LEAK_TOLERANCE,
                });
            }
        }
        let g = self.symmetric_part();
        // A surface that sees nothing but is seen: no scaling keeps its zero sum without
        // deleting what the others see of it.
        if let Some(i) = (0..n).find(|&i| sums[i] == 0.0 && !g[i].is_empty()) {
            return Err(Error::SeenButBlind {
                surface: i as u32,
                seen_by: g[i][0].0,
            });
        }
        let target: Vec<f64> = (0..n)
            .map(|i| match rule {
                Enclosure::Closed => self.area[i],
                _ => self.area[i] * sums[i],
            })
            .collect();
        let spmv = |x: &[f64]| -> Vec<f64> {
            g.iter()
                .map(|row| row.iter().map(|&(j, v)| v * x[j as usize]).sum())
                .collect()
        };
        let (x, products, worst) =
            balance(n, spmv, &target, SCALING_TOLERANCE, SCALING_MAX_PRODUCTS);
        if !(worst <= 1e3 * SCALING_TOLERANCE) {
            return Err(Error::NoReciprocalScaling {
                iterations: products,
            });
        }
        let rows: Vec<Vec<(u32, f64)>> = g
            .iter()
            .enumerate()
            .map(|(i, row)| {
                row.iter()
                    .map(|&(j, v)| (j, x[i] * v * x[j as usize] / self.area[i]))
                    .filter(|e| e.1 > 0.0)
                    .collect()
            })
            .collect();
        let fixed = SurfaceMatrix {
            area: self.area.clone(),
            rows,
        };
        let mut max_change: f64 = 0.0;
        for i in 0..n {
            for &(j, f) in &fixed.rows[i] {
                max_change = max_change.max((f - self.get(i, j as usize)).abs());
            }
            for &(j, f) in &self.rows[i] {
                max_change = max_change.max((f - fixed.get(i, j as usize)).abs());
            }
        }
        let report = EnclosureReport {
            raw,
            fixed: fixed.errors(),
            max_change,
            products,
        };
        Ok((fixed, report))
    }

    /// G_IJ = (A_I F_IJ + A_J F_JI) / 2 on the pattern of F ∪ Fᵀ, rows sorted; the
    /// same bits at (I, J) and (J, I).
    fn symmetric_part(&self) -> Vec<Vec<(u32, f64)>> {
        let n = self.n();
        let mut g: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
        for (i, row) in self.rows.iter().enumerate() {
            for &(j, f) in row {
                let j = j as usize;
                let back = self.get(j, i);
                // Each pair formed once, from its lower index (or from the upper when
                // the lower does not see it), and stored both ways.
                if j < i && back > 0.0 {
                    continue;
                }
                let v = 0.5 * (self.area[i] * f + self.area[j] * back);
                g[i].push((j as u32, v));
                if j != i {
                    g[j].push((i as u32, v));
                }
            }
        }
        for row in &mut g {
            row.sort_unstable_by_key(|e| e.0);
        }
        g
    }
}

/// The most surfaces [`SurfaceMatrix::script_f`] takes (a dense n × n solve).
pub const MAX_SCRIPT_F: usize = 4000;

impl SurfaceMatrix {
    /// Hottel's total exchange factors ("script-F") of grey diffuse surfaces with
    /// emissivities `emissivity`: 𝓕 = E F (I − (I − E) F)⁻¹ E, that is A_I 𝓕_IJ the total
    /// exchange area between I and J (what View3D's `emit=1` reports). For a closed,
    /// reciprocal F each row sums to ε_I and A 𝓕 is symmetric. Dense, by LU with partial
    /// pivoting: at most [`MAX_SCRIPT_F`] surfaces.
    pub fn script_f(&self, emissivity: &[f64]) -> Result<SurfaceMatrix, Error> {
        let n = self.n();
        if emissivity.len() != n {
            return Err(Error::LengthMismatch {
                what: "emissivities",
                len: emissivity.len(),
                n_patches: n,
            });
        }
        if let Some(i) = (0..n).find(|&i| !(emissivity[i] > 0.0 && emissivity[i] <= 1.0)) {
            return Err(Error::BadSurface {
                patch: i as u32,
                what: "emissivity",
                value: [emissivity[i]; 3],
                rule: "in (0, 1]",
            });
        }
        if n > MAX_SCRIPT_F {
            return Err(Error::BadConfig {
                what: "surfaces for script-F",
                value: n as f64,
                rule: "at most 4000 (a dense solve)",
            });
        }
        // Mᵀ, M = I − (I − E) F, row-major; X = F M⁻¹ solved as Mᵀ Xᵀ = Fᵀ.
        let mut mt = vec![0.0f64; n * n];
        for i in 0..n {
            mt[i * n + i] += 1.0;
            for &(j, f) in &self.rows[i] {
                mt[j as usize * n + i] -= (1.0 - emissivity[i]) * f;
            }
        }
        let mut perm: Vec<usize> = (0..n).collect();
        for k in 0..n {
            let p = (k..n)
                .max_by(|&a, &b| mt[a * n + k].abs().total_cmp(&mt[b * n + k].abs()))
                .expect("k < n");
            if !(mt[p * n + k].abs() > 1e-300) {
                return Err(Error::SingularExchange { surface: k as u32 });
            }
            if p != k {
                for c in 0..n {
                    mt.swap(p * n + c, k * n + c);
                }
                perm.swap(p, k);
            }
            let pivot = mt[k * n + k];
            for r in k + 1..n {
                let l = mt[r * n + k] / pivot;
                mt[r * n + k] = l;
                if l != 0.0 {
                    for c in k + 1..n {
                        mt[r * n + c] -= l * mt[k * n + c];
                    }
                }
            }
        }
        let mut rows = Vec::with_capacity(n);
        let mut b = vec![0.0f64; n];
        for i in 0..n {
            // Row i of X: Mᵀ x = (row i of F)ᵀ, permuted.
            let mut dense = vec![0.0f64; n];
            for &(j, f) in &self.rows[i] {
                dense[j as usize] = f;
            }
            for r in 0..n {
                b[r] = dense[perm[r]];
            }
            for r in 0..n {
                let s: f64 = (0..r).map(|c| mt[r * n + c] * b[c]).sum();
                b[r] -= s;
            }
            for r in (0..n).rev() {
                let s: f64 = (r + 1..n).map(|c| mt[r * n + c] * b[c]).sum();
                b[r] = (b[r] - s) / mt[r * n + r];
            }
            rows.push(
                (0..n)
                    .map(|j| (j as u32, emissivity[i] * b[j] * emissivity[j]))
                    .filter(|e| e.1 > 0.0)
                    .collect(),
            );
        }
        Ok(SurfaceMatrix {
            area: self.area.clone(),
            rows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two(f01: f64, f10: f64) -> SurfaceMatrix {
        SurfaceMatrix {
            area: vec![1.0, 2.0],
            rows: vec![vec![(1, f01)], vec![(0, f10)]],
        }
    }

    #[test]
    fn rules_on_two_surfaces() {
        // A_0 F_01 = 0.5, A_1 F_10 = 0.6: G = 0.55.
        let m = two(0.5, 0.3);
        let (raw, report) = m.enforce(Enclosure::Raw).unwrap();
        assert_eq!(raw, m);
        assert!((report.raw.reciprocity.max - 0.1 / 0.6).abs() < 1e-12);
        // Two surfaces that see only each other keep both sums reciprocally only if
        // A_0 s_0 = A_1 s_1: not here (0.5 against 0.6), so no scaling exists.
        assert!(matches!(
            m.enforce(Enclosure::Reciprocal),
            Err(Error::NoReciprocalScaling { .. })
        ));
        let fits = two(0.6, 0.3);
        let (r, rep) = fits.enforce(Enclosure::Reciprocal).unwrap();
        assert!((r.row_sum(0) - 0.6).abs() < 1e-12 && (r.row_sum(1) - 0.3).abs() < 1e-12);
        assert!((r.area[0] * r.get(0, 1) - r.area[1] * r.get(1, 0)).abs() < 1e-15);
        assert!(rep.fixed.reciprocity.max < 1e-12);
        assert!(m.enforce(Enclosure::Closed).is_err());
    }

    #[test]
    fn script_f_of_two_parallel_plates_and_a_closed_box() {
        // Infinite parallel plates (F = 1 each way): 𝓕 = 1 / (1/ε1 + 1/ε2 − 1).
        let plates = SurfaceMatrix {
            area: vec![1.0, 1.0],
            rows: vec![vec![(1, 1.0)], vec![(0, 1.0)]],
        };
        let (e1, e2) = (0.8, 0.3);
        let sf = plates.script_f(&[e1, e2]).unwrap();
        let want = 1.0 / (1.0 / e1 + 1.0 / e2 - 1.0);
        assert!((sf.get(0, 1) - want).abs() < 1e-14 && (sf.get(1, 0) - want).abs() < 1e-14);
        // Black surfaces: script-F is F.
        assert_eq!(plates.script_f(&[1.0, 1.0]).unwrap(), plates);
        // A closed, reciprocal enclosure: rows sum to ε, A 𝓕 symmetric.
        let third = 1.0 / 3.0;
        let tri = SurfaceMatrix {
            area: vec![1.0, 1.0, 1.0, 1.0],
            rows: (0..4u32)
                .map(|i| (0..4u32).filter(|&j| j != i).map(|j| (j, third)).collect())
                .collect(),
        };
        let e = [0.9, 0.5, 0.2, 0.7];
        let sf = tri.script_f(&e).unwrap();
        for i in 0..4 {
            assert!(
                (sf.row_sum(i) - e[i]).abs() < 1e-14,
                "row {i}: {}",
                sf.row_sum(i)
            );
            for j in 0..4 {
                assert!((sf.get(i, j) - sf.get(j, i)).abs() < 1e-15);
            }
        }
        assert!(sf.get(1, 1) > 0.0, "self-exchange through reflections");
        assert!(plates.script_f(&[0.0, 1.0]).is_err());
    }

    #[test]
    fn explicit_zeros_are_no_entries_and_a_blind_surface_is_named() {
        let with_zero = SurfaceMatrix {
            area: vec![1.0, 2.0],
            rows: vec![vec![(1, 0.6)], vec![(0, 0.3), (1, 0.0)]],
        };
        let (a, _) = with_zero.enforce(Enclosure::Reciprocal).unwrap();
        let (b, _) = two(0.6, 0.3).enforce(Enclosure::Reciprocal).unwrap();
        assert_eq!(a, b);
        let blind = SurfaceMatrix {
            area: vec![1.0, 1.0],
            rows: vec![vec![(1, 0.5)], vec![]],
        };
        let err = blind.enforce(Enclosure::Reciprocal).unwrap_err();
        assert_eq!(
            err,
            Error::SeenButBlind {
                surface: 1,
                seen_by: 0
            }
        );
    }
}
