//! The voxel grid agrees with brute force on random scenes and rays.

use glam::Vec3;
use proptest::prelude::*;
use rad_accel::{BruteForce, GridResolution, VoxelGrid, VoxelGridConfig, WideBvh};
use rad_core::{Hit, Ray, RayCast, NO_POLYGON};
use rad_geometry::Scene;
use rad_testkit::{random_scene, ray, two_sided_flags, with_two_sided};

fn same(a: Option<Hit>, b: Option<Hit>) -> Result<(), TestCaseError> {
    match (a, b) {
        (None, None) => Ok(()),
        (Some(a), Some(b)) => {
            prop_assert_eq!(a.polygon, b.polygon);
            prop_assert!(
                (a.t - b.t).abs() <= 1e-4 * a.t.max(1.0),
                "t {} vs {}",
                a.t,
                b.t
            );
            prop_assert!((a.u - b.u).abs() < 1e-3 && (a.v - b.v).abs() < 1e-3);
            prop_assert_eq!(a.front, b.front);
            Ok(())
        }
        (a, b) => Err(TestCaseError::fail(format!("grid {a:?} vs brute {b:?}"))),
    }
}

fn grids(scene: &Scene) -> Vec<VoxelGrid<'_>> {
    [
        GridResolution::Fixed([1, 1, 1]),
        GridResolution::Fixed([7, 3, 5]),
        GridResolution::Auto {
            density: 8.0,
            max_per_axis: 64,
        },
    ]
    .into_iter()
    .map(|resolution| VoxelGrid::build(scene, &VoxelGridConfig { resolution }).unwrap())
    .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn grid_closest_and_all_hits_match_brute_force(
        desc in random_scene(12),
        sides in two_sided_flags(),
        rays in proptest::collection::vec(ray(), 1..40),
    ) {
        let scene = Scene::new(with_two_sided(desc, &sides)).unwrap();
        let brute = BruteForce::new(&scene);
        let mut bs = brute.new_scratch();
        let (mut ha, mut hb) = (Vec::new(), Vec::new());
        for grid in grids(&scene) {
            let mut gs = grid.new_scratch();
            for &(o, d) in &rays {
                let r = Ray::new(o, d);
                same(grid.closest_hit(&r, &mut gs), brute.closest_hit(&r, &mut bs))?;
                grid.all_hits(&r, &mut gs, &mut ha);
                brute.all_hits(&r, &mut bs, &mut hb);
                prop_assert_eq!(ha.iter().map(|h| h.polygon).collect::<Vec<_>>(), hb.iter().map(|h| h.polygon).collect::<Vec<_>>());
            }
        }
        // The wide BVH: the very hits of brute force (polygon, t, u, v, side).
        let wide = WideBvh::new(&scene);
        for &(o, d) in &rays {
            for t_max in [f32::INFINITY, 1.5] {
                let r = Ray { t_max, ..Ray::new(o, d) };
                prop_assert_eq!(wide.closest_hit(&r, &mut ()), brute.closest_hit(&r, &mut bs));
                wide.all_hits(&r, &mut (), &mut ha);
                brute.all_hits(&r, &mut bs, &mut hb);
                prop_assert_eq!(&ha, &hb);
            }
        }
    }

    /// In a scene a hundred thousand times smaller (boxes grown by less than obvhs's
    /// fixed 1e-4 start), the wide BVH still gives brute force's hits, near ones too.
    #[test]
    fn the_wide_bvh_matches_brute_force_in_tiny_scenes(
        desc in random_scene(12),
        rays in proptest::collection::vec(ray(), 1..40),
    ) {
        let mut desc = desc;
        for p in &mut desc.polygons {
            for v in &mut p.vertices {
                *v *= 1e-5;
            }
        }
        let scene = Scene::new(desc);
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let brute = BruteForce::new(&scene);
        let wide = WideBvh::new(&scene);
        let (mut bs, mut ha, mut hb) = (brute.new_scratch(), Vec::new(), Vec::new());
        for &(o, d) in &rays {
            let r = Ray::new(o * 1e-5, d);
            prop_assert_eq!(wide.closest_hit(&r, &mut ()), brute.closest_hit(&r, &mut bs));
            wide.all_hits(&r, &mut (), &mut ha);
            brute.all_hits(&r, &mut bs, &mut hb);
            prop_assert_eq!(&ha, &hb);
        }
    }

    #[test]
    fn shared_origin_queries_match_single_rays(
        desc in random_scene(12),
        sides in two_sided_flags(),
        patch_pick in 0usize..1000,
        dirs in proptest::collection::vec(rad_testkit::unit_vector(), 1..60),
    ) {
        // From a patch centre, over its hemisphere, as a hemisphere casts.
        let scene = Scene::new(with_two_sided(desc, &sides)).unwrap();
        let patch = &scene.patches()[patch_pick % scene.patches().len()];
        let n = patch.normal;
        let dirs: Vec<Vec3> = dirs.into_iter().map(|d| if d.dot(n) > 0.0 { d } else { d - 2.0 * d.dot(n) * n }).filter(|d| d.dot(n) > 1e-3).collect();
        let brute = BruteForce::new(&scene);
        let mut bs = brute.new_scratch();
        let mut out = Vec::new();
        for grid in grids(&scene) {
            let mut gs = grid.new_scratch();
            grid.closest_hits_from(patch.center, patch.polygon, &dirs, &mut gs, &mut out);
            prop_assert_eq!(out.len(), dirs.len());
            for (k, &d) in dirs.iter().enumerate() {
                let r = Ray { origin: patch.center, dir: d, t_max: f32::INFINITY, skip: patch.polygon };
                same(out[k], brute.closest_hit(&r, &mut bs))?;
                // A single-ray query after a shared-origin one sees every polygon again.
                let free = Ray { skip: NO_POLYGON, ..r };
                let g = grid.closest_hit(&free, &mut gs);
                let b = brute.closest_hit(&free, &mut bs);
                // Without `skip`, the own polygon may be hit at t ≈ 0 in either; compare others.
                if g.is_some_and(|h| h.polygon != patch.polygon) || b.is_some_and(|h| h.polygon != patch.polygon) {
                    same(g, b)?;
                }
            }
        }
    }
}
