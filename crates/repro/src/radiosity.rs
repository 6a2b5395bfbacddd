//! From rows to radiosities: a scene's surfaces, the reciprocal matrix, a solve with
//! its energy balance, and the solution file that `coherad solve` writes and
//! `coherad render` reads.

use crate::Error;
use rad_core::PatchId;
use rad_geometry::Scene;
use rad_solver::{
    energy_balance, gauss_seidel, progressive, EnergyBalance, FormFactors, Reciprocity, Solution,
    SolveConfig, Solver, Surfaces,
};
use serde::Serialize;
use std::time::Instant;

/// Area, emission and reflectance of every patch, from the scene's materials.
pub fn surfaces(scene: &Scene) -> Surfaces {
    let n = scene.patches().len();
    let mut s = Surfaces {
        area: Vec::with_capacity(n),
        emission: Vec::with_capacity(n),
        reflectance: Vec::with_capacity(n),
    };
    for (i, p) in scene.patches().iter().enumerate() {
        let m = scene.patch_material(i as PatchId);
        s.area.push(p.area);
        s.emission.push(m.emission.0);
        s.reflectance.push(m.reflectance.0);
    }
    s
}

/// How to solve.
#[derive(Clone, Copy, Debug)]
pub struct SolveOptions {
    pub solver: Solver,
    pub config: SolveConfig,
    /// Make the matrix reciprocal first ([`FormFactors::reciprocal`]); without it the
    /// energy balance holds only to the reciprocity error of the rows.
    pub reciprocal: bool,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            solver: Solver::GaussSeidel,
            config: SolveConfig::default(),
            reciprocal: true,
        }
    }
}

/// Tolerance and iteration cap of the reciprocal scaling.
const SCALING_TOLERANCE: f64 = 1e-9;
const SCALING_ITERATIONS: usize = 5_000;

/// A solve and what it says about energy.
#[derive(Clone, Debug)]
pub struct Solved {
    pub solution: Solution,
    /// What the reciprocal scaling changed (None if it was not asked for).
    pub reciprocity: Option<Reciprocity>,
    /// Energy balance under the matrix solved.
    pub balance: EnergyBalance,
    /// Energy balance of the same radiosities under the rows as computed (before the
    /// scaling): off by their reciprocity error.
    pub raw_balance: EnergyBalance,
    pub scaling_seconds: f64,
    pub solve_seconds: f64,
}

/// Solves `ff` (rows as computed) for `surfaces`.
pub fn solve(ff: &FormFactors, surfaces: &Surfaces, opts: &SolveOptions) -> Result<Solved, Error> {
    let t = Instant::now();
    let (matrix, reciprocity) = if opts.reciprocal {
        let (m, r) = ff.reciprocal(&surfaces.area, SCALING_TOLERANCE, SCALING_ITERATIONS)?;
        (Some(m), Some(r))
    } else {
        (None, None)
    };
    let scaling_seconds = t.elapsed().as_secs_f64();
    let m = matrix.as_ref().unwrap_or(ff);
    let t = Instant::now();
    let solution = match opts.solver {
        Solver::GaussSeidel => gauss_seidel(m, surfaces, &opts.config)?,
        Solver::Progressive => progressive(m, surfaces, &opts.config)?,
    };
    let solve_seconds = t.elapsed().as_secs_f64();
    let balance = energy_balance(m, surfaces, &solution.radiosity);
    let raw_balance = if matrix.is_some() {
        energy_balance(ff, surfaces, &solution.radiosity)
    } else {
        balance
    };
    Ok(Solved {
        solution,
        reciprocity,
        balance,
        raw_balance,
        scaling_seconds,
        solve_seconds,
    })
}

/// `Σ_i Σ_j |a_ij − b_ij|` over rows `rows`, divided by their number: the mean L1
/// distance of two matrices' rows.
pub fn mean_row_l1(a: &FormFactors, b: &FormFactors, rows: &[PatchId]) -> f64 {
    let total: f64 = rows.iter().map(|&i| a.row_l1_distance(b, i)).sum();
    total / rows.len().max(1) as f64
}

/// The solver's part of a solution file.
#[derive(Clone, Debug, Serialize)]
pub struct SolverJson {
    pub solver: &'static str,
    pub tolerance: f64,
    pub iterations: usize,
    pub residual: f64,
    pub converged: bool,
    pub reciprocal: bool,
    pub reciprocity: Option<ReciprocityJson>,
    pub energy: EnergyJson,
}

