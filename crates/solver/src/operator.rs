//! What the solvers need of a form-factor matrix, whatever its storage.

use crate::surfaces::Surfaces;
use rad_core::PatchId;

/// A square form-factor matrix as the solvers use it: [`crate::FormFactors`] (rows as
/// CSR) and [`crate::PairMatrix`] (the compact, pair-by-pair storage) implement it, and
/// [`crate::gauss_seidel`], [`crate::progressive`], [`crate::residual`] and
/// [`crate::energy_balance`] run on either.
///
/// Every method gives the same answer whatever the thread count.
pub trait Operator: Sync {
    /// Number of patches (rows).
    fn n_patches(&self) -> usize;

    /// `Σ_j F_ij` of every row, in `f64`, each row summed in column order.
    fn row_sums(&self) -> Vec<f64>;

    /// `y = F x` for RGB vectors, each row summed in column order.
    fn apply(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]>;

    /// One Gauss-Seidel sweep, patches in order: `b_i ← e_i + ρ_i Σ_j F_ij b_j`, with
    /// `b` updated as it goes (row i summed in column order). Returns the largest change
    /// of a channel and the largest new value.
    fn sweep(&self, surfaces: &Surfaces, b: &mut [[f64; 3]]) -> (f64, f64);

    /// Calls `f(j, F_ji)` for every `j` in row `i`'s pattern, in column order: what
    /// patch `i` shooting gives (`F_ji` exact from symmetric storage, else `F_ij A_i / A_j`
    /// by reciprocity).
    fn shoot<F: FnMut(usize, f64)>(&self, i: PatchId, area: &[f64], f: F);
}

/// `s += f · b` channel by channel (the one product every row sum is made of).
#[inline(always)]
pub(crate) fn add_scaled(s: &mut [f64; 3], f: f64, b: &[f64; 3]) {
    s[0] += f * b[0];
    s[1] += f * b[1];
    s[2] += f * b[2];
}

/// The Gauss-Seidel update of patch `i` from its row's (scaled) sum `h`: writes `b_i`,
/// widens the sweep's largest change and largest value.
#[inline(always)]
pub(crate) fn update(
    surfaces: &Surfaces,
    i: usize,
    h: [f64; 3],
    b: &mut [f64; 3],
    change: &mut f64,
    scale: &mut f64,
) {
    for c in 0..3 {
        let new = surfaces.emission[i][c] + surfaces.reflectance[i][c] * h[c];
        *change = change.max((new - b[c]).abs());
        *scale = scale.max(new.abs());
        b[c] = new;
    }
}
