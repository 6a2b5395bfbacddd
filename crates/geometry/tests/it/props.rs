//! Patch textures: (u, v) → patch id → patch centre round-trips, and patches tile
//! their polygon.

use proptest::prelude::*;
use rad_geometry::Scene;
use rad_testkit::random_scene;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn patch_centres_round_trip_and_patches_tile_polygons(desc in random_scene(4), samples in proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0), 20)) {
        let scene = Scene::new(desc).unwrap();
        for (idx, poly) in scene.polygons().iter().enumerate() {
            let (first, (_, nv)) = (poly.first_patch() as usize, poly.grid());
            let mine: Vec<_> = scene.patches().iter().enumerate().filter(|(_, p)| p.polygon as usize == idx).collect();
            prop_assert!(!mine.is_empty() && mine[0].0 == first);
            // Areas add up to the polygon's.
            let total: f64 = mine.iter().map(|(_, p)| p.area).sum();
            prop_assert!((total - poly.area()).abs() <= 1e-4 * poly.area(), "{total} vs {}", poly.area());
            for (id, p) in &mine {
                // Centre → (u, v) → patch id → the same patch.
                let (u, v) = poly.uv(p.center);
                prop_assert_eq!(poly.patch_at(u, v) as usize, *id);
                prop_assert!(poly.contains_uv(u, v));
                prop_assert!(p.area > 0.0 && p.corners.len() >= 3);
            }
            // A point inside the polygon maps to the patch whose cell holds it.
            for &(su, sv) in &samples {
                if !poly.contains_uv(su, sv) { continue; }
                let id = poly.patch_at(su, sv) as usize;
                let cell = scene.patches()[id].cell;
                let (i, j) = poly.cell_at(su, sv);
                // Cells with no area fall back to a neighbour of the same row or a near row.
                if scene.patches()[id].cell != [i, j] {
                    prop_assert!(cell[1].abs_diff(j) <= nv && scene.patches()[id].on_boundary);
                } else {
                    prop_assert_eq!(cell, [i, j]);
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100))]

    /// The batched patch lookup gives, point for point, what `patch_at` gives (whichever
    /// of its builds, baseline or AVX2, this CPU runs), NaN and far-off points included.
    #[test]
    fn batched_patch_lookup_matches_patch_at(
        desc in random_scene(4),
        uv in proptest::collection::vec(
            (prop_oneof![-0.5f32..1.5, Just(f32::NAN), Just(-1e30f32), Just(1e30f32)],
             prop_oneof![-0.5f32..1.5, Just(f32::NAN), Just(f32::INFINITY)]),
            0..40,
        ),
    ) {
        let scene = Scene::new(desc).unwrap();
        let (u, v): (Vec<f32>, Vec<f32>) = uv.into_iter().unzip();
        for poly in scene.polygons() {
            let mut out = vec![0; u.len()];
            poly.patches_at(&u, &v, &mut out);
            for k in 0..u.len() {
                prop_assert_eq!(out[k], poly.patch_at(u[k], v[k]));
            }
        }
    }
}
