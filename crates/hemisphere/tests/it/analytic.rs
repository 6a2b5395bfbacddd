//! The empty cube against Lambert's closed form and the face-to-face closed forms.

use glam::DVec3;
use rad_accel::{GridResolution, VoxelGrid, VoxelGridConfig};
use rad_geometry::scenes::cube;
use rad_geometry::Scene;
use rad_hemisphere::{
    compute_rows, point_to_polygon_form_factor, Hemisphere, HemisphereConfig, Row,
};

fn grid(scene: &Scene) -> VoxelGrid<'_> {
    VoxelGrid::build(
        scene,
        &VoxelGridConfig {
            resolution: GridResolution::Auto {
                density: 4.0,
                max_per_axis: 64,
            },
        },
    )
    .unwrap()
}

fn lambert(scene: &Scene, from: usize, to: usize) -> f64 {
    let p = &scene.patches()[from];
    let q = &scene.patches()[to];
    let corners: Vec<DVec3> = q.corners.iter().map(|c| c.as_dvec3()).collect();
    point_to_polygon_form_factor(p.center.as_dvec3(), p.normal.as_dvec3(), &corners)
}

fn cube_rows(n_theta: u32, n_phi: u32) -> (Scene, Vec<Row>) {
    let scene = Scene::new(cube(10)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(n_theta, n_phi)).unwrap();
    let all: Vec<u32> = (0..600).collect();
    let rows = compute_rows(&scene, &grid(&scene), &hemi, &all, &|_| {}).unwrap();
    (scene, rows)
}

#[test]
fn lambert_matches_the_parallel_squares_closed_form() {
    // Point at the centre of a unit square's parallel twin at distance 1:
    // F = (2/π)·(x/√(1+x²))·atan(y/√(1+x²))·... for a centred point, four quarter
    // rectangles of a×b at distance c: F = (1/2π) Σ [a/√(a²+c²) atan(b/√(a²+c²)) + …].
    let corners = [
        DVec3::new(-0.5, -0.5, 1.0),
        DVec3::new(0.5, -0.5, 1.0),
        DVec3::new(0.5, 0.5, 1.0),
        DVec3::new(-0.5, 0.5, 1.0),
    ];
    let f = point_to_polygon_form_factor(DVec3::ZERO, DVec3::Z, &corners);
    // One quarter: rectangle 0.5 × 0.5 at distance 1 from a corner-aligned point.
    let (a, b, c) = (0.5f64, 0.5f64, 1.0f64);
    let (x, y) = (a / c, b / c);
    let quarter = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
        + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
        / (2.0 * std::f64::consts::PI);
    assert!(
        (f - 4.0 * quarter).abs() < 1e-12,
        "{f} vs {}",
        4.0 * quarter
    );
}

#[test]
fn cube_rows_sum_to_one_and_match_lambert_and_the_face_closed_forms() {
    let (scene, rows) = cube_rows(180, 720);
    for r in &rows {
        assert_eq!(r.escaped, 0.0, "patch {} leaks", r.patch);
        assert_eq!(r.back, 0.0, "patch {} sees a back face", r.patch);
        assert!(
            (r.sum() - 1.0).abs() < 1e-9,
            "patch {} sums to {}",
            r.patch,
            r.sum()
        );
    }
    // Floor patch (3, 4): mean relative error over the 500 patches it sees.
    let row = &rows[43];
    let mut errs = Vec::new();
    for q in 0..600 {
        let exact = lambert(&scene, 43, q);
        if scene.patches()[q].polygon == 0 {
            assert_eq!(row.get(q as u32), 0.0);
            continue;
        }
        errs.push((row.get(q as u32) - exact).abs() / exact);
    }
    assert_eq!(errs.len(), 500);
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(mean < 0.025, "mean relative error {mean}");
    // Area-weighted face-to-face factors from the floor.
    let mut face = [0.0f64; 6];
    for r in &rows[0..100] {
        for &(j, f) in &r.entries {
            face[scene.patches()[j as usize].polygon as usize] += f / 100.0;
        }
    }
    assert!((face[1] - 0.199825).abs() < 1e-3, "opposite {}", face[1]);
    for &adj in &face[2..] {
        assert!((adj - 0.200044).abs() < 1e-3, "adjacent {adj}");
    }
}
