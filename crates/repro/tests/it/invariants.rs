//! Closure, back faces and reciprocity on the bench scenes.

use rad_accel::VoxelGrid;
use rad_geometry::scenes::{cornell_box, cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig};
use rad_pipeline::default_grid;
use rad_repro::reciprocity::{discretisation_bound, pairs, point_asymmetry, summarise};

#[test]
fn loft_is_closed_and_well_built_from_200_sampled_patches() {
    let scene = Scene::new(loft()).unwrap();
    let grid = VoxelGrid::build(&scene, &default_grid()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let sample: Vec<u32> = (0..14_400).step_by(72).collect();
    assert_eq!(sample.len(), 200);
    for r in compute_rows(&scene, &grid, &hemi, &sample, &|_| {}).unwrap() {
        assert_eq!(
            r.escaped, 0.0,
            "a ray escapes the loft from patch {}",
            r.patch
        );
        assert_eq!(r.back, 0.0, "patch {} sees a polygon from behind", r.patch);
        assert!(
            (r.sum() - 1.0).abs() < 1e-9,
            "patch {} sums to {}",
            r.patch,
            r.sum()
        );
    }
}

#[test]
fn cornell_box_patches_see_no_back_faces() {
    // Open at the front (rays escape toward the camera), but never into a block.
    let scene = Scene::new(cornell_box(40.0)).unwrap();
    let grid = VoxelGrid::build(&scene, &default_grid()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    for r in compute_rows(&scene, &grid, &hemi, &all, &|_| {}).unwrap() {
        assert_eq!(r.back, 0.0, "patch {} sees a polygon from behind", r.patch);
        assert!((r.sum() + r.escaped - 1.0).abs() < 1e-9);
    }
}

#[test]
fn cube_reciprocity_holds_within_the_discretisation_bound() {
    let scene = Scene::new(cube(10)).unwrap();
    let grid = VoxelGrid::build(&scene, &default_grid()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let all: Vec<u32> = (0..600).collect();
    let rows = compute_rows(&scene, &grid, &hemi, &all, &|_| {}).unwrap();
    let p = pairs(&scene, &rows, hemi.n_cells());
    // Every pair seen through at least 100 cells both ways is within its bound.
    let mut resolved = 0;
    for pair in &p {
        if pair.cells.0.min(pair.cells.1) >= 100.0 {
            resolved += 1;
            let bound = discretisation_bound(pair.cells, point_asymmetry(&scene, pair.i, pair.j));
            assert!(
                pair.rel <= bound,
                "pair {}-{}: {} > {}",
                pair.i,
                pair.j,
                pair.rel,
                bound
            );
        }
    }
    assert!(resolved > 1000, "{resolved} resolved pairs");
}

#[test]
fn loft_reciprocity_holds_within_the_discretisation_bound() {
    let scene = Scene::new(loft()).unwrap();
    let grid = VoxelGrid::build(&scene, &default_grid()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let subset: Vec<u32> = (0..14_400).step_by(12).collect();
    let rows = compute_rows(&scene, &grid, &hemi, &subset, &|_| {}).unwrap();
    let s = summarise(
        &pairs(&scene, &rows, hemi.n_cells()),
        rows.len(),
        100.0,
        |i, j| point_asymmetry(&scene, i, j),
    );
    assert!(s.rel_error_resolved.n > 200, "{s:?}");
    // Occluders make the point-value term an estimate, so a few pairs may exceed it.
    assert!(s.within_bound >= 0.95, "{s:?}");
}

/// Exact rows of every patch of a scene at a small resolution.
fn all_rows_matrix(scene: &Scene, res: (u32, u32)) -> rad_solver::FormFactors {
    let grid = rad_accel::VoxelGrid::build(scene, &rad_pipeline::default_grid()).unwrap();
    let hemi =
        rad_hemisphere::Hemisphere::new(rad_hemisphere::HemisphereConfig::exact(res.0, res.1))
            .unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    let rows = rad_hemisphere::compute_rows(scene, &grid, &hemi, &all, &|_| {}).unwrap();
    rad_solver::FormFactors::from_rows(all.len(), rows.iter().map(|r| (r.patch, &r.entries[..])))
        .unwrap()
}

#[test]
fn furnace_and_energy_balance_on_real_rows() {
    use rad_pipeline::solve::{solve, surfaces, SceneSolveConfig};
    use rad_solver::{SolveConfig, Solver, Surfaces};
    let opts = |solver| SceneSolveConfig {
        solver,
        config: SolveConfig {
            tolerance: 1e-10,
            ..SolveConfig::default()
        },
        reciprocal: true,
        ..SceneSolveConfig::default()
    };
    // The cube, closed: the furnace gives B = E / (1 - rho) = 2 everywhere.
    let cube = Scene::new(rad_geometry::scenes::cube(10)).unwrap();
    let ff = all_rows_matrix(&cube, (30, 120));
    let n = cube.patches().len();
    let furnace = Surfaces {
        area: surfaces(&cube).area,
        emission: vec![[1.0; 3]; n],
        reflectance: vec![[0.5; 3]; n],
    };
    for solver in [Solver::GaussSeidel, Solver::Progressive] {
        let s = solve(&ff, &furnace, &opts(solver)).unwrap();
        for b in s.solution.radiosity.iter().flatten() {
            assert!((b - 2.0).abs() / 2.0 < 1e-4, "{solver:?}: {b}");
        }
        assert!(s.balance.relative_imbalance < 1e-6, "{:?}", s.balance);
    }
    // The Cornell box, open at the front: emitted = absorbed + escaped, both solvers
    // agree; without the reciprocal scaling the balance is off by far more.
    let cornell = Scene::new(rad_geometry::scenes::cornell_box(80.0)).unwrap();
    let ff = all_rows_matrix(&cornell, (30, 120));
    let surf = surfaces(&cornell);
    let g = solve(&ff, &surf, &opts(Solver::GaussSeidel)).unwrap();
    let p = solve(&ff, &surf, &opts(Solver::Progressive)).unwrap();
    assert!(g.balance.relative_imbalance < 1e-6, "{:?}", g.balance);
    assert!(p.balance.relative_imbalance < 1e-6, "{:?}", p.balance);
    assert!(g.balance.escaped[0] > 0.0);
    assert!(g.raw_balance.relative_imbalance > 100.0 * g.balance.relative_imbalance);
    let scale = g
        .solution
        .radiosity
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    for (a, b) in g.solution.radiosity.iter().zip(&p.solution.radiosity) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-8 * scale, "{a:?} vs {b:?}");
        }
    }
}
