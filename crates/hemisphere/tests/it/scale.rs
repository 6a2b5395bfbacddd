//! Scale invariance: form factors are ratios of lengths, so a scene scaled by any
//! factor has the same rows. Rows are made from the scene divided by its largest
//! coordinate (`Scene::for_rows`: in f64, from the vertices as described, then rounded
//! to f32), which is the same scene whatever the factor: so the rows are the same to
//! the bit, by a power of two (every f32 operation of the hit tests scales exactly) and
//! by any factor from 1e-6 to 1e6 (the quotients round to the same f32). Tested on the
//! cube and the Cornell box at six scales (patch sizes scaled alike); a scene's own
//! f32 coordinates, rounded at each scale, would move the cells whose rays pass within
//! rounding of an edge (one cell of one Cornell row, 6.7e-4 at 24 x 96, before rows
//! were made from the divided scene). The pipeline's property test draws the scale.

use rad_geometry::{scenes, PatchGrid, Scene, SceneDesc};
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, Row, Scan};

fn scaled(desc: &SceneDesc, s: f64) -> Scene {
    let mut d = desc.clone();
    for p in &mut d.polygons {
        for v in &mut p.vertices {
            *v *= s;
        }
        if let PatchGrid::Size(size) = &mut p.grid {
            *size *= s;
        }
    }
    Scene::new(d).unwrap()
}

/// The rows of every patch, made from the scene rows are made from.
fn rows(scene: &Scene, hemi: &Hemisphere) -> Vec<Row> {
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    compute_rows(scene.for_rows().unwrap(), &Scan, hemi, &all, &|_| {}).unwrap()
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
        let s = 2f64.powi(e);
        assert!(rows(&scaled(&desc, s), &hemi) == base, "scale 2^{e}");
    }
}

#[test]
fn rows_do_not_depend_on_the_scale_from_1e_minus_6_to_1e6() {
    // Bench scenes (boxes resting on floors: touching, not intersecting) at scales that
    // are not powers of two, so that every f32 product of the scene's own coordinates
    // rounds differently.
    let hemi = Hemisphere::new(HemisphereConfig::exact(24, 96)).unwrap();
    for (name, desc) in [
        ("cube", scenes::cube(4)),
        ("cornell", scenes::cornell_box(120.0)),
    ] {
        let base_scene = Scene::new(desc.clone()).unwrap();
        let base = rows(&base_scene, &hemi);
        for s in [1e-6, 3.7e-4, 0.1, 7.3, 1e3, 1e6] {
            let other = rows(&scaled(&desc, s), &hemi);
            let (entry, share) = differences(&base_scene, &base, &other);
            assert!(
                entry <= 1e-6 && share <= 1e-6,
                "{name} at {s:e}: an entry moved by {entry:e}, a polygon's share by {share:e}"
            );
            assert!(
                other == base,
                "{name} at {s:e}: not the same rows to the bit"
            );
        }
    }
}
