//! Properties: reciprocity enforcement, agreement of the solvers, energy balance,
//! thread independence, and refusal of bad input.

use crate::{enclosure, uniform};
use proptest::prelude::*;
use rad_solver::{
    energy_balance, gauss_seidel, progressive, Error, FormFactors, SolveConfig, Surfaces,
};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn reciprocal_matrix_is_reciprocal_and_keeps_row_sums(
        n in 3usize..40, seed in any::<u64>(), density in 0.3f64..0.8, open in 0.0f64..0.1,
    ) {
        let (ff, area) = enclosure(n, seed, density);
        // Open it: scale each row down by a patch-dependent share.
        let rows: Vec<Vec<(u32, f64)>> = (0..n as u32).map(|i| {
            let (c, v) = ff.row(i);
            let keep = 1.0 - open * ((i as f64 * 0.37).sin().abs());
            c.iter().zip(v).map(|(&j, &f)| (j, f as f64 * ff.row_scale(i) * keep)).collect()
        }).collect();
        let raw = FormFactors::from_rows(n, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..]))).unwrap();
        let (rec, report) = raw.reciprocal(&area, 1e-12, 10_000).unwrap();
        prop_assert!(report.converged && report.max_row_sum_error < 1e-6, "{:?}", report);
        for i in 0..n as u32 {
            prop_assert!((rec.row_sum(i) - raw.row_sum(i)).abs() < 1e-6);
            for j in 0..n as u32 {
                let a = area[i as usize] * rec.get(i, j);
                let b = area[j as usize] * rec.get(j, i);
                prop_assert!((a - b).abs() <= 1e-6 * a.max(b), "{i} {j}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn solvers_agree_and_conserve_energy(
        n in 3usize..50, seed in any::<u64>(), density in 0.05f64..0.6,
        rho in 0.0f64..0.95, lights in 1usize..4,
    ) {
        let (ff, area) = enclosure(n, seed, density);
        let mut s = uniform(&area, [0.0; 3], [rho, rho * 0.5, rho * 0.9]);
        for k in 0..lights.min(n) {
            s.emission[(k * 7) % n] = [1.0 + k as f64, 2.0, 0.5];
        }
        let cfg = SolveConfig { tolerance: 1e-10, max_iterations: 10_000_000 };
        let g = gauss_seidel(&ff, &s, &cfg).unwrap();
        let p = progressive(&ff, &s, &cfg).unwrap();
        prop_assert!(g.report.converged && p.report.converged);
        let scale = g.radiosity.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        for (a, b) in g.radiosity.iter().zip(&p.radiosity) {
            for c in 0..3 {
                prop_assert!((a[c] - b[c]).abs() <= 1e-8 * scale, "{a:?} vs {b:?}");
            }
        }
        prop_assert!(energy_balance(&ff, &s, &g.radiosity).relative_imbalance < 1e-6);
        prop_assert!(energy_balance(&ff, &s, &p.radiosity).relative_imbalance < 1e-6);
    }
}

#[test]
fn solution_does_not_depend_on_threads() {
    let (ff, area) = enclosure(300, 11, 0.2);
    let mut s = uniform(&area, [0.0; 3], [0.7, 0.6, 0.5]);
    s.emission[3] = [5.0; 3];
    let cfg = SolveConfig::default();
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (rec, _) = ff.reciprocal(&area, 1e-12, 1000).unwrap();
            (
                gauss_seidel(&rec, &s, &cfg).unwrap(),
                progressive(&rec, &s, &cfg).unwrap(),
            )
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn bad_input_is_refused_with_what_and_where() {
    let row = |v: Vec<(u32, f64)>| v;
    let rows = [row(vec![(1, 0.5)]), row(vec![(0, f64::NAN)])];
    let err = FormFactors::from_rows(2, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])));
    assert!(
        matches!(
            err,
            Err(Error::BadValue {
                row: 1,
                column: 0,
                ..
            })
        ),
        "{err:?}"
    );
    let rows = [row(vec![(1, 0.7), (1, 0.4)]), row(vec![])];
    let err = FormFactors::from_rows(2, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])));
    assert!(
        matches!(err, Err(Error::RowSumAboveOne { row: 0, .. })),
        "{err:?}"
    );
    let rows = [row(vec![(5, 0.1)])];
    let err = FormFactors::from_rows(2, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])));
    assert!(
        matches!(
            err,
            Err(Error::EntryOutOfRange {
                row: 0,
                column: 5,
                ..
            })
        ),
        "{err:?}"
    );
    let err = FormFactors::from_rows(2, [(0u32, &[][..])]);
    assert!(
        matches!(err, Err(Error::MissingRow { patch: 1, .. })),
        "{err:?}"
    );
    let err = FormFactors::from_rows(1, [(0u32, &[][..]), (0u32, &[][..])]);
    assert!(
        matches!(err, Err(Error::DuplicateRow { patch: 0 })),
        "{err:?}"
    );

    let ff = FormFactors::from_rows(1, [(0u32, &[][..])]).unwrap();
    let bad = |s: Surfaces| gauss_seidel(&ff, &s, &SolveConfig::default());
    let good = Surfaces {
        area: vec![1.0],
        emission: vec![[1.0; 3]],
        reflectance: vec![[0.5; 3]],
    };
    assert!(bad(good.clone()).is_ok());
    let e = bad(Surfaces {
        reflectance: vec![[1.0, 0.5, 0.5]],
        ..good.clone()
    });
    assert!(
        matches!(
            e,
            Err(Error::BadSurface {
                patch: 0,
                what: "reflectance",
                ..
            })
        ),
        "{e:?}"
    );
    let e = bad(Surfaces {
        area: vec![0.0],
        ..good.clone()
    });
    assert!(
        matches!(
            e,
            Err(Error::BadSurface {
                patch: 0,
                what: "area",
                ..
            })
        ),
        "{e:?}"
    );
    let e = bad(Surfaces {
        emission: vec![],
        ..good.clone()
    });
    assert!(
        matches!(
            e,
            Err(Error::LengthMismatch {
                what: "emissions",
                ..
            })
        ),
        "{e:?}"
    );
    let e = gauss_seidel(
        &ff,
        &good,
        &SolveConfig {
            tolerance: f64::NAN,
            max_iterations: 1,
        },
    );
    assert!(
        matches!(
            e,
            Err(Error::BadConfig {
                what: "tolerance",
                ..
            })
        ),
        "{e:?}"
    );
}

