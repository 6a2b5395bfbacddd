//! Matrix-free shooting against the stored-matrix solvers; the cache and the batch
//! change what is computed, not the answer.

use crate::{enclosure, uniform};
use rad_solver::{
    gauss_seidel, shoot_matrix_free, Error, FormFactors, MatrixFreeConfig, RowSums, ShootProgress,
    ShotRow, SolveConfig,
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
    // (Classical shooting, one at a time and in batches, the cache empty and whole;
    // then overshooting.)
    let runs = [
        (1, 0, 1.0),
        (16, 0, 1.0),
        (16, usize::MAX, 1.0),
        (16, 0, 1.5),
        (16, usize::MAX, 1.5),
        (1, 0, 1.2),
    ];
    for (batch, cache_bytes, overshoot) in runs {
        let mut asked = 0;
        let (mut last, mut summed) = ((0, 1.0), 0);
        let (sol, stats) = shoot_matrix_free::<Error>(
            &s,
            &MatrixFreeConfig {
                solve: cfg,
                batch,
                cache_bytes,
                overshoot,
            },
            None,
            &mut |ids, _| {
                asked += ids.len();
                Ok(ids.iter().map(|&i| row_of(&ff, i)).collect())
            },
            &mut |p| match p {
                ShootProgress::Rows(k) => summed = k,
                ShootProgress::Shots { shots, pending } => last = (shots, pending),
            },
        )
        .unwrap();
        assert_eq!(summed, 120);
        assert!(sol.report.converged, "{:?}", sol.report);
        assert_eq!(stats.rows_made, asked);
        assert_eq!(last.0, stats.shots);
        assert!(last.1 < 1e-8, "{last:?}");
        assert!(stats.relative_imbalance < 1e-12, "{stats:?}");
        // (The light still to come, never negative, even where overshooting leaves the
        // patches owing some: what a solution file may hold.)
        assert!(sol.ambient.iter().all(|a| *a >= 0.0), "{:?}", sol.ambient);
        if cache_bytes == usize::MAX {
            // Every row made once, by the pass that sums them.
            assert!(stats.rows_made == 120 && stats.cached_rows == 120);
        } else {
            assert_eq!(stats.rows_made, 120 + stats.shots);
        }
        // F_ij rounded to f32 (6e-8) and F_ji by reciprocity from it.
        for (a, b) in reference.radiosity.iter().zip(&sol.radiosity) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-6 * scale, "{a:?} vs {b:?}");
            }
        }
        answers.push((stats.shots, sol.radiosity));
    }
    // The cache changes nothing: the same batch gives the same bits.
    assert_eq!(answers[1].1, answers[2].1);
    assert_eq!(answers[3].1, answers[4].1);
    // Overshooting changes the path, not the answer (within the tolerance, checked
    // above against Gauss-Seidel).
    assert_ne!(answers[1].1, answers[3].1);
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
        overshoot: 1.0,
    };
    let none = &mut |_: &[u32], _: &mut Vec<ShotRow>| Ok(vec![]);
    let err = shoot_matrix_free::<Error>(&s, &cfg(0), None, none, &mut |_| {});
    assert!(matches!(err, Err(Error::BadConfig { what: "batch", .. })));
    for overshoot in [0.9, 2.0, f64::NAN, f64::INFINITY] {
        let bad = MatrixFreeConfig {
            overshoot,
            ..cfg(4)
        };
        let err = shoot_matrix_free::<Error>(&s, &bad, None, none, &mut |_| {});
        let e = err.err().unwrap();
        assert!(
            matches!(
                e,
                Error::BadConfig {
                    what: "overshoot",
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("overshoot"), "{e}");
    }
    let err = shoot_matrix_free::<Error>(
        &s,
        &cfg(4),
        None,
        &mut |_, _| {
            Err(Error::MissingRow {
                patch: 9,
                n_patches: 5,
            })
        },
        &mut |_| {},
    );
    assert!(matches!(err, Err(Error::MissingRow { patch: 9, .. })));
    // A source that gives fewer rows than asked, in the first pass.
    let err = shoot_matrix_free::<Error>(&s, &cfg(4), None, none, &mut |_| {});
    assert!(matches!(err, Err(Error::RowSet { .. })), "{err:?}");
    // Sums given: rows in patch order, columns in range, every row.
    let mut sums = RowSums::new(5);
    let e = sums.add(1, 1.0, [(0, 0.5)]).unwrap_err().to_string();
    assert!(e.contains("patch 1") && e.contains("patch 0's"), "{e}");
    let e = sums.add(0, 1.0, [(5, 0.5)]).unwrap_err();
    assert!(
        matches!(e, Error::EntryOutOfRange { column: 5, .. }),
        "{e:?}"
    );
    sums.add(0, 1.0, [(1, 0.5)]).unwrap();
    assert!(!sums.is_complete());
    let err = shoot_matrix_free::<Error>(&s, &cfg(4), Some(sums), none, &mut |_| {});
    let e = err.err().unwrap().to_string();
    assert!(e.contains("row sums of 1 of 5 patches"), "{e}");
}

#[test]
fn matrix_free_shooting_solves_the_average_of_rows_and_their_reciprocals() {
    // Rows that are not reciprocal (an enclosure's rows, each entry scaled by 0.7 to
    // 0.9), and a last patch that no row names but that sees the emitter and another: it receives
    // light only by gathering.
    let (ff, mut area) = enclosure(60, 7, 0.3);
    let n = 61;
    let mut rows: Vec<Vec<(u32, f64)>> = (0..60u32)
        .map(|i| {
            let (c, _) = ff.row(i);
            c.iter()
                .map(|&j| {
                    let w = 0.7 + 0.02 * ((i as usize * 7 + j as usize * 13) % 11) as f64;
                    (j, ff.get(i, j) * w)
                })
                .collect()
        })
        .collect();
    rows.push(vec![(5, 0.3), (6, 0.3)]);
    area.push(0.5);
    // (The values as shot: f32.)
    for r in &mut rows {
        for e in r.iter_mut() {
            e.1 = e.1 as f32 as f64;
        }
    }
    // K = (F + A⁻¹FᵀA) D / 2, held: d_j = 2 A_j r_j / (A_j r_j + Σ_i A_i F_ij).
    let r: Vec<f64> = rows.iter().map(|r| r.iter().map(|e| e.1).sum()).collect();
    let mut c = vec![0.0; n];
    for (i, row) in rows.iter().enumerate() {
        for &(j, f) in row {
            c[j as usize] += area[i] * f;
        }
    }
    let d: Vec<f64> = (0..n)
        .map(|j| 2.0 * area[j] * r[j] / (area[j] * r[j] + c[j]))
        .collect();
    assert!(d.iter().any(|&v| (v - 1.0).abs() > 0.05), "{d:?}");
    let mut avg: Vec<Vec<(u32, f64)>> = rows
        .iter()
        .map(|r| {
            r.iter()
                .map(|&(j, f)| (j, 0.5 * f * d[j as usize]))
                .collect()
        })
        .collect();
    for (i, r) in rows.iter().enumerate() {
        for &(j, f) in r {
            avg[j as usize].push((i as u32, 0.5 * f * area[i] / area[j as usize] * d[i]));
        }
    }
    let k =
        FormFactors::from_rows(n, avg.iter().enumerate().map(|(i, r)| (i as u32, &r[..]))).unwrap();
    let mut s = uniform(&area, [0.0; 3], [0.6, 0.4, 0.2]);
    s.emission[5] = [3.0, 2.0, 1.0];
    let cfg = SolveConfig {
        tolerance: 1e-11,
        max_iterations: 10_000_000,
    };
    let reference = gauss_seidel(&k, &s, &cfg).unwrap();
    let scale = reference
        .radiosity
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    let row = |i: u32| ShotRow {
        columns: rows[i as usize].iter().map(|e| e.0).collect(),
        values: rows[i as usize].iter().map(|e| e.1 as f32).collect(),
    };
    let (sol, stats) = shoot_matrix_free::<Error>(
        &s,
        &MatrixFreeConfig {
            solve: cfg,
            batch: 8,
            cache_bytes: usize::MAX,
            // (The pipeline's default: overshooting solves the same system.)
            overshoot: 1.2,
        },
        None,
        &mut |ids, _| Ok(ids.iter().map(|&i| row(i)).collect()),
        &mut |_| {},
    )
    .unwrap();
    assert!(sol.report.converged, "{:?}", sol.report);
    assert!(stats.relative_imbalance < 1e-12, "{stats:?}");
    // Power conserved: what escapes is exactly what the rows miss, `A_j B_j (1 − r_j)`.
    for ch in 0..3 {
        let missed: f64 = (0..n)
            .map(|j| area[j] * sol.radiosity[j][ch] * (1.0 - r[j]))
            .sum();
        let escaped = stats.escaped[ch] + stats.unshot[ch];
        assert!(
            (escaped - missed).abs() <= 1e-8 * stats.emitted[ch],
            "channel {ch}: {escaped} escaped, the rows miss {missed}"
        );
    }
    assert!(reference.radiosity[60][0] > 0.01 * scale);
    // F_ij rounded to f32 (6e-8) in the rows shot, K's values in the matrix held.
    for (i, (a, b)) in reference.radiosity.iter().zip(&sol.radiosity).enumerate() {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 1e-6 * scale,
                "patch {i}: {a:?} vs {b:?}"
            );
        }
    }
    // Plain shooting's system, A⁻¹FᵀA, is another: the halves are what made it K.
    let mut shot: Vec<Vec<(u32, f64)>> = vec![Vec::new(); n];
    for (i, r) in rows.iter().enumerate() {
        for &(j, f) in r {
            shot[j as usize].push((i as u32, f * area[i] / area[j as usize]));
        }
    }
    let t = FormFactors::from_rows(n, shot.iter().enumerate().map(|(i, r)| (i as u32, &r[..])))
        .unwrap();
    let other = gauss_seidel(&t, &s, &cfg).unwrap();
    let apart = (0..n)
        .map(|i| (other.radiosity[i][0] - sol.radiosity[i][0]).abs())
        .fold(0.0, f64::max);
    assert!(apart > 1e-3 * scale, "{apart}");
}
