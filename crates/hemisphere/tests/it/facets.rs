//! The facet scan gives the voxel grid's item buffers, to the bit, on meshes of flat
//! pieces: random scenes of intersecting polygons, each cut into a fan of one-patch
//! triangles (thin ones too) that join into facets, some pressed into planes of constant
//! x, y or z (whose triangles share their facet's plane to the bit).

use proptest::prelude::*;
use rad_accel::{BruteForce, GridResolution, VoxelGrid, VoxelGridConfig};
use rad_core::{Ray, RayCast};
use rad_geometry::{PatchGrid, PolygonDesc, Scene, SceneDesc};
use rad_hemisphere::{Caster, FacetRays, FacetScan, Hemisphere, HemisphereConfig, ItemBuffer};
use rad_testkit::{random_scene, ray, two_sided_flags, unit_vector, with_two_sided};

/// Every polygon of `desc` cut into a fan of one-patch triangles from its centroid, each
/// edge split in `cuts` pieces (the split points made once an edge, so that neighbours
/// share them to the bit).
fn fans(desc: SceneDesc, cuts: &[usize]) -> SceneDesc {
    let mut polygons = Vec::new();
    for (p, &m) in desc.polygons.iter().zip(cuts.iter().cycle()) {
        let vs = &p.vertices;
        let c = vs.iter().copied().sum::<glam::DVec3>() / vs.len() as f64;
        let mut ring = Vec::new();
        for k in 0..vs.len() {
            let (a, b) = (vs[k], vs[(k + 1) % vs.len()]);
            for j in 0..m {
                ring.push(a + (b - a) * (j as f64 / m as f64));
            }
        }
        for k in 0..ring.len() {
            polygons.push(PolygonDesc {
                name: format!("{} {k}", p.name),
                vertices: vec![c, ring[k], ring[(k + 1) % ring.len()]],
                grid: PatchGrid::Cells { nu: 1, nv: 1 },
                ..p.clone()
            });
        }
    }
    SceneDesc { polygons, ..desc }
}

/// `desc` with polygon k pressed into a plane of constant x, y or z (k mod 3) through
/// its first vertex: its fan's triangles then share their f32 plane with their facet to
/// the bit (the facet scan's shortcut for them).
fn axis_aligned(mut desc: SceneDesc) -> SceneDesc {
    for (k, p) in desc.polygons.iter_mut().enumerate() {
        let axis = k % 3;
        let c = p.vertices[0][axis];
        for v in &mut p.vertices {
            v[axis] = c;
        }
    }
    desc
}

/// `desc` (pressed into axis planes if `flat`) with its sides, cut into fans, moved by
/// `offset` along (1, −1/2, 1/4): the random meshes of these tests.
fn mesh_scene(
    desc: SceneDesc,
    sides: &[bool],
    cuts: &[usize],
    offset: f64,
    flat: bool,
) -> Result<Scene, rad_geometry::Error> {
    let desc = if flat { axis_aligned(desc) } else { desc };
    let mut desc = fans(with_two_sided(desc, sides), cuts);
    for p in &mut desc.polygons {
        for v in &mut p.vertices {
            *v += glam::DVec3::new(offset, -0.5 * offset, 0.25 * offset);
        }
    }
    Scene::new(desc)
}

fn first_difference(a: &ItemBuffer, b: &ItemBuffer) -> Option<usize> {
    (0..a.patch.len())
        .find(|&k| a.patch[k] != b.patch[k] || a.dist[k].to_bits() != b.dist[k].to_bits())
}

