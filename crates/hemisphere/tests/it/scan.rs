//! The polygon scan, and the scan over a hierarchy, give the voxel grid's item
//! buffers, to the bit.

use proptest::prelude::*;
use rad_accel::{GridResolution, VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::{cornell_box, cube, loft, CORNELL_PATCH_MM};
use rad_geometry::{Scene, SceneDesc};
use rad_hemisphere::{
    Caster, FacetScan, Hemisphere, HemisphereConfig, Hierarchy, ItemBuffer, ScanScratch,
};
use rad_testkit::{random_scene, two_sided_flags, with_two_sided};

fn grid(scene: &Scene, density: f64) -> VoxelGrid<'_> {
    let resolution = GridResolution::Auto {
        density,
        max_per_axis: 64,
    };
    VoxelGrid::build(scene, &VoxelGridConfig { resolution }).unwrap()
}

/// The first cell where the two buffers differ (patch, or distance bits).
fn first_difference(a: &ItemBuffer, b: &ItemBuffer) -> Option<usize> {
    assert_eq!(a.patch.len(), b.patch.len());
    (0..a.patch.len())
        .find(|&k| a.patch[k] != b.patch[k] || a.dist[k].to_bits() != b.dist[k].to_bits())
}

/// Casts `patches` through the grid, scans them plainly and over a hierarchy; the first
/// patch whose buffers differ, with the cell and the caster.
fn compare(
    scene: &Scene,
    hemi: &Hemisphere,
    patches: &[u32],
    density: f64,
) -> Option<(u32, usize, &'static str)> {
    let grid = grid(scene, density);
    let tree = Hierarchy::new(scene);
    let mut gs = grid.new_scratch();
    let mut ss = ScanScratch::default();
    let mut hs = tree.scratch();
    let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
    patches.iter().find_map(|&p| {
        hemi.cast(scene, &grid, p, &mut gs, &mut a);
        hemi.scan(scene, p, &mut ss, &mut b);
        if let Some(k) = first_difference(&a, &b) {
            return Some((p, k, "scan"));
        }
        tree.item_buffer(scene, hemi, p, &mut hs, &mut b);
        first_difference(&a, &b).map(|k| (p, k, "hierarchy"))
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(150))]

    /// Random scenes of intersecting polygons (patch centres on or near other polygons'
    /// planes, back faces, general convex polygons), random resolutions and φ shifts.
    #[test]
    fn scan_matches_the_grid_on_random_scenes(
        desc in random_scene(10),
        sides in two_sided_flags(),
        n_theta in 1u32..40,
        n_phi in 1u32..120,
        shift in prop_oneof![Just(0.0), Just(0.5), 0.0f64..1.0],
        picks in proptest::collection::vec(any::<prop::sample::Index>(), 1..6),
        density in prop_oneof![Just(0.5), Just(4.0), Just(16.0)],
        offset in prop_oneof![Just(0.0f32), Just(37.0), Just(-300.0)],
    ) {
        // Far from the origin, f32 rounding is coarser than the scene's details.
        let mut desc = with_two_sided(desc, &sides);
        for p in &mut desc.polygons {
            for v in &mut p.vertices {
                *v = (v.as_vec3() + glam::Vec3::new(offset, -0.5 * offset, 0.25 * offset)).as_dvec3();
            }
        }
        let scene = Scene::new(desc);
        // (f32 vertices so far out may fail the planarity check: draw again)
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let hemi = Hemisphere::new(HemisphereConfig { phi_shift: shift, ..HemisphereConfig::exact(n_theta, n_phi) }).unwrap();
        let patches: Vec<u32> = picks.iter().map(|i| i.index(scene.patches().len()) as u32).collect();
        prop_assert_eq!(compare(&scene, &hemi, &patches, density), None);
    }
}

