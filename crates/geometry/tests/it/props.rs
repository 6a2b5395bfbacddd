//! Patch textures: (u, v) → patch id → patch centre round-trips, and patches tile
//! their polygon.

use proptest::prelude::*;
use rad_geometry::Scene;
use rad_testkit::{random_scene, unit_vector};

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

    /// The batched front-hit query gives, ray for ray, what `intersect_from` and
    /// `patch_at` give (whichever of its builds, baseline or AVX2, this CPU runs).
    #[test]
    fn batched_front_hits_match_ray_by_ray(
        desc in random_scene(4),
        origin in (-2.0f32..3.0, -2.0f32..3.0, -2.0f32..3.0),
        dirs in proptest::collection::vec(unit_vector(), 1..40),
    ) {
        let scene = Scene::new(desc).unwrap();
        let o = glam::Vec3::new(origin.0, origin.1, origin.2);
        for poly in scene.polygons() {
            let terms = poly.origin_terms(o);
            let mut patch = vec![0; dirs.len()];
            let mut t = vec![0.0; dirs.len()];
            match poly.front_hits_from(terms, &dirs, &mut patch, &mut t) {
                None => prop_assert!(!poly.is_parallelogram()),
                Some(()) => {
                    for (k, &d) in dirs.iter().enumerate() {
                        match poly.intersect_from(terms, d, f32::INFINITY) {
                            Some((tt, u, v, true)) => {
                                prop_assert_eq!(patch[k], poly.patch_at(u, v));
                                prop_assert_eq!(t[k].to_bits(), tt.to_bits());
                            }
                            _ => prop_assert_eq!(patch[k], rad_geometry::MISS),
                        }
                    }
                }
            }
        }
    }
}
