//! Integration tests of rad-pipeline: rows streamed into the pair storage, and solves
//! on it, against the rows held whole and the CSR solve.

use rad_geometry::{scenes, Scene};
use rad_pipeline::images::render_image;
use rad_pipeline::solve::{solve, solve_scene, surfaces, SceneSolveConfig};
use rad_pipeline::{
    rows, rows_streamed, CasterKind, Hemisphere, HemisphereConfig, Mode, RenderConfig, RowMethod,
    SceneFile, Shading, Solver, Storage, View, DEFAULT_MEMORY_LIMIT, STREAM_CHUNK,
};
use rad_solver::FormFactors;

mod export;
mod motion;
mod scale;
mod share;

fn loft() -> SceneFile {
    SceneFile {
        path: "loft.json".into(),
        scene: Scene::new(scenes::loft()).unwrap(),
        hash: 1,
        view3d: None,
        triangulation: Default::default(),
        repair: Default::default(),
        repaired: false,
        notes: Vec::new(),
    }
}

fn all_rows(scene: &Scene, hemi: &Hemisphere, method: RowMethod) -> rad_pipeline::Rows {
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    rows(scene, hemi, method, &all, &|_| {}).unwrap()
}

#[test]
fn streamed_rows_are_the_rows_in_order() {
    let scene = loft();
    let n = scene.scene.patches().len();
    assert!(n > 4 * STREAM_CHUNK, "the loft streams in several chunks");
    let mut per_polygon = vec![0usize; scene.scene.polygons().len()];
    for p in scene.scene.patches() {
        per_polygon[p.polygon as usize] += 1;
    }
    let largest = per_polygon.iter().max().copied().unwrap_or(0);
    assert!(largest > STREAM_CHUNK, "a polygon of {largest} patches");
    let hemi = Hemisphere::new(HemisphereConfig::exact(6, 24)).unwrap();
    for method in [
        RowMethod::Exact {
            caster: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: CasterKind::Hierarchy,
        },
    ] {
        let whole = all_rows(&scene.scene, &hemi, method);
        let mut streamed = Vec::new();
        let mut chunks = 0;
        let done = std::sync::atomic::AtomicUsize::new(0);
        let stats = rows_streamed(
            &scene.scene,
            &hemi,
            method,
            &|k| {
                done.fetch_max(k, std::sync::atomic::Ordering::Relaxed);
            },
            &mut |made| {
                chunks += 1;
                // A chunk cuts a polygon larger than a chunk: what a stream holds
                // follows the chunk, not the largest polygon.
                assert!(made.rows.len() <= STREAM_CHUNK, "{} rows", made.rows.len());
                streamed.extend(made.rows);
                Ok(())
            },
        )
        .unwrap();
        assert!(chunks > 4);
        assert_eq!(done.into_inner(), n);
        assert_eq!(streamed, whole.rows, "{method}");
        assert_eq!(stats.exact + stats.estimated + stats.fallback_exact, n);
        assert_eq!(stats.exact, whole.stats.exact);
    }
}

/// A mesh's windows cross chunks: a stream of estimated rows makes each window once
/// (its centre cast once) and keeps the rows of later chunks, in the list's order, for
/// the whole list and for a list in another order.
#[test]
fn streamed_estimates_make_each_window_once() {
    let scene = Scene::new(scenes::loft_patches()).unwrap();
    let n = scene.patches().len();
    let hemi = Hemisphere::new(HemisphereConfig::exact(4, 16)).unwrap();
    let method = RowMethod::Estimated {
        mode: Mode::Improved,
        centres: CasterKind::Hierarchy,
    };
    let schedule = rad_estimator::Schedule::of(&scene);
    let crossing = schedule
        .windows()
        .iter()
        .filter(|w| {
            w.estimated
                .iter()
                .any(|&p| p as usize / STREAM_CHUNK != w.centre as usize / STREAM_CHUNK)
        })
        .count();
    assert!(crossing > 100, "{crossing} windows cross chunks");
    let whole = all_rows(&scene, &hemi, method);
    // Every patch's, in order; and every third patch's, backwards by polygon.
    let all: Vec<u32> = (0..n as u32).collect();
    let some: Vec<u32> = (0..n as u32).rev().step_by(3).collect();
    // Patches listed twice, within the reach of the rows kept ahead and beyond it.
    let twice: Vec<u32> = (0..2000)
        .chain(100..700)
        .chain(1500..1600)
        .chain(5000..5600)
        .chain(0..300)
        .collect();
    for list in [all, some, twice] {
        let mut streamed = Vec::new();
        let stats =
            rad_pipeline::rows_streamed_of(&scene, &hemi, method, &list, &|_| {}, &mut |made| {
                streamed.extend(made.rows);
                Ok(())
            })
            .unwrap();
        let want: Vec<_> = list
            .iter()
            .map(|&p| whole.rows[p as usize].clone())
            .collect();
        assert_eq!(streamed.len(), list.len());
        assert!(
            streamed == want,
            "streamed rows equal the rows, in the list's order"
        );
        if list.len() == n {
            assert_eq!(stats.exact, whole.stats.exact, "each centre cast once");
            assert_eq!(stats.exact + stats.estimated + stats.fallback_exact, n);
        }
    }
}

