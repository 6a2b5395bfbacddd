//! Rows shared among processes: parts balanced by work units, rows as bytes, and
//! parts' rows joined equal to one run's, to the bit; processes simulated by threads
//! ([`in_threads`]) share rows and solves as one process makes them, and a Jacobi solve
//! shared by rows is the same whatever their number.

use rad_geometry::{scenes, Scene};
use rad_pipeline::share::{
    decode_rows, encode_rows, in_threads, join_rows, shared_rows, shares, SharedRun,
};
use rad_pipeline::solve::{solve_scene, solve_scene_shared, SceneSolveConfig};
use rad_pipeline::{
    rows, CasterKind, Hemisphere, HemisphereConfig, Mode, RowMethod, SceneFile, Solver, Storage,
};

fn methods() -> [RowMethod; 3] {
    [
        RowMethod::Exact {
            caster: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Faithful,
            centres: CasterKind::Grid,
        },
    ]
}

#[test]
fn shares_cover_the_patches_and_balance_the_lofts_work_within_10_percent() {
    let scene = Scene::new(scenes::loft()).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    for method in methods() {
        for parts in 1..=8 {
            let shares = shares(&scene, method, &all, parts);
            assert_eq!(shares.len(), parts);
            let mut seen: Vec<u32> = shares.iter().flat_map(|s| s.patches.clone()).collect();
            seen.sort();
            assert_eq!(seen, all, "{method:?}, {parts} parts");
            // A share never splits an estimated polygon.
            if method.mode().is_some() {
                let owner = |p: u32| shares.iter().position(|s| s.patches.contains(&p));
                for poly in 0..scene.polygons().len() {
                    let of: Vec<_> = scene
                        .patches()
                        .iter()
                        .enumerate()
                        .filter(|(_, p)| p.polygon as usize == poly)
                        .map(|(k, _)| owner(k as u32))
                        .collect();
                    assert!(of.windows(2).all(|w| w[0] == w[1]), "polygon {poly}");
                }
            }
            let units: Vec<f64> = shares.iter().map(|s| s.units).collect();
            let mean = units.iter().sum::<f64>() / parts as f64;
            let worst = units.iter().cloned().fold(0.0, f64::max);
            if parts <= 4 {
                assert!(worst <= 1.1 * mean, "{method:?}, {parts} parts: {units:?}");
            }
        }
    }
}

#[test]
fn parts_rows_joined_are_one_runs_rows_to_the_bit() {
    let scene = Scene::new(scenes::cornell_box(120.0)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(12, 48)).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    for method in methods() {
        let whole = rows(&scene, &hemi, method, &all, &|_| {}).unwrap();
        for parts in [2, 3, 5] {
            let made: Vec<_> = shares(&scene, method, &all, parts)
                .iter()
                .map(|s| {
                    let part = rows(&scene, &hemi, method, &s.patches, &|_| {}).unwrap();
                    // Through bytes, as between processes.
                    decode_rows(&encode_rows(&part), method).unwrap()
                })
                .collect();
            let joined = join_rows(method, &all, made).unwrap();
            assert_eq!(joined.rows, whole.rows, "{method:?}, {parts} parts");
            assert_eq!(joined.sources, whole.sources);
            assert_eq!(joined.stats.exact, whole.stats.exact);
            assert_eq!(joined.stats.estimated, whole.stats.estimated);
        }
    }
}

#[test]
fn rows_bytes_that_are_cut_or_padded_are_refused() {
    let scene = Scene::new(scenes::cube(3)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(6, 24)).unwrap();
    let method = methods()[0];
    let made = rows(&scene, &hemi, method, &[0, 1, 2], &|_| {}).unwrap();
    let bytes = encode_rows(&made);
    assert_eq!(decode_rows(&bytes, method).unwrap().rows, made.rows);
    for cut in [0, 3, 4, 40, bytes.len() / 2, bytes.len() - 1] {
        let e = decode_rows(&bytes[..cut], method).unwrap_err().to_string();
        assert!(e.contains("rows from another process"), "{cut}: {e}");
    }
    let mut long = bytes.clone();
    long.push(0);
    assert!(decode_rows(&long, method)
        .unwrap_err()
        .to_string()
        .contains("left over"));
    let mut huge = bytes;
    huge[4..12].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(decode_rows(&huge, method).is_err());
}