#[derive(Clone, Debug, Serialize)]
pub struct ReciprocityJson {
    pub max_input_asymmetry: f64,
    pub median_input_asymmetry: f64,
    pub mean_row_l1_change: f64,
    pub max_row_sum_error: f64,
    pub iterations: usize,
    pub converged: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct EnergyJson {
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub escaped: [f64; 3],
    pub relative_imbalance: f64,
    /// The same radiosities under the rows as computed.
    pub relative_imbalance_unscaled_rows: f64,
}

impl SolverJson {
    pub fn new(s: &Solved, opts: &SolveOptions) -> SolverJson {
        let r = &s.solution.report;
        SolverJson {
            solver: r.solver.name(),
            tolerance: opts.config.tolerance,
            iterations: r.iterations,
            residual: r.residual,
            converged: r.converged,
            reciprocal: opts.reciprocal,
            reciprocity: s.reciprocity.map(|r| ReciprocityJson {
                max_input_asymmetry: r.max_input_asymmetry,
                median_input_asymmetry: r.median_input_asymmetry,
                mean_row_l1_change: r.mean_row_l1_change,
                max_row_sum_error: r.max_row_sum_error,
                iterations: r.iterations,
                converged: r.converged,
            }),
            energy: EnergyJson {
                emitted: s.balance.emitted,
                absorbed: s.balance.absorbed,
                escaped: s.balance.escaped,
                relative_imbalance: s.balance.relative_imbalance,
                relative_imbalance_unscaled_rows: s.raw_balance.relative_imbalance,
            },
        }
    }
}

/// The solution file of `coherad solve`.
#[derive(Clone, Debug, Serialize)]
pub struct SolutionFile<'a> {
    pub scene: &'a str,
    pub resolution: [u32; 2],
    pub method: &'a str,
    pub n_patches: usize,
    pub solver: SolverJson,
    /// Seconds: form factors, reciprocal scaling, solve.
    pub timings: Timings,
    /// Progressive refinement's ambient term (added for display as `ρ · ambient`).
    pub ambient: [f64; 3],
    /// Radiosity per patch, in patch order: `radiosity[i]` is patch i's RGB.
    pub radiosity: Vec<[f64; 3]>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct Timings {
    pub form_factors_seconds: f64,
    pub scaling_seconds: f64,
    pub solve_seconds: f64,
}

/// Reads the radiosities of a solution file, for display (ambient term added), and
/// checks them against the scene: the right count, finite and non-negative.
pub fn read_solution(text: &str, scene: &Scene) -> Result<Vec<[f64; 3]>, Error> {
    let bad = |reason: String| Error::Parse {
        what: "solution file",
        input: String::new(),
        reason,
    };
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let b = v
        .get("radiosity")
        .and_then(|b| b.as_array())
        .ok_or_else(|| bad("no \"radiosity\" array".into()))?;
    let n = scene.patches().len();
    if b.len() != n {
        return Err(bad(format!(
            "{} radiosities for a scene of {n} patches (another scene's solution?)",
            b.len()
        )));
    }
    let triple = |x: &serde_json::Value, what: &str| -> Result<[f64; 3], Error> {
        let a = x.as_array().filter(|a| a.len() == 3);
        let vals: Option<Vec<f64>> = a
            .map(|a| a.iter().map(|c| c.as_f64()).collect::<Option<_>>())
            .flatten();
        match vals {
            Some(v) if v.iter().all(|c| c.is_finite() && *c >= 0.0) => Ok([v[0], v[1], v[2]]),
            _ => Err(bad(format!("{what} is {x}, not three finite numbers >= 0"))),
        }
    };
    let ambient = match v.get("ambient") {
        Some(a) => triple(a, "ambient")?,
        None => [0.0; 3],
    };
    let s = surfaces(scene);
    b.iter()
        .enumerate()
        .map(|(i, x)| {
            let r = triple(x, &format!("radiosity of patch {i}"))?;
            Ok(std::array::from_fn(|c| {
                r[c] + s.reflectance[i][c] * ambient[c]
            }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rad_geometry::scenes::cube;

    #[test]
    fn solution_files_are_checked_against_the_scene() {
        let scene = Scene::new(cube(2)).unwrap();
        let ok = format!(
            "{{\"radiosity\": {}, \"ambient\": [1, 0, 0]}}",
            serde_json::to_string(&vec![[0.5, 0.25, 0.0]; 24]).unwrap()
        );
        let b = read_solution(&ok, &scene).unwrap();
        assert_eq!(b[3], [0.5 + 0.7, 0.25, 0.0]);
        for (text, want) in [
            ("{", "not JSON"),
            ("{}", "no \"radiosity\""),
            (
                "{\"radiosity\": [[1,1,1]]}",
                "1 radiosities for a scene of 24",
            ),
        ] {
            let e = read_solution(text, &scene).unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
        let mut bad = vec![[0.5, 0.25, 0.0]; 24];
        bad[5][1] = -1.0;
        let text = format!(
            "{{\"radiosity\": {}}}",
            serde_json::to_string(&bad).unwrap()
        );
        let e = read_solution(&text, &scene).unwrap_err().to_string();
        assert!(e.contains("radiosity of patch 5"), "{e}");
    }
}