#[test]
fn streamed_solve_matches_the_rows_solve_and_not_the_threads() {
    let scene = loft();
    let hemi = Hemisphere::new(HemisphereConfig::exact(10, 40)).unwrap();
    let method = RowMethod::Exact {
        caster: CasterKind::Hierarchy,
    };
    let n = scene.scene.patches().len();
    // The rows held whole, as CSR, made reciprocal there.
    let made = all_rows(&scene.scene, &hemi, method);
    let ff =
        FormFactors::from_rows(n, made.rows.iter().map(|r| (r.patch, &r.entries[..]))).unwrap();
    let s = surfaces(&scene.scene);
    let (rec, _) = ff.reciprocal(&s.area, 1e-9, 5_000).unwrap();
    for solver in [Solver::GaussSeidel, Solver::Progressive, Solver::Jacobi] {
        let opts = SceneSolveConfig {
            solver,
            ..SceneSolveConfig::default()
        };
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| solve_scene(&scene, &hemi, method, &opts, &|_| {}).unwrap())
        };
        let (one, solved, _) = run(1);
        let (two, _, _) = run(2);
        assert_eq!(
            serde_json::to_string(&one.radiosity).unwrap(),
            serde_json::to_string(&two.radiosity).unwrap()
        );
        assert!(solved.solution.report.converged);
        assert!(solved.balance.relative_imbalance < 1e-8);
        let reference = match solver {
            Solver::GaussSeidel => rad_solver::gauss_seidel(&rec, &s, &opts.config),
            Solver::Progressive => rad_solver::progressive(&rec, &s, &opts.config),
            Solver::Jacobi => rad_solver::jacobi(&rec, &s, &opts.config),
        }
        .unwrap();
        let scale = reference
            .radiosity
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(*v));
        for (a, b) in reference.radiosity.iter().zip(&one.radiosity) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-9 * scale, "{a:?} vs {b:?}");
            }
        }
        // And `solve` on the CSR rows goes through the same pair storage (Jacobi on
        // stored rows goes through rows held by process, `RowSet`, whose reciprocal
        // scaling sums in another order: the same within the tolerance, checked above).
        if solver != Solver::Jacobi {
            let again = solve(&ff, &s, &opts).unwrap();
            assert_eq!(again.solution.radiosity, solved.solution.radiosity);
        }
    }
}

/// Displayed radiosities (ambient term added) of a solution file's solve.
fn display(scene: &Scene, solved: &rad_pipeline::solve::Solved) -> Vec<[f64; 3]> {
    solved.solution.display(&surfaces(scene))
}

#[test]
fn matrix_free_agrees_with_the_stored_solve_and_not_the_threads() {
    let scene = loft();
    // Shooting gathers and shoots through halves of each row, so it solves the average
    // (F + A⁻¹FᵀA) / 2; the stored path solves the reciprocal scaling of the same
    // average: the two differ by the scaling, not by the solvers' tolerances (rad-solver's
    // tests: matrix-free shooting agrees with Gauss-Seidel on the average held to 1e-6).
    // The issue asks 1 % (see the README for 180 x 720).
    let hemi = Hemisphere::new(HemisphereConfig::exact(30, 120)).unwrap();
    let method = RowMethod::Exact {
        caster: CasterKind::Scan,
    };
    let stored = SceneSolveConfig {
        storage: Some(Storage::Stored),
        ..SceneSolveConfig::default()
    };
    let (_, reference, _) = solve_scene(&scene, &hemi, method, &stored, &|_| {}).unwrap();
    let free = |threads, limit| {
        let opts = SceneSolveConfig {
            storage: Some(Storage::MatrixFree),
            memory_limit: limit,
            ..SceneSolveConfig::default()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| solve_scene(&scene, &hemi, method, &opts, &|_| {}).unwrap())
    };
    let (file, a, _) = free(2, DEFAULT_MEMORY_LIMIT);
    let (_, b, _) = free(1, 8 << 20);
    assert_eq!(file.matrix.storage, "matrix-free");
    // The cache changes what is made, not the answer; nor do the threads.
    assert!(b.matrix.rows_made > a.matrix.rows_made);
    assert_eq!(a.solution.radiosity, b.solution.radiosity);
    assert!(a.solution.report.converged);
    assert!(a.balance.relative_imbalance < 1e-9, "{:?}", a.balance);
    let ambient = a.solution.ambient;
    assert!(
        ambient.iter().all(|x| x.is_finite() && *x >= 0.0),
        "{ambient:?}"
    );
    // The images agree with the stored solve's.
    let view = View::of_scene(&scene.scene, 160, 120).unwrap();
    let config = RenderConfig {
        samples: 2,
        shading: Shading::Smooth,
    };
    let img = |s| render_image(&scene.scene, &display(&scene.scene, s), &view, &config).unwrap();
    let (_, diff) = rad_render::relative_difference(&img(&reference), &img(&a)).unwrap();
    assert!(diff.mean < 0.01, "{diff:?}");
}

