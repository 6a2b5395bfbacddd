//! The bench scenes' counts and shapes.

use rad_geometry::scenes::{
    blob_room, cornell_box, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
    sculptures_100k,
};
use rad_geometry::Scene;

#[test]
fn cube_has_600_patches_of_equal_area() {
    let s = Scene::new(cube(10)).unwrap();
    assert_eq!(s.polygons().len(), 6);
    assert_eq!(s.patches().len(), 600);
    for p in s.patches() {
        assert!((p.area - 0.01).abs() < 1e-9, "{p:?}");
        // Normals face into the cube: the centre is in front of every patch.
        let to_centre = glam::Vec3::splat(0.5) - p.center;
        assert!(to_centre.dot(p.normal) > 0.4);
    }
    // Floor patch (3, 4) is patch 43 with its centre at u = 0.35 (z), v = 0.45 (x).
    let p = &s.patches()[43];
    assert_eq!(p.cell, [3, 4]);
    assert!((p.center - glam::Vec3::new(0.45, 0.0, 0.35)).length() < 1e-6);
}

#[test]
fn loft_has_the_reports_counts() {
    let s = Scene::new(loft()).unwrap();
    assert_eq!(s.polygons().len(), 185);
    assert_eq!(s.patches().len(), 14_400);
}

#[test]
fn loft_boxes_are_disjoint_and_inside_the_room() {
    use rad_geometry::scenes::{loft_boxes, LOFT_SIZE};
    let boxes = loft_boxes();
    assert_eq!(boxes.len(), 29);
    for (name, lo, hi, _, _) in &boxes {
        for k in 0..3 {
            assert!(
                lo[k] >= 0.02 - 1e-6 && hi[k] <= LOFT_SIZE[k] - 0.02 + 1e-6,
                "{name} leaves the room"
            );
            assert!(lo[k] < hi[k]);
        }
    }
    for (a, (na, la, ha, _, _)) in boxes.iter().enumerate() {
        for (nb, lb, hb, _, _) in &boxes[a + 1..] {
            // Separated by at least 2 cm along some axis.
            let apart =
                (0..3).any(|k| la[k] >= hb[k] + 0.02 - 1e-5 || lb[k] >= ha[k] + 0.02 - 1e-5);
            assert!(apart, "{na} and {nb} are closer than 2 cm");
        }
    }
}

#[test]
fn cornell_box_builds_with_every_patch_facing_into_the_box() {
    let s = Scene::new(cornell_box(50.0)).unwrap();
    assert!(s.patches().len() > 100);
    let centre = glam::Vec3::new(278.0, 274.4, 279.6);
    let light = s
        .materials()
        .iter()
        .position(|m| m.name == "light")
        .unwrap() as u32;
    let light_area: f64 = s
        .polygons()
        .iter()
        .filter(|p| p.material() == light)
        .map(|p| p.area())
        .sum();
    assert!((light_area - 130.0 * 105.0).abs() < 1e-3);
    // The floor pieces cover the floor less the two block footprints.
    let floor: f64 = s
        .polygons()
        .iter()
        .filter(|p| p.name().starts_with("floor"))
        .map(|p| p.area())
        .sum();
    let full = 0.5 * (552.8 + 549.6) * 559.2;
    assert!(
        floor < full - 20_000.0 && floor > full - 60_000.0,
        "floor area {floor}"
    );
    for p in s.patches() {
        let poly = &s.polygons()[p.polygon as usize];
        if poly.name().starts_with("short") || poly.name().starts_with("tall") {
            continue;
        }
        assert!(
            (centre - p.center).dot(p.normal) > 0.0,
            "{} faces out",
            poly.name()
        );
    }
}

