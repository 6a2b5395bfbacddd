//! Gauss-Seidel gathering, progressive shooting, the residual and the energy balance.

use crate::surfaces::Surfaces;
use crate::Error;
use crate::Operator;
use rad_core::PatchId;

/// Which iteration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// Gauss-Seidel on `B = E + ρ F B`, patches in order.
    GaussSeidel,
    /// Progressive refinement: shoot the patch of largest unshot power.
    Progressive,
    /// Jacobi on `B = E + ρ F B`: every patch from the last sweep's radiosities, so
    /// rows held by several processes need only the radiosities shared each sweep.
    Jacobi,
}

impl Solver {
    pub fn name(self) -> &'static str {
        match self {
            Solver::GaussSeidel => "gauss-seidel",
            Solver::Progressive => "progressive",
            Solver::Jacobi => "jacobi",
        }
    }
}

/// When to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveConfig {
    /// Stop once [`residual`] is at most this.
    pub tolerance: f64,
    /// Gauss-Seidel: sweeps; progressive: shots (each shot is one row).
    pub max_iterations: usize,
}

impl Default for SolveConfig {
    fn default() -> Self {
        SolveConfig {
            tolerance: 1e-9,
            max_iterations: 10_000_000,
        }
    }
}

impl SolveConfig {
    pub(crate) fn validate(&self) -> Result<(), Error> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::BadConfig {
                what: "tolerance",
                value: self.tolerance,
                rule: "must be finite and > 0",
            });
        }
        Ok(())
    }
}

/// How a solve ended. Non-convergence is reported here, not as an error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveReport {
    pub solver: Solver,
    /// Sweeps (Gauss-Seidel) or shots (progressive).
    pub iterations: usize,
    /// [`residual`] of the returned radiosities.
    pub residual: f64,
    pub converged: bool,
}

/// Radiosities (per patch, RGB) and how they were reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Solution {
    pub radiosity: Vec<[f64; 3]>,
    /// Progressive refinement's ambient term (unshot radiosity spread evenly, times the
    /// mean interreflection `1 / (1 − ρ̄)`), for display: `B_i + ρ_i · ambient`. Zero
    /// for Gauss-Seidel and at convergence it is below the tolerance anyway.
    pub ambient: [f64; 3],
    pub report: SolveReport,
}

impl Solution {
    /// Radiosity for display: with the ambient term added.
    pub fn display(&self, surfaces: &Surfaces) -> Vec<[f64; 3]> {
        self.radiosity
            .iter()
            .zip(&surfaces.reflectance)
            .map(|(b, r)| std::array::from_fn(|c| b[c] + r[c] * self.ambient[c]))
            .collect()
    }
}

/// `max_{i,c} |E + ρ F B − B|_{i,c} / max_{i,c} B_{i,c}` (0 if B is zero everywhere and
/// so is E).
pub fn residual<M: Operator>(ff: &M, surfaces: &Surfaces, b: &[[f64; 3]]) -> f64 {
    residual_from(surfaces, b, &ff.apply(b))
}

/// [`residual`] of `b` given its product `h = F b`.
pub fn residual_from(surfaces: &Surfaces, b: &[[f64; 3]], h: &[[f64; 3]]) -> f64 {
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for i in 0..b.len() {
        for c in 0..3 {
            let r = surfaces.emission[i][c] + surfaces.reflectance[i][c] * h[i][c] - b[i][c];
            worst = worst.max(r.abs());
            scale = scale.max(b[i][c].abs());
        }
    }
    if scale > 0.0 {
        worst / scale
    } else {
        worst
    }
}

fn check<M: Operator>(ff: &M, surfaces: &Surfaces, config: &SolveConfig) -> Result<(), Error> {
    config.validate()?;
    surfaces.validate(ff.n_patches())
}

/// Gauss-Seidel gathering: `B_i ← E_i + ρ_i Σ_j F_ij B_j`, patches in order, sweeps until
/// the largest change of a sweep and then the true residual are within tolerance.
/// Sequential, so the answer does not depend on threads.
pub fn gauss_seidel<M: Operator>(
    ff: &M,
    surfaces: &Surfaces,
    config: &SolveConfig,
) -> Result<Solution, Error> {
    gauss_seidel_from(ff, surfaces, config, surfaces.emission.clone())
}