#[test]
fn out_of_core_is_matrix_free_shooting_to_the_bit_and_leaves_nothing() {
    let scene = loft();
    let hemi = Hemisphere::new(HemisphereConfig::exact(8, 32)).unwrap();
    let exact = RowMethod::Exact {
        caster: CasterKind::Scan,
    };
    let temp = tempfile::tempdir().unwrap();
    let run = |storage, method, threads, limit| {
        let opts = SceneSolveConfig {
            storage: Some(storage),
            memory_limit: limit,
            temp_dir: Some(temp.path().to_path_buf()),
            ..SceneSolveConfig::default()
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| solve_scene(&scene, &hemi, method, &opts, &|_| {}).unwrap())
    };
    let (_, free, _) = run(Storage::MatrixFree, exact, 2, DEFAULT_MEMORY_LIMIT);
    let (file, a, _) = run(Storage::OutOfCore, exact, 2, DEFAULT_MEMORY_LIMIT);
    let (_, b, _) = run(Storage::OutOfCore, exact, 1, 4 << 20);
    assert_eq!(file.matrix.storage, "out-of-core");
    assert!(file.matrix.disk_bytes > 0);
    // The same rows (f32), the same shots: matrix-free solving's answer to the bit,
    // whatever the threads and the rows kept in memory.
    assert_eq!(a.solution.radiosity, free.solution.radiosity);
    assert_eq!(b.solution.radiosity, free.solution.radiosity);
    assert!(b.matrix.cached_rows < a.matrix.cached_rows);
    assert!(a.solution.report.converged);
    assert!(a.balance.relative_imbalance < 1e-9, "{:?}", a.balance);
    // Estimated rows go out of core too (matrix-free cannot make them): the very shots
    // of the same rows held in memory.
    let estimated = RowMethod::Estimated {
        mode: Mode::Improved,
        centres: CasterKind::Scan,
    };
    let (_, e, stats) = run(Storage::OutOfCore, estimated, 2, DEFAULT_MEMORY_LIMIT);
    assert!(stats.estimated > stats.exact, "{stats:?}");
    assert!(e.balance.relative_imbalance < 1e-9, "{:?}", e.balance);
    let held = all_rows(&scene.scene, &hemi, estimated).rows;
    let config = rad_solver::MatrixFreeConfig {
        solve: SceneSolveConfig::default().matrix_free,
        batch: rad_pipeline::MATRIX_FREE_BATCH,
        overshoot: rad_pipeline::MATRIX_FREE_OVERSHOOT,
        cache_bytes: 0,
    };
    let mut shot_rows = |ids: &[u32],
                         _: &mut Vec<rad_solver::ShotRow>|
     -> Result<Vec<rad_solver::ShotRow>, rad_solver::Error> {
        Ok(ids
            .iter()
            .map(|&p| rad_solver::ShotRow {
                columns: held[p as usize].entries.iter().map(|e| e.0).collect(),
                values: held[p as usize]
                    .entries
                    .iter()
                    .map(|e| e.1 as f32)
                    .collect(),
            })
            .collect())
    };
    let surf = surfaces(&scene.scene);
    let (want, _) =
        rad_solver::shoot_matrix_free(&surf, &config, None, &mut shot_rows, &mut |_| {}).unwrap();
    assert_eq!(e.solution.radiosity, want.radiosity);
    // Nothing is left in the temporary folder.
    assert_eq!(std::fs::read_dir(temp.path()).unwrap().count(), 0);
    // A temporary folder that does not exist is named.
    let opts = SceneSolveConfig {
        storage: Some(Storage::OutOfCore),
        temp_dir: Some(temp.path().join("no/such")),
        ..SceneSolveConfig::default()
    };
    let e = solve_scene(&scene, &hemi, exact, &opts, &|_| {})
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("cannot create a temporary file in") && e.contains("no/such"),
        "{e}"
    );
}