#[test]
fn committed_bench_scene_files_match_their_builders() {
    // `cargo xtask scenes` writes them; this keeps them in step with the code.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench-scenes");
    let cases = [
        ("cube.json", cube(10)),
        ("loft.json", loft()),
        (
            "cornell.json",
            cornell_box(rad_geometry::scenes::CORNELL_PATCH_MM),
        ),
        ("satellite.json", rad_geometry::scenes::satellite()),
        ("room_cart.json", rad_geometry::scenes::room_with_cart(0.5)),
    ];
    for (name, built) in cases {
        let file = rad_geometry::file::load_scene_desc(&dir.join(name), None).unwrap();
        assert_eq!(
            file, built,
            "{name} is out of date: run `cargo xtask scenes`"
        );
    }
    for (name, built) in [
        (
            "satellite_motion.json",
            rad_geometry::scenes::satellite_motion(36),
        ),
        ("cart_motion.json", rad_geometry::scenes::cart_motion(10)),
    ] {
        let mut file = rad_geometry::Motion::read(&dir.join(name)).unwrap();
        file.path = built.path.clone();
        assert!(
            file == built,
            "{name} is out of date: run `cargo xtask scenes`"
        );
    }
    // The mesh scenes are written without polygon names (by index, compactly).
    let unnamed = |mut d: rad_geometry::SceneDesc| {
        for (k, p) in d.polygons.iter_mut().enumerate() {
            p.name = format!("polygon {k}");
        }
        d
    };
    for (name, built) in [
        ("loft_patches.json", loft_patches()),
        ("canyon.json", rad_geometry::scenes::urban_canyon()),
        ("loft_triangles.json", loft_triangles()),
        ("loft_fine.json", loft_fine_triangles()),
        ("blob_room.json", blob_room()),
    ] {
        let file = rad_geometry::file::load_scene_desc(&dir.join(name), None).unwrap();
        assert!(
            file == unnamed(built),
            "{name} is out of date: run `cargo xtask scenes`"
        );
    }
}

#[test]
fn mesh_scenes_have_their_counts() {
    let loft_area: f64 = Scene::new(loft())
        .unwrap()
        .patches()
        .iter()
        .map(|p| p.area)
        .sum();
    for (desc, polygons) in [
        (loft_patches(), 14_400),
        (loft_triangles(), 28_800),
        (loft_fine_triangles(), 115_200),
    ] {
        let s = Scene::new(desc).unwrap();
        assert_eq!(s.polygons().len(), polygons);
        assert_eq!(s.patches().len(), polygons, "one patch a polygon");
        // The same surfaces as the loft's.
        let area: f64 = s.patches().iter().map(|p| p.area).sum();
        assert!(
            (area / loft_area - 1.0).abs() < 1e-6,
            "{area} against {loft_area}"
        );
    }
    let blob = Scene::new(blob_room()).unwrap();
    let triangles = blob
        .polygons()
        .iter()
        .filter(|p| p.vertices().len() == 3)
        .count();
    assert_eq!(triangles, 20_480);
    // The room's faces cut into 0.25 m cells (2 · 16 · 16 + 4 · 12 · 16), the lamp's
    // into 0.2 m cells (2 · 4 · 4 + 4 · 4), a patch a triangle.
    assert_eq!(blob.patches().len(), 1280 + 48 + 20_480);
}

#[test]
fn the_blob_faces_out_and_varies() {
    let s = Scene::new(blob_room()).unwrap();
    let centre = glam::Vec3::new(2.0, 1.15, 2.0);
    let tris: Vec<_> = s
        .polygons()
        .iter()
        .filter(|p| p.vertices().len() == 3)
        .collect();
    let mut areas: Vec<f64> = tris.iter().map(|p| p.area()).collect();
    for p in &tris {
        assert!(
            (p.vertices()[0] - centre).dot(p.normal()) > 0.0,
            "{} faces in",
            p.name()
        );
    }
    areas.sort_by(f64::total_cmp);
    let (lo, hi) = (areas[areas.len() / 100], areas[areas.len() * 99 / 100]);
    assert!(
        hi / lo > 3.0,
        "irregular: areas from {lo} to {hi} (1st to 99th percentile)"
    );
}

