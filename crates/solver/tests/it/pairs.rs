//! The pair storage against the CSR rows: the same entries, and the same bits from
//! every product, sweep and shot, on random matrices whose patterns are not symmetric.

use crate::{enclosure, uniform};
use proptest::prelude::*;
use rad_solver::{
    gauss_seidel, progressive, Error, FormFactors, Operator, PairBuilder, PairMatrix, SolveConfig,
};

/// Uniform draws in [0, 1) from `seed` (xorshift).
pub fn draws(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed | 1;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Random rows: each patch sees a random subset (so the pattern is not symmetric),
/// some entries split in two (a column repeated) and some rows shuffled.
pub fn random_rows(n: usize, seed: u64, density: f64) -> Vec<Vec<(u32, f64)>> {
    let mut next = draws(seed);
    (0..n)
        .map(|i| {
            let mut row = Vec::new();
            for j in 0..n {
                if (j != i || next() < 0.1) && next() < density {
                    let f = next() * 0.9 / n as f64;
                    if next() < 0.2 {
                        row.push((j as u32, f * 0.25));
                        row.push((j as u32, f * 0.75));
                    } else {
                        row.push((j as u32, f));
                    }
                }
            }
            if next() < 0.5 {
                row.reverse();
            }
            row
        })
        .collect()
}

fn both(rows: &[Vec<(u32, f64)>]) -> (FormFactors, PairMatrix) {
    let n = rows.len();
    let ff = FormFactors::from_rows(n, rows.iter().enumerate().map(|(i, r)| (i as u32, &r[..])))
        .unwrap();
    let mut b = PairBuilder::new(n);
    for (i, r) in rows.iter().enumerate() {
        b.push_row(i as u32, r).unwrap();
    }
    (ff, b.finish().unwrap())
}

pub fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
    v.iter().map(|x| x.map(f64::to_bits)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn pairs_hold_the_rows_and_give_their_bits(
        n in 1usize..60, seed in any::<u64>(), density in 0.0f64..0.7,
    ) {
        let rows = random_rows(n, seed, density);
        let (ff, pm) = both(&rows);
        prop_assert_eq!(&pm.to_form_factors(), &ff);
        for i in 0..n as u32 {
            for j in 0..n as u32 {
                prop_assert_eq!(pm.get(i, j).to_bits(), ff.get(i, j).to_bits());
            }
        }
        prop_assert_eq!(PairMatrix::from_form_factors(&ff).to_form_factors(), ff.clone());
        let x: Vec<[f64; 3]> = (0..n).map(|i| [1.0 + i as f64, 0.5, (i as f64).sin().abs()]).collect();
        prop_assert_eq!(bits(&Operator::apply(&pm, &x)), bits(&Operator::apply(&ff, &x)));
        // (An empty row sums to -0 as an iterator's sum, to +0 here.)
        let sums = |v: Vec<f64>| v.iter().map(|v| (v + 0.0).to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(sums(pm.row_sums()), sums(ff.row_sums()));
        let area: Vec<f64> = (0..n).map(|i| 0.5 + (i as f64 * 0.7).cos().abs()).collect();
        let s = uniform(&area, [0.1, 0.0, 0.2], [0.6, 0.5, 0.4]);
        let (mut b1, mut b2) = (x.clone(), x.clone());
        let c1 = ff.sweep(&s, &mut b1);
        let c2 = pm.sweep(&s, &mut b2);
        prop_assert_eq!(bits(&b1), bits(&b2));
        prop_assert_eq!((c1.0.to_bits(), c1.1.to_bits()), (c2.0.to_bits(), c2.1.to_bits()));
        for i in 0..n as u32 {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            ff.shoot(i, &area, |j, k| a.push((j, k.to_bits())));
            pm.shoot(i, &area, |j, k| b.push((j, k.to_bits())));
            prop_assert_eq!(a, b);
        }
    }

    #[test]
    fn reciprocal_pairs_solve_as_the_rows_do(n in 3usize..40, seed in any::<u64>()) {
        let (rec, area) = enclosure(n, seed, 0.4);
        let pm = PairMatrix::from_form_factors(&rec);
        prop_assert!(pm.is_symmetric());
        let mut s = uniform(&area, [0.0; 3], [0.7, 0.5, 0.3]);
        s.emission[0] = [1.0, 2.0, 3.0];
        let cfg = SolveConfig { tolerance: 1e-10, max_iterations: 1_000_000 };
        for (a, b) in [
            (gauss_seidel(&rec, &s, &cfg).unwrap(), gauss_seidel(&pm, &s, &cfg).unwrap()),
            (progressive(&rec, &s, &cfg).unwrap(), progressive(&pm, &s, &cfg).unwrap()),
        ] {
            prop_assert_eq!(bits(&a.radiosity), bits(&b.radiosity));
            prop_assert_eq!(a.report.iterations, b.report.iterations);
        }
    }
}

#[test]
fn reciprocal_of_pairs_is_reciprocal_and_keeps_row_sums() {
    let rows = random_rows(80, 5, 0.3);
    let (_, pm) = both(&rows);
    let area: Vec<f64> = (0..80).map(|i| 0.2 + (i % 7) as f64 * 0.3).collect();
    let (rec, report) = pm.reciprocal(&area, 1e-12, 10_000).unwrap();
    assert!(report.converged, "{report:?}");
    assert!(rec.is_symmetric());
    let (old, new) = (pm.row_sums(), rec.row_sums());
    // Stored as f32: each value within 6e-8 of its own, so each sum within 6e-8 of its.
    assert!(report.max_row_sum_error <= 6e-8 * old.iter().fold(0.0f64, |m, v| m.max(*v)));
    for i in 0..80u32 {
        assert!((old[i as usize] - new[i as usize]).abs() <= report.max_row_sum_error);
        for j in 0..80u32 {
            let (a, b) = (
                area[i as usize] * rec.get(i, j),
                area[j as usize] * rec.get(j, i),
            );
            assert!((a - b).abs() <= 1e-12 * a.max(b), "{i} {j}: {a} vs {b}");
        }
    }
    assert!(rec.heap_bytes() < pm.heap_bytes());
    assert_eq!(rec.pattern_bytes(), pm.pattern_bytes());
}

#[test]
fn builder_refuses_rows_out_of_order_and_missing() {
    let mut b = PairBuilder::new(3);
    b.push_row(0, &[(1, 0.5)]).unwrap();
    assert!(matches!(
        b.push_row(0, &[]),
        Err(Error::DuplicateRow { patch: 0 })
    ));
    assert!(matches!(
        b.push_row(2, &[]),
        Err(Error::MissingRow { patch: 1, .. })
    ));
    assert!(matches!(
        b.push_row(1, &[(7, 0.1)]),
        Err(Error::EntryOutOfRange {
            row: 1,
            column: 7,
            ..
        })
    ));
    assert!(matches!(
        b.push_row(1, &[(0, f64::NAN)]),
        Err(Error::BadValue {
            row: 1,
            column: 0,
            ..
        })
    ));
    assert!(matches!(
        b.push_row(1, &[(0, 0.6), (2, 0.6)]),
        Err(Error::RowSumAboveOne { row: 1, .. })
    ));
    assert!(matches!(
        b.push_row(5, &[]),
        Err(Error::EntryOutOfRange { row: 5, .. })
    ));
    b.push_row(1, &[(0, 0.5)]).unwrap();
    assert!(matches!(
        b.finish(),
        Err(Error::MissingRow { patch: 2, .. })
    ));
}
