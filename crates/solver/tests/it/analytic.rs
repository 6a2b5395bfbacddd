//! Closed forms: the furnace enclosure and two facing infinite planes.

use crate::{enclosure, uniform};
use rad_solver::{energy_balance, gauss_seidel, progressive, FormFactors, SolveConfig, Surfaces};

#[test]
fn furnace_converges_to_e_over_one_minus_rho_with_both_solvers() {
    let (ff, area) = enclosure(60, 7, 0.3);
    let e = [1.0, 0.5, 2.0];
    let rho = [0.5, 0.8, 0.3];
    let s = uniform(&area, e, rho);
    let cfg = SolveConfig {
        tolerance: 1e-10,
        max_iterations: 1_000_000,
    };
    for sol in [
        gauss_seidel(&ff, &s, &cfg).unwrap(),
        progressive(&ff, &s, &cfg).unwrap(),
    ] {
        assert!(sol.report.converged, "{:?}", sol.report);
        for b in &sol.radiosity {
            for c in 0..3 {
                let want = e[c] / (1.0 - rho[c]);
                assert!(
                    ((b[c] - want) / want).abs() < 1e-4,
                    "{:?}: {} vs {want}",
                    sol.report.solver,
                    b[c]
                );
            }
        }
        let bal = energy_balance(&ff, &s, &sol.radiosity);
        assert!(bal.relative_imbalance < 1e-6, "{bal:?}");
    }
}

#[test]
fn two_facing_planes() {
    // Two infinite parallel planes see only each other: F12 = F21 = 1.
    let rows = [vec![(1u32, 1.0)], vec![(0u32, 1.0)]];
    let ff = FormFactors::from_rows(2, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])))
        .unwrap();
    let s = Surfaces {
        area: vec![1.0, 1.0],
        emission: vec![[1.0; 3], [0.0; 3]],
        reflectance: vec![[0.5; 3], [0.25; 3]],
    };
    // B1 = E1 + r1 B2, B2 = r2 B1 → B1 = E1 / (1 − r1 r2).
    let b1 = 1.0 / (1.0 - 0.5 * 0.25);
    let b2 = 0.25 * b1;
    let cfg = SolveConfig::default();
    for sol in [
        gauss_seidel(&ff, &s, &cfg).unwrap(),
        progressive(&ff, &s, &cfg).unwrap(),
    ] {
        assert!(
            (sol.radiosity[0][1] - b1).abs() < 1e-8,
            "{:?}",
            sol.radiosity
        );
        assert!(
            (sol.radiosity[1][2] - b2).abs() < 1e-8,
            "{:?}",
            sol.radiosity
        );
    }
}