/// Rays from a mesh scene's patches: in the loft's tessellations each meets the
/// surface the loft itself puts there (the nearest hit at the same distance, so the
/// tessellation leaves no crack), and in the blob's room none escapes (brute force).
#[test]
fn mesh_scenes_are_closed() {
    let loft_scene = Scene::new(loft()).unwrap();
    let spiral = |frame: rad_core::Frame, j: usize, n: usize| {
        let z = (j as f32 + 0.5) / n as f32;
        let a = 2.4 * j as f32;
        let r = (1.0 - z * z).sqrt();
        frame.world_from_local(glam::Vec3::new(r * a.cos(), r * a.sin(), z))
    };
    let mut hits = Vec::new();
    let mut nearest = |s: &Scene, ray: &rad_core::Ray| {
        s.all_hits(ray, &mut hits);
        hits.first().map(|h| h.t)
    };
    for (desc, n_patches, n_dirs, like_loft) in [
        (loft_triangles(), 12, 24, true),
        (loft_fine_triangles(), 6, 16, true),
        (blob_room(), 24, 24, false),
    ] {
        let s = Scene::new(desc).unwrap();
        let n = s.patches().len();
        for k in 0..n_patches {
            let p = &s.patches()[(k * 7919 + 13) % n];
            let frame = s.polygons()[p.polygon as usize].frame();
            for j in 0..n_dirs {
                // From just off the patch (on no polygon of either scene).
                let ray = rad_core::Ray::new(p.center + 1e-3 * p.normal, spiral(frame, j, n_dirs));
                let t = nearest(&s, &ray);
                assert!(t.is_some(), "a ray escapes from patch {}", p.polygon);
                if like_loft {
                    let t_loft = nearest(&loft_scene, &ray).unwrap();
                    let t = t.unwrap();
                    assert!(
                        (t - t_loft).abs() <= 1e-4 * (1.0 + t_loft),
                        "{t} against {t_loft}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_canyon_has_its_facets_each_facing_out_of_its_building() {
    use rad_geometry::scenes::{urban_canyon, CANYON_FACETS};
    let desc = urban_canyon();
    let s = Scene::new(desc.clone()).unwrap();
    assert_eq!(s.polygons().len(), CANYON_FACETS);
    assert_eq!(s.patches().len(), CANYON_FACETS);
    let groups: std::collections::HashSet<_> =
        (0..CANYON_FACETS).map(|k| s.group(k).unwrap()).collect();
    assert_eq!(groups.len(), 1 + 12 * 5);
    for (k, poly) in s.polygons().iter().enumerate() {
        assert!((poly.area() - 1.0).abs() < 1e-6);
        // Every facet faces the open air: a point 0.5 m in front of it is outside
        // every building.
        let c = s.patches()[k].center + poly.normal() * 0.5;
        assert!(c.y > 0.0);
        let g = s.group(k).unwrap();
        if let Some(rest) = g.strip_prefix("building ") {
            let b: usize = rest.split(' ').next().unwrap().parse().unwrap();
            let (x0, z0) = (8 + (b % 6) * 18, 8 + (b / 6) * 24);
            let inside = (x0 as f32..(x0 + 12) as f32).contains(&c.x)
                && (z0 as f32..(z0 + 12) as f32).contains(&c.z)
                && c.y < 25.0;
            assert!(!inside, "facet {k} ({g}) faces into its building");
        }
    }
}

/// `two_sided` in the JSON format: the polygon and its reverse, appended after the
/// file's polygons, with the front's cells (a 3 × 5 grid turned to 5 × 3), groups kept
/// apart, and the flag written back.
#[test]
fn two_sided_polygons_get_a_back_with_the_fronts_cells() {
    let json = r#"{"materials": [{"name": "m", "reflectance": [0.5, 0.5, 0.5]}],
      "polygons": [
        {"name": "fin", "material": "m", "patches": [3, 5], "group": "fins", "two_sided": true,
         "vertices": [[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]]},
        {"name": "tile", "material": "m", "patches": [2, 4], "two_sided": true,
         "vertices": [[0, 0, 2], [1, 0, 2], [1, 1, 2], [0, 1, 2]]},
        {"name": "floor", "material": "m", "patches": [1, 1],
         "vertices": [[0, 0, -1], [2, 0, -1], [2, 1, -1], [0, 1, -1]]}
      ]}"#;
    let desc = rad_geometry::file::scene_desc_from_json(json, None).unwrap();
    assert!(desc.polygons[0].two_sided && !desc.polygons[2].two_sided);
    let again = rad_geometry::file::scene_desc_to_json(&desc, None);
    assert!(again.contains("\"two_sided\": true"), "{again}");
    assert_eq!(again.matches("two_sided").count(), 2);
    let scene = Scene::new(desc).unwrap();
    let names: Vec<&str> = scene.polygons().iter().map(|p| p.name()).collect();
    assert_eq!(names, ["fin", "tile", "floor", "fin:back", "tile:back"]);
    let (front, back) = (&scene.polygons()[0], &scene.polygons()[3]);
    assert!(front.front_only() && back.front_only() && !scene.polygons()[2].front_only());
    assert_eq!(front.normal(), -back.normal());
    assert_eq!((front.grid(), back.grid()), ((3, 5), (5, 3)));
    // A square's too (its sides are equal: turned by direction).
    assert_eq!(
        (scene.polygons()[1].grid(), scene.polygons()[4].grid()),
        ((2, 4), (4, 2))
    );
    assert_eq!(scene.group(3), Some("fins:back"));
    // Patches polygon by polygon: the backs' last, at the fronts' centres.
    assert_eq!(scene.patches().len(), 15 + 8 + 1 + 15 + 8);
    let centres = |poly: u32| {
        let mut c: Vec<[u32; 3]> = scene
            .patches()
            .iter()
            .filter(|p| p.polygon == poly)
            .map(|p| (p.center * 1e4).round().to_array().map(|x| x as i64 as u32))
            .collect();
        c.sort();
        c
    };
    assert_eq!(centres(0), centres(3));
    assert_eq!(centres(1), centres(4));
    assert!(scene.patches()[24..39].iter().all(|p| p.polygon == 3));
    assert!(scene.patches()[24..39]
        .iter()
        .all(|p| (p.normal + front.normal()).length() < 1e-6));
}

/// The scan-like gallery: 102,400 triangles beside the room's polygons, valid as built,
/// the same at every build, each sculpture facing out from its centre (star-shaped),
/// triangle areas spread over more than thirtyfold (1st to 99th percentile), and thin
/// horns: some vertices reach more than 1.4 outer radii from their centre.
#[test]
fn the_sculptures_are_curved_uneven_and_valid() {
    let desc = sculptures_100k();
    assert_eq!(desc, sculptures_100k(), "deterministic");
    let s = Scene::new(desc).unwrap();
    let tris: Vec<_> = s
        .polygons()
        .iter()
        .filter(|p| p.name().starts_with("sculpture "))
        .collect();
    assert_eq!(tris.len(), 81_920 + 20_480);
    let mut areas: Vec<f64> = tris.iter().map(|p| p.area()).collect();
    areas.sort_by(f64::total_cmp);
    let (lo, hi) = (areas[areas.len() / 100], areas[areas.len() * 99 / 100]);
    assert!(hi / lo > 30.0, "areas from {lo} to {hi}");
    let mut reach = 0.0f32;
    for p in &tris {
        let k: f32 = p.name().split(' ').nth(1).unwrap().parse().unwrap();
        let centre = glam::Vec3::new(0.3 + 1.8 * (k + 0.5), 1.05, 1.8);
        assert!(
            (p.vertices()[0] - centre).dot(p.normal()) > 0.0,
            "{} faces in",
            p.name()
        );
        reach = p
            .vertices()
            .iter()
            .fold(reach, |r, v| r.max((*v - centre).length()));
    }
    assert!(reach > 1.4 * 0.5, "the horns reach {reach} m");
}