#[test]
fn memory_limit_chooses_the_storage_and_refuses_what_fits_nothing() {
    let scene = loft();
    let hemi = Hemisphere::new(HemisphereConfig::exact(6, 24)).unwrap();
    let exact = RowMethod::Exact {
        caster: CasterKind::Scan,
    };
    let temp = tempfile::tempdir().unwrap();
    let run = |method, limit| {
        let opts = SceneSolveConfig {
            memory_limit: limit,
            temp_dir: Some(temp.path().to_path_buf()),
            ..SceneSolveConfig::default()
        };
        solve_scene(&scene, &hemi, method, &opts, &|_| {})
    };
    let (big, _, _) = run(exact, DEFAULT_MEMORY_LIMIT).unwrap();
    assert_eq!(big.matrix.storage, "stored");
    // Too small to store: out of core (the temporary folder has room), whatever the
    // method.
    let (small, _, _) = run(exact, 6 << 20).unwrap();
    assert_eq!(small.matrix.storage, "out-of-core");
    let estimated = RowMethod::Estimated {
        mode: Mode::Improved,
        centres: CasterKind::Scan,
    };
    let (small, _, _) = run(estimated, 10 << 20).unwrap();
    assert_eq!(small.matrix.storage, "out-of-core");
    for (method, limit, want) in [
        (exact, 1 << 20, "matrix-free solving of 14400 patches"),
        (estimated, 1 << 20, "out-of-core solving of 14400 patches"),
    ] {
        let e = run(method, limit).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("memory limit"), "{e}");
    }
    // Shared among processes (no temporary folder of one's own), matrix-free.
    let shared = rad_pipeline::share::in_threads(2, |peers| {
        let opts = SceneSolveConfig {
            memory_limit: 6 << 20,
            ..SceneSolveConfig::default()
        };
        rad_pipeline::solve::solve_scene_shared(&scene, &hemi, exact, &opts, &|_| {}, peers)
            .map(|s| s.map(|(file, _, _)| file.matrix.storage))
            .map_err(|e| e.to_string())
    });
    assert_eq!(shared[0].clone().unwrap().unwrap(), "matrix-free");
    // Jacobi, shared by rows: each process's share must fit the limit; more processes
    // need less each.
    let jacobi = |limit, processes| {
        let opts = SceneSolveConfig {
            solver: Solver::Jacobi,
            memory_limit: limit,
            ..SceneSolveConfig::default()
        };
        let got = rad_pipeline::share::in_threads(processes, |peers| {
            rad_pipeline::solve::solve_scene_shared(&scene, &hemi, exact, &opts, &|_| {}, peers)
                .map(|s| s.map(|(file, _, _)| file.matrix.storage))
                .map_err(|e| e.to_string())
        });
        got.into_iter().next().unwrap()
    };
    assert_eq!(jacobi(DEFAULT_MEMORY_LIMIT, 1).unwrap().unwrap(), "stored");
    let need = |processes| -> u64 {
        let e = jacobi(1 << 20, processes).unwrap_err();
        assert!(
            e.contains(&format!("shared by rows among {processes} process")),
            "{e}"
        );
        let mib = e
            .split("need about ")
            .nth(1)
            .and_then(|t| t.split(' ').next());
        mib.and_then(|m| m.parse().ok())
            .unwrap_or_else(|| panic!("{e}"))
    };
    let (one, four) = (need(1), need(4));
    assert!(four < one, "{four} MiB a process of 4, {one} MiB alone");
    // A limit between the two: too small alone, enough for a quarter each.
    let between = ((one + four) / 2) << 20;
    assert!(jacobi(between as usize, 1).is_err() && jacobi(between as usize, 4).is_ok());
}

/// `RowMethod::auto_for`, `coherad solve`'s default: estimated rows on the loft cut into
/// 28,800 one-patch triangles (walls of triangles, most estimated by windows), exact on
/// the loft (14,400 patches: too few), on its 14,400 one-patch polygons, and on the
/// curved blob room (few of its triangles share a plane).
#[test]
fn auto_estimates_large_flat_meshes_only() {
    for (name, desc, estimated) in [
        ("loft", scenes::loft(), false),
        ("loft_patches", scenes::loft_patches(), false),
        ("loft_triangles", scenes::loft_triangles(), true),
        ("blob_room", scenes::blob_room(), false),
    ] {
        let scene = Scene::new(desc).unwrap();
        let (method, share) = RowMethod::auto_for(&scene).unwrap();
        assert_eq!(
            !method.is_exact(),
            estimated,
            "{name}: {method}, {share:.2} estimated by windows"
        );
        let fastest = CasterKind::fastest_for(&scene);
        assert!(matches!(
            method,
            RowMethod::Exact { caster } | RowMethod::Estimated { centres: caster, .. }
                if caster == fastest
        ));
    }
}