/// [`gauss_seidel`] from the radiosities `start` instead of the emission (a warm start:
/// the solution of a neighbouring problem, such as the step before of a motion). It
/// converges to the same radiosities within the tolerance from any start (the sweep is
/// a contraction where reflectances are below 1 and rows sum to at most 1); from the
/// emission it is [`gauss_seidel`], to the bit.
pub fn gauss_seidel_from<M: Operator>(
    ff: &M,
    surfaces: &Surfaces,
    config: &SolveConfig,
    start: Vec<[f64; 3]>,
) -> Result<Solution, Error> {
    check(ff, surfaces, config)?;
    if start.len() != ff.n_patches() {
        return Err(Error::LengthMismatch {
            what: "the starting radiosities",
            len: start.len(),
            n_patches: ff.n_patches(),
        });
    }
    if let Some((i, &value)) = start
        .iter()
        .enumerate()
        .find(|(_, b)| b.iter().any(|c| !c.is_finite() || *c < 0.0))
    {
        return Err(Error::BadSurface {
            patch: i as PatchId,
            what: "starting radiosity",
            value,
            rule: "finite and at least 0",
        });
    }
    let mut b = start;
    let mut iterations = 0;
    let mut res = residual(ff, surfaces, &b);
    let mut fresh = true;
    while res > config.tolerance && iterations < config.max_iterations {
        fresh = false;
        let (change, scale) = ff.sweep(surfaces, &mut b);
        iterations += 1;
        if change <= config.tolerance * scale.max(f64::MIN_POSITIVE) {
            res = residual(ff, surfaces, &b);
            fresh = true;
        }
    }
    if !fresh {
        // Stopped by the iteration cap: report the residual of what is returned.
        res = residual(ff, surfaces, &b);
    }
    Ok(Solution {
        radiosity: b,
        ambient: [0.0; 3],
        report: SolveReport {
            solver: Solver::GaussSeidel,
            iterations,
            residual: res,
            converged: res <= config.tolerance,
        },
    })
}

/// Jacobi: `B ← E + ρ F B`, every patch from the last sweep's radiosities, until the
/// true residual is within tolerance. Each sweep's product is the residual's, so the
/// residual reported is that of the radiosities returned, exactly.
pub fn jacobi<M: Operator>(
    ff: &M,
    surfaces: &Surfaces,
    config: &SolveConfig,
) -> Result<Solution, Error> {
    check(ff, surfaces, config)?;
    let product = |b: &[[f64; 3]]| Ok::<_, Error>(ff.apply(b));
    Ok(jacobi_with(surfaces, config, product, &mut |_, _| {})?.0)
}