#[test]
fn non_convergence_is_reported_not_raised() {
    let (ff, area) = enclosure(40, 3, 0.3);
    let s = uniform(&area, [1.0; 3], [0.9; 3]);
    let cfg = SolveConfig {
        tolerance: 1e-12,
        max_iterations: 2,
    };
    let g = gauss_seidel(&ff, &s, &cfg).unwrap();
    assert!(!g.report.converged && g.report.iterations == 2 && g.report.residual > 1e-12);
}

#[test]
fn row_l1_distance_merges_sparse_rows() {
    let rows_a = [vec![(0u32, 0.25), (2, 0.5)], vec![(1, 0.125)], vec![]];
    let rows_b = [
        vec![(1u32, 0.25), (2, 0.25)],
        vec![(1, 0.125)],
        vec![(0, 0.5)],
    ];
    let m = |r: &[Vec<(u32, f64)>; 3]| {
        FormFactors::from_rows(3, r.iter().enumerate().map(|(i, v)| (i as u32, &v[..]))).unwrap()
    };
    let (a, b) = (m(&rows_a), m(&rows_b));
    assert_eq!(a.row_l1_distance(&b, 0), 0.25 + 0.25 + 0.25);
    assert_eq!(a.row_l1_distance(&b, 1), 0.0);
    assert_eq!(a.row_l1_distance(&b, 2), 0.5);
    assert_eq!(b.row_l1_distance(&a, 2), 0.5);
    // Against the reciprocal matrix, whose values carry a row scale.
    let (ff, area) = crate::enclosure(12, 5, 0.4);
    let (rec, report) = ff.reciprocal(&area, 1e-12, 1000).unwrap();
    let mean: f64 = (0..12).map(|i| ff.row_l1_distance(&rec, i)).sum::<f64>() / 12.0;
    assert!(
        (mean - report.mean_row_l1_change).abs() < 1e-6,
        "{mean} vs {report:?}"
    );
}
