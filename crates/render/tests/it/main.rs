//! Integration tests of rad-render: shading of known radiosity fields in the cube,
//! refused requests, relative differences.

use rad_accel::BruteForce;
use rad_geometry::scenes::cube;
use rad_geometry::Scene;
use rad_render::{relative_difference, render, Error, Image, RenderConfig, Shading, View};

fn cube_scene() -> Scene {
    Scene::new(cube(10)).unwrap()
}

const FLAT: RenderConfig = RenderConfig {
    samples: 2,
    shading: Shading::Flat,
};
const SMOOTH: RenderConfig = RenderConfig {
    samples: 2,
    shading: Shading::Smooth,
};

#[test]
fn constant_radiosity_renders_constant_in_both_shadings() {
    let scene = cube_scene();
    let grid = BruteForce::new(&scene);
    let view = View::of_scene(&scene, 64, 48).unwrap();
    let b = vec![[1.0, 2.0, 3.0]; scene.patches().len()];
    for cfg in [FLAT, SMOOTH] {
        let img = render(&scene, &grid, &view, &b, &cfg).unwrap();
        assert_eq!(img.pixels.len(), 64 * 48);
        for (k, p) in img.pixels.iter().enumerate() {
            for c in 0..3 {
                assert!((p[c] - (c + 1) as f32).abs() < 1e-5, "pixel {k}: {p:?}");
            }
        }
    }
}

