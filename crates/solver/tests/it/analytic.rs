//! Closed forms: the furnace enclosure and two facing infinite planes.

use crate::{enclosure, uniform};
use rad_solver::{
    energy_balance, gauss_seidel, gauss_seidel_from, progressive, Error, FormFactors, SolveConfig,
    Surfaces,
};

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

#[test]
fn a_warm_start_reaches_the_same_radiosities_in_fewer_sweeps() {
    let (ff, area) = enclosure(60, 7, 0.3);
    let s = uniform(&area, [1.0, 0.5, 2.0], [0.5, 0.8, 0.3]);
    let cfg = SolveConfig {
        tolerance: 1e-10,
        max_iterations: 1_000_000,
    };
    let cold = gauss_seidel(&ff, &s, &cfg).unwrap();
    // From the emission: the cold solve, to the bit.
    let same = gauss_seidel_from(&ff, &s, &cfg, s.emission.clone()).unwrap();
    assert_eq!(same.radiosity, cold.radiosity);
    assert_eq!(same.report.iterations, cold.report.iterations);
    // From a neighbour's answer (a tenth off): the same within the tolerance, sooner.
    let near: Vec<[f64; 3]> = cold.radiosity.iter().map(|b| b.map(|c| c * 1.1)).collect();
    let warm = gauss_seidel_from(&ff, &s, &cfg, near).unwrap();
    assert!(warm.report.converged, "{:?}", warm.report);
    assert!(
        warm.report.iterations < cold.report.iterations,
        "warm {} sweeps, cold {}",
        warm.report.iterations,
        cold.report.iterations
    );
    for (w, c) in warm.radiosity.iter().zip(&cold.radiosity) {
        for k in 0..3 {
            assert!((w[k] - c[k]).abs() <= 1e-8 * c[k], "{w:?} vs {c:?}");
        }
    }
    // From the answer itself: no sweep at all.
    let at = gauss_seidel_from(&ff, &s, &cfg, cold.radiosity.clone()).unwrap();
    assert_eq!(at.report.iterations, 0);
    assert_eq!(at.radiosity, cold.radiosity);
    // A start of the wrong length, or not finite: refused.
    let short = gauss_seidel_from(&ff, &s, &cfg, vec![[0.0; 3]; 3]);
    assert!(
        matches!(short, Err(Error::LengthMismatch { .. })),
        "{short:?}"
    );
    let mut nan = cold.radiosity.clone();
    nan[5][1] = f64::NAN;
    let bad = gauss_seidel_from(&ff, &s, &cfg, nan).unwrap_err();
    assert!(bad.to_string().contains("patch 5"), "{bad}");
}