#[test]
fn view_factors_of_shared_rows_are_one_runs_to_the_bit() {
    use rad_pipeline::viewfactors::{
        area_rows, row_patches, view_factors, view_factors_of_rows, Grouping, ViewFactorConfig,
    };
    use rad_pipeline::Enclosure;
    let scene = Scene::new(scenes::cornell_box(120.0)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(12, 48)).unwrap();
    for (by, enclosure) in [
        (Grouping::Polygon, Enclosure::Reciprocal),
        (Grouping::Patch, Enclosure::Raw),
    ] {
        let opts = ViewFactorConfig {
            by,
            enclosure,
            ..ViewFactorConfig::for_scene(&scene)
        };
        let whole = view_factors(&scene, &hemi, &opts, &|_| {}).unwrap();
        let ids = row_patches(&scene);
        let method = RowMethod::Exact {
            caster: opts.caster,
        };
        let parts: Vec<_> = shares(&scene, method, &ids, 3)
            .iter()
            .map(|s| {
                let rows = area_rows(&scene, &hemi, &opts, &s.patches, &|_| {}).unwrap();
                let n = rows.len();
                rad_pipeline::Rows {
                    method,
                    rows,
                    sources: vec![None; n],
                    stats: Default::default(),
                }
            })
            .collect();
        let joined = join_rows(method, &ids, parts).unwrap();
        let shared = view_factors_of_rows(&scene, &opts, joined.rows.clone()).unwrap();
        assert_eq!(shared.matrix.rows, whole.matrix.rows, "{by:?}");
        assert_eq!(shared.back, whole.back);
        // Rows not one a patch, in order, are refused.
        assert!(view_factors_of_rows(&scene, &opts, joined.rows[1..].to_vec()).is_err());
    }
}

/// A solution file as JSON, timings removed (they differ from run to run).
fn without_timings(file: &rad_pipeline::solve::SolutionFile) -> serde_json::Value {
    let mut v = serde_json::to_value(file).unwrap();
    v.as_object_mut().unwrap().remove("timings");
    v
}

fn cornell() -> SceneFile {
    SceneFile {
        path: "cornell.json".into(),
        scene: Scene::new(scenes::cornell_box(120.0)).unwrap(),
        hash: 7,
        view3d: None,
        triangulation: Default::default(),
        repair: Default::default(),
        repaired: false,
        notes: Vec::new(),
    }
}

#[test]
fn processes_in_threads_share_rows_and_solves_as_one_process_does() {
    let scene = cornell();
    let hemi = Hemisphere::new(HemisphereConfig::exact(8, 32)).unwrap();
    let n = scene.scene.patches().len();
    let all: Vec<u32> = (0..n as u32).collect();
    for method in methods() {
        let one = rows(&scene.scene, &hemi, method, &all, &|_| {}).unwrap();
        for (size, everyone) in [(2, false), (3, true), (8, false)] {
            let got = in_threads(size, |peers| {
                let run = SharedRun {
                    scene: &scene.scene,
                    scene_hash: scene.hash,
                    method,
                    what: b"8x32",
                };
                let mut make = |ids: &[u32]| rows(&scene.scene, &hemi, method, ids, &|_| {});
                shared_rows(run, &all, peers, everyone, &mut make).unwrap()
            });
            // Gathered on the first, or with `everyone` on every process.
            for (r, g) in got.iter().enumerate() {
                match &g.rows {
                    Some(made) => assert_eq!(made.rows, one.rows, "{method:?}, {size}: {r}"),
                    None => assert!(r > 0 && !everyone),
                }
            }
            let units: Vec<f64> = got[0].shares.iter().map(|s| s.units).collect();
            assert_eq!(units.len(), size);
        }
    }
    // Solves: stored (gathered on the first), matrix-free (every process shoots).
    let method = methods()[0];
    for storage in [Storage::Stored, Storage::MatrixFree] {
        let opts = SceneSolveConfig {
            storage: Some(storage),
            ..SceneSolveConfig::default()
        };
        let (want, _, _) = solve_scene(&scene, &hemi, method, &opts, &|_| {}).unwrap();
        for size in [2, 4] {
            let got = in_threads(size, |peers| {
                solve_scene_shared(&scene, &hemi, method, &opts, &|_| {}, peers).unwrap()
            });
            let (file, _, _) = got[0].as_ref().unwrap();
            assert_eq!(without_timings(file), without_timings(&want), "{storage:?}");
            assert!(got[1..].iter().all(Option::is_none));
        }
    }
}