/// [`jacobi`] with the product `F b` given (one made by several processes, each its
/// rows, say), and `progress(sweeps, residual)` after each: the solution and the last
/// product (`F B` of the radiosities returned, for their energy balance).
pub fn jacobi_with<E: From<Error>>(
    surfaces: &Surfaces,
    config: &SolveConfig,
    mut product: impl FnMut(&[[f64; 3]]) -> Result<Vec<[f64; 3]>, E>,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<(Solution, Vec<[f64; 3]>), E> {
    config.validate()?;
    surfaces.validate(surfaces.area.len())?;
    let mut b = surfaces.emission.clone();
    let mut iterations = 0;
    loop {
        let h = product(&b)?;
        if h.len() != b.len() {
            return Err(Error::LengthMismatch {
                what: "a product",
                len: h.len(),
                n_patches: b.len(),
            }
            .into());
        }
        let res = residual_from(surfaces, &b, &h);
        progress(iterations, res);
        if res <= config.tolerance || iterations >= config.max_iterations || !res.is_finite() {
            let report = SolveReport {
                solver: Solver::Jacobi,
                iterations,
                residual: res,
                converged: res <= config.tolerance,
            };
            let solution = Solution {
                radiosity: b,
                ambient: [0.0; 3],
                report,
            };
            return Ok((solution, h));
        }
        for (i, bi) in b.iter_mut().enumerate() {
            for c in 0..3 {
                bi[c] = surfaces.emission[i][c] + surfaces.reflectance[i][c] * h[i][c];
            }
        }
        iterations += 1;
    }
}

/// Progressive refinement: repeatedly the patch `i` of largest unshot power
/// `A_i Σ_c ΔB_{i,c}` shoots, giving each `j` in its row `ρ_j F_ij ΔB_i A_i / A_j`
/// (that is `ρ_j F_ji ΔB_i` by reciprocity: run it on [`crate::FormFactors::reciprocal`]'s
/// matrix; on rows that are not reciprocal it converges to a slightly different system
/// and its residual levels off near their reciprocity error). Stops when the largest
/// unshot radiosity is within tolerance of the largest radiosity and then the true
/// residual is too.
pub fn progressive<M: Operator>(
    ff: &M,
    surfaces: &Surfaces,
    config: &SolveConfig,
) -> Result<Solution, Error> {
    check(ff, surfaces, config)?;
    let n = ff.n_patches();
    let area = &surfaces.area;
    let rho = &surfaces.reflectance;
    let mut b = surfaces.emission.clone();
    let mut unshot = surfaces.emission.clone();
    let mut power: Vec<f64> = (0..n)
        .map(|i| area[i] * unshot[i].iter().sum::<f64>())
        .collect();
    let mut iterations = 0;
    let mut res;
    loop {
        // Ties go to the lower index, so the order is deterministic.
        let mut i = 0;
        for (k, &p) in power.iter().enumerate() {
            if p > power[i] {
                i = k;
            }
        }
        if n == 0 || iterations % 64 == 0 {
            let max_b = b.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
            let max_unshot = unshot.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
            if max_unshot <= config.tolerance * max_b.max(f64::MIN_POSITIVE) {
                res = residual(ff, surfaces, &b);
                if res <= config.tolerance || n == 0 {
                    break;
                }
            }
        }
        if iterations >= config.max_iterations {
            res = residual(ff, surfaces, &b);
            break;
        }
        let shot = unshot[i];
        unshot[i] = [0.0; 3];
        power[i] = 0.0;
        ff.shoot(i as PatchId, area, |j, k| {
            let mut add_power = 0.0;
            for c in 0..3 {
                let d = rho[j][c] * k * shot[c];
                b[j][c] += d;
                unshot[j][c] += d;
                add_power += d;
            }
            power[j] += area[j] * add_power;
        });
        iterations += 1;
    }
    let ambient = ambient_term(area, rho, &unshot);
    Ok(Solution {
        radiosity: b,
        ambient,
        report: SolveReport {
            solver: Solver::Progressive,
            iterations,
            residual: res,
            converged: res <= config.tolerance,
        },
    })
}

/// Progressive refinement's ambient term: unshot radiosity, area-averaged, times
/// `1 / (1 − ρ̄)`.
pub(crate) fn ambient_term(area: &[f64], rho: &[[f64; 3]], unshot: &[[f64; 3]]) -> [f64; 3] {
    let n = area.len();
    let total_area: f64 = area.iter().sum();
    std::array::from_fn(|c| {
        if n == 0 {
            return 0.0;
        }
        let u: f64 = (0..n).map(|i| area[i] * unshot[i][c]).sum::<f64>() / total_area;
        let r: f64 = (0..n).map(|i| area[i] * rho[i][c]).sum::<f64>() / total_area;
        u / (1.0 - r)
    })
}

/// Where the power goes, per RGB channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBalance {
    /// `Σ A_i E_i`.
    pub emitted: [f64; 3],
    /// `Σ A_i (1 − ρ_i) H_i`, with `H = F B` the irradiance.
    pub absorbed: [f64; 3],
    /// Power leaving the scene: `Σ A_i B_i (1 − Σ_j F_ij)` (zero in a closed scene).
    pub escaped: [f64; 3],
    /// `max_c |emitted − absorbed − escaped| / emitted` over channels that emit.
    pub relative_imbalance: f64,
}

/// The energy balance of radiosities `b` under `ff`: exact (to the residual) when `ff`
/// is reciprocal, off by the reciprocity error otherwise.
pub fn energy_balance<M: Operator>(ff: &M, surfaces: &Surfaces, b: &[[f64; 3]]) -> EnergyBalance {
    energy_balance_from(surfaces, b, &ff.apply(b), &ff.row_sums())
}

/// [`energy_balance`] of `b` given its product `h = F b` and the row sums of F.
pub fn energy_balance_from(
    surfaces: &Surfaces,
    b: &[[f64; 3]],
    h: &[[f64; 3]],
    sums: &[f64],
) -> EnergyBalance {
    let mut e = EnergyBalance::default();
    for i in 0..b.len() {
        let a = surfaces.area[i];
        let leave = 1.0 - sums[i];
        for c in 0..3 {
            e.emitted[c] += a * surfaces.emission[i][c];
            e.absorbed[c] += a * (1.0 - surfaces.reflectance[i][c]) * h[i][c];
            e.escaped[c] += a * b[i][c] * leave;
        }
    }
    e.relative_imbalance = (0..3)
        .filter(|&c| e.emitted[c] > 0.0)
        .map(|c| (e.emitted[c] - e.absorbed[c] - e.escaped[c]).abs() / e.emitted[c])
        .fold(0.0, f64::max);
    e
}