/// The first patch of `patches` whose facet-scan buffer differs from the grid's.
fn compare(scene: &Scene, hemi: &Hemisphere, patches: &[u32]) -> Option<(u32, usize)> {
    let resolution = GridResolution::Auto {
        density: 4.0,
        max_per_axis: 64,
    };
    let grid = VoxelGrid::build(scene, &VoxelGridConfig { resolution }).unwrap();
    let facets = FacetScan::new(scene);
    let (mut gs, mut fs) = (grid.new_scratch(), facets.scratch());
    let (mut a, mut b) = (ItemBuffer::default(), ItemBuffer::default());
    let r = patches.iter().find_map(|&p| {
        hemi.cast(scene, &grid, p, &mut gs, &mut a);
        facets.item_buffer(scene, hemi, p, &mut fs, &mut b);
        first_difference(&a, &b).map(|k| (p, k))
    });
    r
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]

    #[test]
    fn the_facet_scan_matches_the_grid_on_random_meshes(
        desc in random_scene(8),
        sides in two_sided_flags(),
        cuts in proptest::collection::vec(1usize..5, 1..8),
        n_theta in 4u32..50,
        n_phi in 8u32..200,
        shift in prop_oneof![Just(0.0), 0.0f64..1.0],
        picks in proptest::collection::vec(any::<prop::sample::Index>(), 1..8),
        offset in prop_oneof![Just(0.0f64), Just(37.0)],
        flat in any::<bool>(),
    ) {
        let scene = mesh_scene(desc, &sides, &cuts, offset, flat);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let hemi = Hemisphere::new(HemisphereConfig { phi_shift: shift, ..HemisphereConfig::exact(n_theta, n_phi) }).unwrap();
        let patches: Vec<u32> = picks.iter().map(|i| i.index(scene.patches().len()) as u32).collect();
        prop_assert_eq!(compare(&scene, &hemi, &patches), None);
    }

    /// Single rays through the facets give brute force's hits to the bit (polygon, t,
    /// u, v, side; every hit along the ray too): from anywhere, from patch centres (in
    /// their facet's plane) with and without their own polygon skipped, along and
    /// nearly along a facet's plane, and with a bound on t.
    #[test]
    fn facet_rays_match_brute_force_on_random_meshes(
        desc in random_scene(8),
        sides in two_sided_flags(),
        cuts in proptest::collection::vec(1usize..5, 1..8),
        offset in prop_oneof![Just(0.0f64), Just(37.0)],
        flat in any::<bool>(),
        free in proptest::collection::vec(ray(), 1..20),
        picks in proptest::collection::vec((any::<prop::sample::Index>(), unit_vector(), -1e-4f32..1e-4), 1..30),
    ) {
        let scene = mesh_scene(desc, &sides, &cuts, offset, flat);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let shift = glam::Vec3::new(offset as f32, -0.5 * offset as f32, 0.25 * offset as f32);
        let mut rays: Vec<Ray> = free.iter().map(|&(o, d)| Ray::new(o + shift, d)).collect();
        for (i, d, lift) in &picks {
            let patch = &scene.patches()[i.index(scene.patches().len())];
            let n = patch.normal;
            // A direction in the patch's plane, nearly, and one off it.
            let along = (*d - n * d.dot(n)).normalize_or_zero();
            let slant = (along + n * *lift).normalize_or_zero();
            for dir in [*d, slant] {
                if dir.length() > 0.5 {
                    let r = Ray::new(patch.center, dir);
                    rays.push(r);
                    rays.push(Ray { skip: patch.polygon, ..r });
                    rays.push(Ray { origin: patch.center + n * 0.3, ..r });
                }
            }
        }
        let facets = FacetRays::new(&scene, rad_accel::WideTree::new);
        let brute = BruteForce::new(&scene);
        let (mut fs, mut bs) = (facets.new_scratch(), brute.new_scratch());
        let (mut ha, mut hb) = (Vec::new(), Vec::new());
        for r in &rays {
            for t_max in [f32::INFINITY, 1.5] {
                let r = Ray { t_max, ..*r };
                prop_assert_eq!(facets.closest_hit(&r, &mut fs), brute.closest_hit(&r, &mut bs), "{:?}", r);
                facets.all_hits(&r, &mut fs, &mut ha);
                brute.all_hits(&r, &mut bs, &mut hb);
                prop_assert_eq!(&ha, &hb, "{:?}", r);
            }
        }
    }
}

