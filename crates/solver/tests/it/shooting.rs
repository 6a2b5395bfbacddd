//! Matrix-free shooting against the stored-matrix solvers; the cache and the batch
//! change what is computed, not the answer.

use crate::{enclosure, uniform};
use rad_solver::{
    gauss_seidel, shoot_matrix_free, Error, FormFactors, MatrixFreeConfig, ShotRow, SolveConfig,
};

fn row_of(ff: &FormFactors, i: u32) -> ShotRow {
    let (c, _) = ff.row(i);
    ShotRow {
        columns: c.to_vec(),
        values: c.iter().map(|&j| ff.get(i, j) as f32).collect(),
    }
}

#[test]
fn matrix_free_shooting_solves_the_system_and_conserves_energy() {
    let (ff, area) = enclosure(120, 3, 0.2);
    let mut s = uniform(&area, [0.0; 3], [0.6, 0.4, 0.2]);
    s.emission[5] = [3.0, 2.0, 1.0];
    s.emission[77] = [0.5, 1.0, 2.0];
    let cfg = SolveConfig {
        tolerance: 1e-10,
        max_iterations: 10_000_000,
    };
    let reference = gauss_seidel(&ff, &s, &cfg).unwrap();
    let scale = reference
        .radiosity
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    let mut answers = Vec::new();
    for (batch, cache_bytes) in [(1, 0), (16, 0), (16, usize::MAX)] {
        let mut asked = 0;
        let mut last = (0, 1.0);
        let (sol, stats) = shoot_matrix_free::<Error>(
            &s,
            &MatrixFreeConfig {
                solve: cfg,
                batch,
                cache_bytes,
            },
            &mut |ids, _| {
                asked += ids.len();
                Ok(ids.iter().map(|&i| row_of(&ff, i)).collect())
            },
            &mut |shots, unshot| last = (shots, unshot),
        )
        .unwrap();
        assert!(sol.report.converged, "{:?}", sol.report);
        assert_eq!(stats.rows_made, asked);
        assert_eq!(last.0, stats.shots);
        assert!(last.1 < 1e-8, "{last:?}");
        assert!(stats.relative_imbalance < 1e-12, "{stats:?}");
        if cache_bytes == usize::MAX {
            // Every shooter's row made once.
            assert!(stats.rows_made <= 120 && stats.cached_rows == stats.rows_made);
        } else {
            assert_eq!(stats.rows_made, stats.shots);
        }
        // F_ij rounded to f32 (6e-8) and F_ji by reciprocity from it.
        for (a, b) in reference.radiosity.iter().zip(&sol.radiosity) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * scale, "{a:?} vs {b:?}");
            }
        }
        answers.push((batch, sol.radiosity));
    }
    // The cache changes nothing: the same batch gives the same bits.
    assert_eq!(answers[1].1, answers[2].1);
}

#[test]
fn matrix_free_refuses_a_zero_batch_and_passes_source_errors_on() {
    let (_, area) = enclosure(5, 1, 0.5);
    let mut s = uniform(&area, [0.0; 3], [0.5; 3]);
    s.emission[0] = [1.0; 3];
    let cfg = |batch| MatrixFreeConfig {
        solve: SolveConfig::default(),
        batch,
        cache_bytes: 0,
    };
    let err = shoot_matrix_free::<Error>(&s, &cfg(0), &mut |_, _| Ok(vec![]), &mut |_, _| {});
    assert!(matches!(err, Err(Error::BadConfig { what: "batch", .. })));
    let err = shoot_matrix_free::<Error>(
        &s,
        &cfg(4),
        &mut |_, _| {
            Err(Error::MissingRow {
                patch: 9,
                n_patches: 5,
            })
        },
        &mut |_, _| {},
    );
    assert!(matches!(err, Err(Error::MissingRow { patch: 9, .. })));
}
