//! Integration tests of rad-pipeline: rows streamed into the pair storage, and solves
//! on it, against the rows held whole and the CSR solve.

use rad_geometry::{scenes, Scene};
use rad_pipeline::solve::{solve, solve_scene, surfaces, SolveOptions};
use rad_pipeline::{
    rows, rows_streamed, CasterKind, Hemisphere, HemisphereConfig, Mode, RowMethod, SceneFile,
    Solver, STREAM_CHUNK,
};
use rad_solver::FormFactors;

fn loft() -> SceneFile {
    SceneFile {
        path: "loft.json".into(),
        scene: Scene::new(scenes::loft()).unwrap(),
        hash: 1,
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
    for solver in [Solver::GaussSeidel, Solver::Progressive] {
        let opts = SolveOptions {
            solver,
            ..SolveOptions::default()
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
        // And `solve` on the CSR rows goes through the same pair storage.
        let again = solve(&ff, &s, &opts).unwrap();
        assert_eq!(again.solution.radiosity, solved.solution.radiosity);
    }
}
