//! The reciprocal scaling: the diagonal x with `x ∘ (G x) = t` that makes a symmetric
//! matrix's rows sum to given targets (Newton's method, conjugate-gradient steps), and
//! what it changed.

/// What [`crate::FormFactors::reciprocal`] changed, and how well it converged.
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
/// made by several processes, say, each its rows): what [`crate::FormFactors::reciprocal`]
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