#[test]
fn smooth_shading_reproduces_a_linear_field_inside_faces_and_flat_is_piecewise_constant() {
    let scene = cube_scene();
    let grid = BruteForce::new(&scene);
    let view = View::of_scene(&scene, 80, 60).unwrap();
    // B linear in position: exact at patch centres.
    let field = |p: glam::Vec3| 1.0 + p.x as f64 + 2.0 * p.y as f64 + 0.5 * p.z as f64;
    let b: Vec<[f64; 3]> = scene
        .patches()
        .iter()
        .map(|p| [field(p.center); 3])
        .collect();
    let smooth = render(
        &scene,
        &grid,
        &view,
        &b,
        &RenderConfig {
            samples: 1,
            shading: Shading::Smooth,
        },
    )
    .unwrap();
    let flat = render(
        &scene,
        &grid,
        &view,
        &b,
        &RenderConfig {
            samples: 1,
            shading: Shading::Flat,
        },
    )
    .unwrap();
    let mut checked = 0;
    let mut flat_off = 0;
    let mut scratch = rad_core::RayCast::new_scratch(&grid);
    for y in 0..60 {
        for x in 0..80 {
            let ray = view.ray(x as f32 + 0.5, y as f32 + 0.5);
            let hit = rad_core::RayCast::closest_hit(&grid, &ray, &mut scratch).unwrap();
            let p = ray.origin + hit.t * ray.dir;
            // Inside the face's interior cells (border corners average fewer patches).
            let inside = (0..3).filter(|&k| p[k] > 0.1 && p[k] < 0.9).count() == 2;
            if !inside {
                continue;
            }
            let want = field(p);
            let got = smooth.get(x, y)[0] as f64;
            assert!(
                (got - want).abs() < 2e-3 * want,
                "({x}, {y}) at {p}: {got} vs {want}"
            );
            checked += 1;
            if (flat.get(x, y)[0] as f64 - want).abs() > 1e-3 {
                flat_off += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked}");
    assert!(
        flat_off > checked / 2,
        "flat shading should be piecewise constant: {flat_off}/{checked}"
    );
}

#[test]
fn image_does_not_depend_on_threads() {
    let scene = cube_scene();
    let grid = BruteForce::new(&scene);
    let view = View::of_scene(&scene, 40, 30).unwrap();
    let b: Vec<[f64; 3]> = (0..scene.patches().len())
        .map(|i| [i as f64, 1.0, 0.5])
        .collect();
    let run = |t| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| render(&scene, &grid, &view, &b, &SMOOTH).unwrap())
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn bad_requests_are_refused() {
    let scene = cube_scene();
    let grid = BruteForce::new(&scene);
    assert!(matches!(
        View::of_scene(&scene, 0, 10),
        Err(Error::Size { width: 0, .. })
    ));
    assert!(matches!(
        View::of_scene(&scene, 100_000, 10),
        Err(Error::Size { .. })
    ));
    let view = View::of_scene(&scene, 8, 8).unwrap();
    let n = scene.patches().len();
    let b = vec![[0.5; 3]; n];
    let e = render(&scene, &grid, &view, &b[..10], &FLAT);
    assert!(matches!(e, Err(Error::Radiosity { len: 10, .. })), "{e:?}");
    let mut nan = b.clone();
    nan[7] = [f64::NAN, 0.0, 0.0];
    let e = render(&scene, &grid, &view, &nan, &FLAT);
    assert!(
        matches!(e, Err(Error::BadRadiosity { patch: 7, .. })),
        "{e:?}"
    );
    let e = render(
        &scene,
        &grid,
        &view,
        &b,
        &RenderConfig {
            samples: 0,
            shading: Shading::Flat,
        },
    );
    assert!(matches!(e, Err(Error::Samples { samples: 0 })), "{e:?}");
    let mut desc = cube(2);
    desc.camera = None;
    let bare = Scene::new(desc).unwrap();
    assert!(matches!(View::of_scene(&bare, 8, 8), Err(Error::NoCamera)));
}

#[test]
fn relative_difference_statistics() {
    let img = |v: &[f32]| Image {
        width: v.len() as u32,
        height: 1,
        pixels: v.iter().map(|&x| [x; 3]).collect(),
    };
    let a = img(&[1.0, 1.0, 2.0, 0.0, 4.0]);
    let b = img(&[1.0, 1.2, 1.9, 5.0, 4.0]);
    let (diff, s) = relative_difference(&a, &b).unwrap();
    assert_eq!(s.pixels, 4);
    assert!(
        (s.mean - (0.0 + 0.2 + 0.05 + 0.0) / 4.0).abs() < 1e-6,
        "{s:?}"
    );
    assert!(
        (s.max - 0.2).abs() < 1e-6 && (s.over_10_percent - 0.25).abs() < 1e-12,
        "{s:?}"
    );
    assert_eq!(diff.pixels[1], [1.0; 3]);
    assert!((diff.pixels[2][0] - 0.5).abs() < 1e-5);
    assert_eq!(diff.pixels[3], [0.0; 3]);
    assert!(matches!(
        relative_difference(&a, &img(&[1.0])),
        Err(Error::SizeMismatch { .. })
    ));
}

/// A polygon of one patch (a mesh's triangle) has that patch's radiosity at every
/// corner, +0 for −0 as the sum of its neighbours gives; a polygon of several, the
/// mean of the (one to four) patches about each corner.
#[test]
fn corner_values_are_the_means_of_the_patches_about_each_corner() {
    let scene = Scene::new(rad_geometry::scenes::loft_triangles()).unwrap();
    let b: Vec<[f64; 3]> = (0..scene.patches().len())
        .map(|k| [k as f64, -0.0, (k % 3) as f64])
        .collect();
    let corners = rad_render::corner_values(&scene, &b);
    let mut ones = 0;
    for (k, poly) in scene.polygons().iter().enumerate() {
        if poly.grid() == (1, 1) {
            ones += 1;
            let p = poly.cell_patch(0, 0) as usize;
            for c in &corners[k] {
                assert_eq!(
                    c.map(f64::to_bits),
                    [b[p][0], 0.0, b[p][2]].map(f64::to_bits)
                );
            }
        }
    }
    assert!(ones > 1000, "{ones}");
    // The cube's faces are cut 2 × 2 (or finer): a face's middle corner is the mean of
    // its four patches.
    let scene = cube_scene();
    let b: Vec<[f64; 3]> = (0..scene.patches().len())
        .map(|k| [k as f64, 1.0, 0.0])
        .collect();
    let corners = rad_render::corner_values(&scene, &b);
    let poly = &scene.polygons()[0];
    let (nu, nv) = poly.grid();
    assert!(nu >= 2 && nv >= 2);
    let (i, j) = (1u32, 1u32);
    let mean = [(0, 0), (1, 0), (0, 1), (1, 1)]
        .iter()
        .map(|&(di, dj)| b[poly.cell_patch(i - di, j - dj) as usize][0])
        .sum::<f64>()
        / 4.0;
    assert_eq!(corners[0][(j * (nu + 1) + i) as usize][0], mean);
}