/// Every polygon shrunk about its centre by its own factor in `scales`.
fn shrink(desc: &mut SceneDesc, scales: &[f32]) {
    for (p, &s) in desc.polygons.iter_mut().zip(scales.iter().cycle()) {
        let c =
            p.vertices.iter().map(|v| v.as_vec3()).sum::<glam::Vec3>() / p.vertices.len() as f32;
        for v in &mut p.vertices {
            *v = (c + (v.as_vec3() - c) * s).as_dvec3();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Many small intersecting polygons (so that the hierarchy has depth, leaves
    /// hidden behind others, subtrees behind a patch's plane and small footprints):
    /// both scans still give the grid's cells.
    #[test]
    fn scans_match_the_grid_on_many_small_polygons(
        desc in random_scene(160),
        sides in two_sided_flags(),
        scales in proptest::collection::vec(0.03f32..0.6, 1..16),
        n_theta in 10u32..60,
        n_phi in 40u32..240,
        picks in proptest::collection::vec(any::<prop::sample::Index>(), 1..6),
    ) {
        let mut desc = with_two_sided(desc, &sides);
        shrink(&mut desc, &scales);
        let scene = Scene::new(desc);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let hemi = Hemisphere::new(HemisphereConfig::exact(n_theta, n_phi)).unwrap();
        let patches: Vec<u32> = picks.iter().map(|i| i.index(scene.patches().len()) as u32).collect();
        prop_assert_eq!(compare(&scene, &hemi, &patches, 4.0), None);
    }
}

/// The hierarchy's cost follows what is seen: in the room with a 20k-triangle blob,
/// a hemisphere reaches a small share of the polygons.
#[test]
fn the_hierarchy_skips_what_is_hidden() {
    let scene = Scene::new(rad_geometry::scenes::blob_room()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let tree = Hierarchy::new(&scene);
    let mut hs = tree.scratch();
    let mut buf = ItemBuffer::default();
    let patches = spread(&scene, 12);
    for &p in &patches {
        tree.item_buffer(&scene, &hemi, p, &mut hs, &mut buf);
    }
    let per = hs.stats.polygons as f64 / patches.len() as f64;
    let n = scene.polygons().len() as f64;
    assert!(per < 0.25 * n, "{per} of {n} polygons reached a hemisphere");
    assert!(
        hs.stats.occluded > 0 && hs.stats.behind > 0,
        "{:?}",
        hs.stats
    );
}

/// The scan-like gallery (102,400 curved triangles of uneven size, crevices, thin
/// horns): the scan, the hierarchy and the facet scan give the grid's cells.
#[test]
fn every_caster_matches_the_grid_on_the_sculptures() {
    let scene = Scene::new(rad_geometry::scenes::sculptures_100k()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    let patches = spread(&scene, 10);
    assert_eq!(compare(&scene, &hemi, &patches, 4.0), None);
    let grid = grid(&scene, 4.0);
    let facets = FacetScan::new(&scene);
    let (mut gs, mut fs) = (grid.new_scratch(), facets.scratch());
    let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
    for &p in &patches {
        hemi.cast(&scene, &grid, p, &mut gs, &mut a);
        facets.item_buffer(&scene, &hemi, p, &mut fs, &mut b);
        assert_eq!(first_difference(&a, &b), None, "facets, patch {p}");
    }
}

fn spread(scene: &Scene, k: usize) -> Vec<u32> {
    let n = scene.patches().len();
    (0..k)
        .map(|i| ((i * n) / k + (7 * i) % (n / k).max(1)) as u32)
        .collect()
}

fn check_scene(desc: SceneDesc, k: usize, hemi: &Hemisphere) {
    let scene = Scene::new(desc).unwrap();
    let patches = spread(&scene, k);
    assert_eq!(compare(&scene, hemi, &patches, 4.0), None);
}

#[test]
fn scan_matches_the_grid_on_the_bench_scenes() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    check_scene(loft(), 120, &hemi);
    check_scene(cube(10), 60, &hemi);
    check_scene(cornell_box(CORNELL_PATCH_MM), 60, &hemi);
    // The report's resolution, and a turned grid.
    let full = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    check_scene(loft(), 8, &full);
    let turned = Hemisphere::new(HemisphereConfig {
        phi_shift: 0.5,
        ..HemisphereConfig::exact(90, 360)
    })
    .unwrap();
    check_scene(loft(), 16, &turned);
}

/// The scan really skips work: far fewer (cell, polygon) tests than polygons per cell.
#[test]
fn scan_tests_few_polygons_per_cell() {
    let scene = Scene::new(loft()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(90, 360)).unwrap();
    let mut ss = ScanScratch::default();
    let mut buf = ItemBuffer::default();
    for p in spread(&scene, 20) {
        hemi.scan(&scene, p, &mut ss, &mut buf);
    }
    let per_cell = ss.stats.tests as f64 / (ss.stats.hemispheres as f64 * hemi.n_cells() as f64);
    assert!(
        per_cell < 12.0,
        "{per_cell} tests per cell of {} polygons",
        scene.polygons().len()
    );
}

/// A convex pentagon whose first and last edges are short (2 % of its size) and whose
/// second vertex lies off the plane of the others (within the planarity tolerance): the
/// grid meets its plane n·p = d, which (u, v) measured along those short edges leave
/// far behind; the scan must bound the former. Placed by `frame` at `centre`.
fn skewed_pentagon(
    centre: glam::Vec3,
    normal: glam::Vec3,
    size: f32,
    lift: f32,
) -> rad_geometry::PolygonDesc {
    let t = normal.any_orthonormal_vector();
    let b = normal.cross(t);
    let local = [
        [0.0, 0.0, 0.0],
        [0.02, 0.0, lift],
        [1.0, 0.5, 0.0],
        [0.5, 1.0, 0.0],
        [0.0, 0.02, 0.0],
    ];
    rad_geometry::PolygonDesc {
        name: "skewed".into(),
        vertices: local
            .iter()
            .map(|[x, y, z]| {
                (centre + (t * (x - 0.4) + b * (y - 0.4) + normal * z) * size).as_dvec3()
            })
            .collect(),
        material: 0,
        grid: rad_geometry::PatchGrid::Cells { nu: 3, nv: 3 },
        group: None,
        obstruction: false,
        two_sided: false,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn scan_matches_the_grid_on_polygons_off_their_plane(
        desc in random_scene(6),
        centre in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        normal in rad_testkit::unit_vector(),
        size in 1.0f32..3.0,
        lift in prop_oneof![Just(1.5e-4f32), -1.5e-4f32..1.5e-4],
        n_theta in 90u32..181,
        n_phi in 360u32..721,
        picks in proptest::collection::vec(any::<prop::sample::Index>(), 1..5),
    ) {
        let mut desc = desc;
        let c = glam::Vec3::new(centre.0, centre.1, centre.2);
        desc.polygons.push(skewed_pentagon(c, normal, size, lift));
        let scene = Scene::new(desc);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let hemi = Hemisphere::new(HemisphereConfig::exact(n_theta, n_phi)).unwrap();
        let patches: Vec<u32> = picks.iter().map(|i| i.index(scene.patches().len()) as u32).collect();
        prop_assert_eq!(compare(&scene, &hemi, &patches, 4.0), None);
    }
}

/// One scratch over several scenes: polygon ids repeat, frames do not.
#[test]
fn a_scratch_moves_between_scenes() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(30, 120)).unwrap();
    // The cube with its faces in another order: polygon 0 is another face.
    let mut turned = cube(10);
    turned.polygons.rotate_left(1);
    let scenes = [cube(10), turned, loft()].map(|d| Scene::new(d).unwrap());
    let n0 = |s: &Scene| s.polygons()[0].normal();
    assert!(n0(&scenes[0]).dot(n0(&scenes[1])) < 0.5);
    let mut shared = ScanScratch::default();
    let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
    // Patch 5 of each scene lies on its polygon 0.
    for scene in [&scenes[0], &scenes[1], &scenes[2], &scenes[0]] {
        assert_eq!(scene.patches()[5].polygon, 0);
        hemi.scan(scene, 5, &mut shared, &mut a);
        hemi.scan(scene, 5, &mut ScanScratch::default(), &mut b);
        assert_eq!(first_difference(&a, &b), None);
    }
}

/// The pentagon above, as found by a check (first and last edges 2 % of its size, its
/// second vertex 1.5e-4 off the others' plane), seen from 300 small probe patches around
/// it with random orientations: at 180 × 720 some cell centres fall where the polygon's
/// plane and the plane of its short edges disagree by several milliradians.
#[test]
fn scan_matches_the_grid_around_a_pentagon_off_its_plane() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut uniform = move |lo: f32, hi: f32| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        lo + (hi - lo) * ((seed >> 40) as f32 / (1u64 << 24) as f32)
    };
    let mut polygons = vec![rad_geometry::PolygonDesc {
        name: "pentagon".into(),
        vertices: [
            [0.0, 0.0, 0.0],
            [0.02, 0.0, 1.5e-4],
            [1.0, 0.5, 0.0],
            [0.5, 1.0, 0.0],
            [0.0, 0.02, 0.0],
        ]
        .map(glam::DVec3::from)
        .to_vec(),
        material: 0,
        grid: rad_geometry::PatchGrid::Cells { nu: 2, nv: 2 },
        group: None,
        obstruction: false,
        two_sided: false,
    }];
    for k in 0..300 {
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let o = glam::Vec3::new(
            uniform(-1.0, 2.0),
            uniform(-1.0, 2.0),
            side * uniform(0.05, 1.0),
        );
        let n =
            glam::Vec3::new(uniform(-1.0, 1.0), uniform(-1.0, 1.0), uniform(-1.0, 1.0)).normalize();
        let t = n.any_orthonormal_vector() * 0.005;
        let b = n.cross(t);
        polygons.push(rad_geometry::PolygonDesc {
            name: format!("probe {k}"),
            vertices: [o - t - b, o + t - b, o + t + b, o - t + b]
                .map(glam::Vec3::as_dvec3)
                .to_vec(),
            material: 0,
            grid: rad_geometry::PatchGrid::Cells { nu: 1, nv: 1 },
            group: None,
            obstruction: false,
            two_sided: false,
        });
    }
    let scene = Scene::new(SceneDesc {
        materials: vec![rad_geometry::Material {
            name: "grey".into(),
            reflectance: rad_core::Rgb([0.5; 3]),
            emission: rad_core::Rgb::BLACK,
        }],
        polygons,
        camera: None,
    })
    .unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let probes: Vec<u32> = (4..scene.patches().len() as u32).collect();
    assert_eq!(probes.len(), 300);
    assert_eq!(compare(&scene, &hemi, &probes, 4.0), None);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(120))]

    /// The scan's and the hierarchy's single rays (improved estimation's real rays,
    /// boundary lists) give the grid's answers to the bit: closest hits from a patch centre, all rays leaving its
    /// plane forwards (so both cull) or some not, and every crossing of a ray.
    #[test]
    fn scan_single_rays_match_the_grid(
        desc in random_scene(10),
        sides in two_sided_flags(),
        pick in any::<prop::sample::Index>(),
        dirs in proptest::collection::vec(rad_testkit::unit_vector(), 1..40),
        density in prop_oneof![Just(0.5), Just(4.0)],
    ) {
        use rad_hemisphere::Scan;
        let scene = Scene::new(with_two_sided(desc, &sides)).unwrap();
        let grid = grid(&scene, density);
        let tree = Hierarchy::new(&scene);
        let mut hs = tree.scratch();
        let patch = &scene.patches()[pick.index(scene.patches().len())];
        let n = scene.polygons()[patch.polygon as usize].normal();
        // Forward rays (as a hemisphere's), then the same with one turned back.
        let forward: Vec<glam::Vec3> = dirs.iter().map(|&d| if d.dot(n) > 0.0 { d } else { -d }).collect();
        let mut mixed = forward.clone();
        mixed[0] = -mixed[0];
        let (mut gs, mut ss) = (grid.new_scratch(), Scan.scratch());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for set in [&forward, &mixed] {
            grid.closest_hits_from(patch.center, patch.polygon, set, &mut gs, &mut a);
            Scan.closest_hits(&scene, patch.center, patch.polygon, set, &mut ss, &mut b);
            prop_assert_eq!(&a, &b);
            tree.closest_hits(&scene, patch.center, patch.polygon, set, &mut hs, &mut b);
            prop_assert_eq!(&a, &b);
        }
        let (mut ga, mut sa) = (Vec::new(), Vec::new());
        for &d in &mixed {
            let mut ray = rad_core::Ray::new(patch.center, d);
            ray.skip = patch.polygon;
            grid.all_hits(&ray, &mut gs, &mut ga);
            Scan.all_hits_along(&scene, &ray, &mut ss, &mut sa);
            prop_assert_eq!(&ga, &sa);
            tree.all_hits_along(&scene, &ray, &mut hs, &mut sa);
            prop_assert_eq!(&ga, &sa);
            // The tree as a ray caster (rendering): closest hits, and with a bound.
            let rays = tree.rays(&scene);
            let mut stack = rays.new_scratch();
            prop_assert_eq!(grid.closest_hit(&ray, &mut gs), rays.closest_hit(&ray, &mut stack));
            ray.t_max = 0.7;
            prop_assert_eq!(grid.closest_hit(&ray, &mut gs), rays.closest_hit(&ray, &mut stack));
            rays.all_hits(&ray, &mut stack, &mut sa);
            grid.all_hits(&ray, &mut gs, &mut ga);
            prop_assert_eq!(&ga, &sa);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    /// A polygon whose plane passes through (or within 1e-7 of) a patch centre, tilted
    /// from the patch's plane by half a ring of 180 × 720 (where its near-plane skip is
    /// decided by a hair: the last ring's rays meet it nearly edge-on) and spanning the
    /// centre's projection, facing either way: the scan still gives the grid's cells.
    #[test]
    fn scan_matches_the_grid_on_planes_through_the_centre(
        tilt in -5e-5f64..5e-5,
        lift in prop_oneof![Just(0.0f32), -1e-7f32..1e-7],
        up in any::<bool>(),
    ) {
        use rad_geometry::{Material, PatchGrid, PolygonDesc};
        let psi = (0.25f64).to_radians() + tilt;
        let y = |x: f32| ((x as f64 - 0.5) * psi.tan()) as f32 + lift;
        let v = |x: f32, z: f32| glam::Vec3::new(x, y(x), z);
        let mut tilted = [v(0.2, 0.2), v(0.2, 0.8), v(0.8, 0.8), v(0.8, 0.2)];
        if !up {
            tilted.reverse();
        }
        let one = PatchGrid::Cells { nu: 1, nv: 1 };
        let floor = [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]
            .map(|(x, z)| glam::Vec3::new(x, 0.0, z))
            .to_vec();
        let desc = SceneDesc {
            materials: vec![Material {
                name: "grey".into(),
                reflectance: rad_core::Rgb([0.5; 3]),
                emission: rad_core::Rgb([0.0; 3]),
            }],
            polygons: vec![
                PolygonDesc { name: "floor".into(), vertices: floor.iter().map(|v| v.as_dvec3()).collect(), material: 0, grid: one, group: None, obstruction: false, two_sided: false },
                PolygonDesc { name: "tilted".into(), vertices: tilted.iter().map(|v| v.as_dvec3()).collect(), material: 0, grid: one, group: None, obstruction: false, two_sided: false },
            ],
            camera: None,
        };
        let scene = Scene::new(desc).unwrap();
        let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
        prop_assert_eq!(compare(&scene, &hemi, &[0, 1], 4.0), None);
    }
}