proptest! {
    /// Rays from one origin through facets binned by direction from it (a light
    /// buffer, made at the first ray) give brute force's hits to the bit: from anywhere,
    /// and from a patch centre (in its facet's plane) with and without its polygon
    /// skipped, along and nearly along the plane, with and without a bound on t.
    #[test]
    fn binned_facet_rays_match_brute_force(
        desc in random_scene(8),
        sides in two_sided_flags(),
        cuts in proptest::collection::vec(1usize..5, 1..8),
        offset in prop_oneof![Just(0.0f64), Just(37.0)],
        flat in any::<bool>(),
        free in ray(),
        pick in any::<prop::sample::Index>(),
        dirs in proptest::collection::vec((unit_vector(), -1e-4f32..1e-4), 1..40),
    ) {
        let scene = mesh_scene(desc, &sides, &cuts, offset, flat);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let shift = glam::Vec3::new(offset as f32, -0.5 * offset as f32, 0.25 * offset as f32);
        let patch = &scene.patches()[pick.index(scene.patches().len())];
        let n = patch.normal;
        let facets = FacetRays::new(&scene, rad_accel::WideTree::new).bin_after(1);
        let brute = BruteForce::new(&scene);
        let (mut fs, mut bs) = (facets.new_scratch(), brute.new_scratch());
        for (origin, skip) in [(free.0 + shift, None), (patch.center, None), (patch.center, Some(patch.polygon))] {
            let mut rays = vec![Ray::new(origin, free.1)];
            for (d, lift) in &dirs {
                let along = (*d - n * d.dot(n)).normalize_or_zero();
                let slant = (along + n * *lift).normalize_or_zero();
                rays.extend([*d, slant].into_iter().filter(|d| d.length() > 0.5).map(|d| Ray::new(origin, d)));
            }
            // (Also binned once, for every scratch.)
            let shared = FacetRays::new(&scene, rad_accel::WideTree::new).bin_from(origin);
            let mut ss = shared.new_scratch();
            for r in rays {
                for t_max in [f32::INFINITY, 1.5] {
                    let r = Ray { t_max, skip: skip.unwrap_or(r.skip), ..r };
                    let want = brute.closest_hit(&r, &mut bs);
                    prop_assert_eq!(facets.closest_hit(&r, &mut fs), want, "{:?}", r);
                    prop_assert_eq!(shared.closest_hit(&r, &mut ss), want, "{:?}", r);
                }
            }
        }
    }
}

/// On the loft cut into 115,200 triangles, single rays through its 180 facets give
/// brute force's hits (rays from the camera and from patch centres).
#[test]
fn facet_rays_match_brute_force_on_the_fine_loft() {
    let scene = Scene::new(rad_geometry::scenes::loft_fine_triangles()).unwrap();
    let facets = FacetRays::new(&scene, rad_accel::WideTree::new);
    assert!(facets.facet_count() < 200, "{}", facets.facet_count());
    let brute = BruteForce::new(&scene);
    let (mut fs, mut bs) = (facets.new_scratch(), brute.new_scratch());
    let camera = scene.camera().unwrap().position;
    let patches = scene.patches();
    let mut k = 0u32;
    let mut dir = || {
        // (Deterministic spread of directions.)
        k += 1;
        let (a, b) = (k as f32 * 0.618_034, k as f32 * 0.414_214);
        let z = 2.0 * a.fract() - 1.0;
        let r = (1.0 - z * z).sqrt();
        let phi = std::f32::consts::TAU * b.fract();
        glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    for j in 0..400 {
        let p = &patches[(j * 7919) % patches.len()];
        for r in [
            Ray::new(camera, dir()),
            Ray {
                skip: p.polygon,
                ..Ray::new(p.center, dir())
            },
        ] {
            assert_eq!(
                facets.closest_hit(&r, &mut fs),
                brute.closest_hit(&r, &mut bs),
                "{r:?}"
            );
        }
    }
    // The camera's rays through the facets binned by direction from it.
    let binned = facets.bin_after(1);
    let mut fs = binned.new_scratch();
    for _ in 0..2000 {
        let r = Ray::new(camera, dir());
        assert_eq!(
            binned.closest_hit(&r, &mut fs),
            brute.closest_hit(&r, &mut bs),
            "{r:?}"
        );
    }
}

/// The loft cut into 28,800 triangles: the facet scan locates (rather than scans one by
/// one) nearly every facet, takes most cells' t from the facet's plane, and gives the
/// grid's cells.
#[test]
fn the_facet_scan_matches_the_grid_on_the_tessellated_loft() {
    let scene = Scene::new(rad_geometry::scenes::loft_triangles()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).unwrap();
    let n = scene.patches().len();
    let patches: Vec<u32> = (0..12).map(|k| ((k * n / 12 + 37) % n) as u32).collect();
    assert_eq!(compare(&scene, &hemi, &patches), None);
    let facets = FacetScan::new(&scene);
    let mut fs = facets.scratch();
    let mut buf = ItemBuffer::default();
    for &p in &patches {
        facets.item_buffer(&scene, &hemi, p, &mut fs, &mut buf);
    }
    let st = fs.stats;
    assert!(st.located > 20 * st.one_by_one, "{st:?}");
    // (Its triangles share their walls' f32 planes: most located cells take the
    // facet plane's t as it stands, and still give the grid's bits.)
    assert!(2 * st.direct > st.cells_near, "{st:?}");
}
