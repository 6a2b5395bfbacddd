//! Patch textures of polygons that are neither triangles nor parallelograms: their
//! (u, v) frame is their smallest bounding rectangle, so patches have the size and
//! shape asked for, whatever vertex the polygon starts at.

use glam::Vec3;
use rad_core::Rgb;
use rad_geometry::{Material, PatchGrid, PolygonDesc, Scene, SceneDesc};

fn scene(vertices: Vec<Vec3>, grid: PatchGrid) -> Scene {
    Scene::new(SceneDesc {
        materials: vec![Material {
            name: "m".into(),
            reflectance: Rgb([0.5; 3]),
            emission: Rgb::BLACK,
        }],
        polygons: vec![PolygonDesc {
            name: "p".into(),
            vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
            material: 0,
            grid,
            group: None,
            obstruction: false,
            two_sided: false,
        }],
        camera: None,
    })
    .expect("a valid polygon")
}

/// A regular `n`-gon of radius `r` in the plane z = 0, counter-clockwise from angle `a0`.
fn regular(n: usize, r: f32, a0: f32) -> Vec<Vec3> {
    (0..n)
        .map(|k| {
            let a = a0 + std::f32::consts::TAU * k as f32 / n as f32;
            Vec3::new(r * a.cos(), r * a.sin(), 0.0)
        })
        .collect()
}

#[test]
fn a_first_vertex_on_a_straight_edge_is_no_longer_a_problem() {
    // A 2 x 1 rectangle with a vertex in the middle of its bottom edge, listed first.
    let v = vec![
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::ZERO,
    ];
    let s = scene(v, PatchGrid::Cells { nu: 2, nv: 2 });
    assert_eq!(s.patches().len(), 4);
    for p in s.patches() {
        assert!((p.area - 0.5).abs() < 1e-9, "area {}", p.area);
    }
    let total: f64 = s.patches().iter().map(|p| p.area).sum();
    assert!((total - 2.0).abs() < 1e-9);
}

#[test]
fn a_many_sided_polygon_gets_square_patches_of_the_size_asked() {
    // The 96-gon of the coaxial-discs case: r = 1, a patch size of 0.2 is a 10 x 10
    // grid over its 2 x 2 bounding square (the edge frame made it one patch).
    for a0 in [0.0f32, 0.3, 1.0] {
        let s = scene(regular(96, 1.0, a0), PatchGrid::Size(0.2));
        let poly = &s.polygons()[0];
        assert_eq!(poly.grid(), (10, 10), "start angle {a0}");
        let area: f64 = s.patches().iter().map(|p| p.area).sum();
        assert!((area - poly.area()).abs() < 1e-6 * area);
        // Every cell wholly inside is a whole cell of the frame (both sides 2 cos(pi/96),
        // across the polygon's flats: 96 is a multiple of 4); no patch is larger.
        let (lu, lv) = (poly.e_u().length() as f64, poly.e_v().length() as f64);
        let flats = 2.0 * (std::f64::consts::PI / 96.0).cos();
        assert!(
            (lu - flats).abs() < 1e-5 && (lv - flats).abs() < 1e-5,
            "{lu} x {lv}"
        );
        let full = lu * lv / 100.0;
        let inner: Vec<_> = s.patches().iter().filter(|p| !p.on_boundary).collect();
        assert!(inner.len() >= 40, "{} inner patches", inner.len());
        for p in &inner {
            assert!(
                (p.area - full).abs() < 1e-6 * full,
                "inner patch of area {}",
                p.area
            );
        }
        for p in s.patches() {
            assert!(p.area <= full * (1.0 + 1e-6), "patch of area {}", p.area);
        }
    }
}

#[test]
fn patches_and_patch_size_give_the_same_grid_on_a_disc() {
    let by_cells = scene(regular(96, 1.0, 0.0), PatchGrid::Cells { nu: 10, nv: 10 });
    let by_size = scene(regular(96, 1.0, 0.0), PatchGrid::Size(0.2));
    assert_eq!(by_cells.patches(), by_size.patches());
}

#[test]
fn the_rectangle_frame_is_the_smallest_bounding_rectangle() {
    // A rhombus-like hexagon rotated by 30 degrees in its plane: its frame must follow
    // its long axis, whatever vertex it starts at, and its patches keep its area.
    let base: Vec<Vec3> = [
        (-2.0f32, 0.0f32),
        (-1.0, -0.5),
        (1.0, -0.5),
        (2.0, 0.0),
        (1.0, 0.5),
        (-1.0, 0.5),
    ]
    .iter()
    .map(|&(x, y)| {
        let (c, s) = (0.5f32.sqrt() * 1.2247449, 0.5f32);
        Vec3::new(c * x - s * y, s * x + c * y, 3.0)
    })
    .collect();
    for start in 0..base.len() {
        let v: Vec<Vec3> = (0..base.len())
            .map(|k| base[(k + start) % base.len()])
            .collect();
        let s = scene(v, PatchGrid::Size(0.5));
        let poly = &s.polygons()[0];
        let (lu, lv) = (poly.e_u().length(), poly.e_v().length());
        let (long, short) = (lu.max(lv), lu.min(lv));
        assert!(
            (long - 4.0).abs() < 1e-5 && (short - 1.0).abs() < 1e-5,
            "{lu} x {lv}"
        );
        let (nu, nv) = poly.grid();
        assert_eq!(nu.max(nv), 8);
        assert_eq!(nu.min(nv), 2);
        let area: f64 = s.patches().iter().map(|p| p.area).sum();
        assert!((area - 3.0).abs() < 1e-5, "area {area}");
        // The frame's normal is the polygon's.
        assert!(poly.e_u().cross(poly.e_v()).normalize().dot(poly.normal()) > 0.999_999);
    }
}

#[test]
fn parallelograms_and_triangles_keep_their_edge_frame() {
    let par = vec![
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(3.0, 1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
    ];
    let s = scene(par.clone(), PatchGrid::Cells { nu: 3, nv: 2 });
    let poly = &s.polygons()[0];
    assert!(poly.is_parallelogram());
    assert_eq!(poly.origin(), par[0]);
    assert_eq!(poly.e_u(), par[1] - par[0]);
    assert_eq!(poly.e_v(), par[3] - par[0]);
    let tri = vec![
        Vec3::new(0.5, 0.0, 1.0),
        Vec3::new(2.0, 0.5, 1.0),
        Vec3::new(0.0, 1.5, 1.0),
    ];
    let s = scene(tri.clone(), PatchGrid::Cells { nu: 2, nv: 2 });
    let poly = &s.polygons()[0];
    assert_eq!(poly.origin(), tri[0]);
    assert_eq!(poly.e_u(), tri[1] - tri[0]);
    assert_eq!(poly.e_v(), tri[2] - tri[0]);
}