#[test]
fn a_jacobi_solve_shared_by_rows_is_the_same_whatever_the_processes() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(8, 32)).unwrap();
    for (scene, method) in [(cornell(), methods()[0]), (cornell(), methods()[1])] {
        let opts = SceneSolveConfig {
            solver: Solver::Jacobi,
            storage: Some(Storage::Stored),
            ..SceneSolveConfig::default()
        };
        let (want, solved, _) = solve_scene(&scene, &hemi, method, &opts, &|_| {}).unwrap();
        assert!(solved.solution.report.converged);
        assert_eq!(solved.solution.report.solver, Solver::Jacobi);
        // Energy balanced to what the residual leaves (see rad-solver's rowset tests).
        assert!(
            solved.balance.relative_imbalance < 1e-7,
            "{:?}",
            solved.balance
        );
        for size in [2, 3, 5] {
            let got = in_threads(size, |peers| {
                solve_scene_shared(&scene, &hemi, method, &opts, &|_| {}, peers).unwrap()
            });
            let (file, _, _) = got[0].as_ref().unwrap();
            assert_eq!(
                without_timings(file),
                without_timings(&want),
                "{size} processes"
            );
            assert!(got[1..].iter().all(Option::is_none));
        }
        // Gauss-Seidel on the pair storage, one process: the same radiosities within
        // the tolerances, and the same input asymmetry to the bit.
        let gs = SceneSolveConfig {
            storage: Some(Storage::Stored),
            ..SceneSolveConfig::default()
        };
        let (other, by_pairs, _) = solve_scene(&scene, &hemi, method, &gs, &|_| {}).unwrap();
        let top = other
            .radiosity
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(*v));
        for (a, b) in want
            .radiosity
            .iter()
            .flatten()
            .zip(other.radiosity.iter().flatten())
        {
            assert!((a - b).abs() <= 1e-8 * top, "{a} vs {b}");
        }
        let (r, p) = (solved.reciprocity.unwrap(), by_pairs.reciprocity.unwrap());
        assert_eq!(r.max_input_asymmetry, p.max_input_asymmetry);
        assert_eq!(r.median_input_asymmetry, p.median_input_asymmetry);
        assert_eq!(want.matrix.pairs, other.matrix.pairs);
    }
}

#[test]
fn processes_of_different_runs_or_a_failing_one_end_every_process_with_an_error() {
    let scene = cornell();
    let hemi = Hemisphere::new(HemisphereConfig::exact(8, 32)).unwrap();
    let method = methods()[0];
    let got = in_threads(2, |peers| {
        let opts = SceneSolveConfig {
            solver: Solver::Jacobi,
            storage: Some(Storage::Stored),
            config: rad_pipeline::SolveConfig {
                tolerance: if peers.rank() == 0 { 1e-9 } else { 1e-6 },
                ..Default::default()
            },
            ..SceneSolveConfig::default()
        };
        solve_scene_shared(&scene, &hemi, method, &opts, &|_| {}, peers)
            .err()
            .map(|e| e.to_string())
    });
    for e in &got {
        let e = e.as_deref().unwrap_or("no error");
        assert!(e.contains("made rows of another run"), "{e}");
    }
    // Rows that fail on one process (a rank's share of a bad hemisphere, say: here a
    // patch list naming a patch the scene does not have) fail every process.
    let got = in_threads(3, |peers| {
        let run = SharedRun {
            scene: &scene.scene,
            scene_hash: scene.hash,
            method,
            what: b"",
        };
        let all: Vec<u32> = (0..scene.scene.patches().len() as u32).collect();
        let mut make = |ids: &[u32]| {
            let mut ids = ids.to_vec();
            if peers.rank() == 2 {
                ids.push(u32::MAX);
            }
            rows(&scene.scene, &hemi, method, &ids, &|_| {})
        };
        shared_rows(run, &all, peers, false, &mut make)
            .err()
            .map(|e| e.to_string())
    });
    for e in &got {
        let e = e.as_deref().unwrap_or("no error");
        assert!(e.starts_with("rank 2: "), "{e}");
    }
}

#[test]
fn a_simulated_process_that_ends_early_or_panics_ends_the_others_collectives() {
    // Rank 1 returns before the collective the others wait in: theirs is an error.
    let got = in_threads(3, |peers| {
        if peers.rank() == 1 {
            return Ok(Vec::new());
        }
        peers.all_gather(Ok(vec![1, 2, 3]))
    });
    assert!(got[1].is_ok());
    for r in [0, 2] {
        let e = got[r].as_ref().unwrap_err();
        assert!(e.contains("a process ended"), "{e}");
    }
    // A panic is passed on once every process has ended (no process left waiting).
    let caught = std::panic::catch_unwind(|| {
        in_threads(2, |peers| {
            if peers.rank() == 0 {
                panic!("rank 0 fails");
            }
            peers.gather(Ok(Vec::new())).map(|_| ())
        })
    });
    assert!(caught.is_err());
    // Processes calling different collectives: out of step, every one.
    let got = in_threads(2, |peers| match peers.rank() {
        0 => peers.all_gather(Ok(Vec::new())).map(|_| ()),
        _ => peers.exchange(Ok(vec![Vec::new(), Vec::new()])).map(|_| ()),
    });
    for e in &got {
        assert!(e.as_ref().unwrap_err().contains("out of step"));
    }
}
