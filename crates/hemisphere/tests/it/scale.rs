//! Scale invariance: form factors are ratios of lengths, so a scene scaled by any
//! factor has the same rows. By a power of two, every f32 operation of the hit tests
//! scales exactly, so the rows are the same to the bit; by any factor from 1e-6 to 1e6,
//! the same within the f32 rounding of the ray tests, which can move a cell whose ray
//! passes within rounding of an edge to the neighbouring polygon: the rows agree to a
//! few cells' delta form factors, and each polygon's share of a row far closer.

use proptest::prelude::*;
use rad_geometry::{scenes, Scene, SceneDesc};
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, Row, Scan};

fn scaled(desc: &SceneDesc, s: f32) -> Scene {
    let mut d = desc.clone();
    for p in &mut d.polygons {
        for v in &mut p.vertices {
            *v *= s;
        }
    }
    Scene::new(d).unwrap()
}

fn rows(scene: &Scene, hemi: &Hemisphere) -> Vec<Row> {
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    compute_rows(scene, &Scan, hemi, &all, &|_| {}).unwrap()
}

/// The largest difference of one entry, and of one polygon's share of a row, between
/// two sets of rows of the same scene.
fn differences(scene: &Scene, a: &[Row], b: &[Row]) -> (f64, f64) {
    let n = scene.patches().len();
    let polygon_of: Vec<usize> = scene.patches().iter().map(|p| p.polygon as usize).collect();
    let (mut entry, mut share) = (0.0f64, 0.0f64);
    let mut dense = vec![0.0; n];
    let mut by_polygon = vec![0.0; scene.polygons().len()];
    for (ra, rb) in a.iter().zip(b) {
        dense.iter_mut().for_each(|x| *x = 0.0);
        by_polygon.iter_mut().for_each(|x| *x = 0.0);
        for &(j, f) in &ra.entries {
            dense[j as usize] += f;
            by_polygon[polygon_of[j as usize]] += f;
        }
        for &(j, f) in &rb.entries {
            dense[j as usize] -= f;
            by_polygon[polygon_of[j as usize]] -= f;
        }
        entry = dense.iter().fold(entry, |m, x| m.max(x.abs()));
        share = by_polygon.iter().fold(share, |m, x| m.max(x.abs()));
    }
    (entry, share)
}

#[test]
fn scaling_by_powers_of_two_gives_the_same_rows_to_the_bit() {
    let desc = scenes::cube(4);
    let hemi = Hemisphere::new(HemisphereConfig::exact(30, 120)).unwrap();
    let base = rows(&Scene::new(desc.clone()).unwrap(), &hemi);
    for e in [-20, -7, 3, 19] {
        let s = 2f32.powi(e);
        assert!(rows(&scaled(&desc, s), &hemi) == base, "scale 2^{e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]
    #[test]
    fn rows_do_not_depend_on_the_scale_from_1e_minus_6_to_1e6(
        scene in rad_testkit::random_scene(8),
        exponent in -6.0f64..6.0,
    ) {
        let s = 10f64.powf(exponent) as f32;
        let hemi = Hemisphere::new(HemisphereConfig::exact(24, 96)).unwrap();
        let base_scene = Scene::new(scene.clone()).unwrap();
        let base = rows(&base_scene, &hemi);
        let other = rows(&scaled(&scene, s), &hemi);
        let (entry, share) = differences(&base_scene, &base, &other);
        // One cell of this hemisphere holds at most this much form factor.
        let cell = hemi.ring_form_factors().iter().fold(0.0f64, |m, &d| m.max(d));
        prop_assert!(entry <= 4.0 * cell, "scale {s:e}: an entry moved by {entry:e} (a cell is {cell:e})");
        prop_assert!(share <= 4.0 * cell, "scale {s:e}: a polygon's share moved by {share:e}");
    }
}
