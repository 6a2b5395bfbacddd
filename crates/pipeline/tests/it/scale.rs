//! Rows do not depend on the scene's scale: a scene scaled by any factor
//! from 1e-6 to 1e6, as a file would give it (its coordinates multiplied in f64, its
//! patch size alike), two-sided polygons among them, gets the same rows within 1e-6 an
//! entry, by every caster and estimated (they are made from the scene divided by its largest coordinate,
//! `Scene::for_rows`, the same scene whatever the factor).

use proptest::prelude::*;
use rad_geometry::{scenes, PatchGrid, Scene, SceneDesc};
use rad_pipeline::{rows, Hemisphere, HemisphereConfig, RowMethod};

fn scaled(desc: &SceneDesc, s: f64) -> SceneDesc {
    let mut d = desc.clone();
    for p in &mut d.polygons {
        for v in &mut p.vertices {
            *v *= s;
        }
        if let PatchGrid::Size(size) = &mut p.grid {
            *size *= s;
        }
    }
    d
}

/// The largest difference of an entry (the escaped and back shares too) between two
/// sets of rows of the same patches.
fn largest_difference(a: &rad_pipeline::Rows, b: &rad_pipeline::Rows, n: usize) -> f64 {
    let mut dense = vec![0.0f64; n];
    let mut most = 0.0f64;
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        dense.iter_mut().for_each(|x| *x = 0.0);
        ra.entries.iter().for_each(|&(j, f)| dense[j as usize] += f);
        rb.entries.iter().for_each(|&(j, f)| dense[j as usize] -= f);
        most = dense.iter().fold(most, |m, x| m.max(x.abs()));
        most = most
            .max((ra.escaped - rb.escaped).abs())
            .max((ra.back - rb.back).abs());
    }
    most
}

/// The unit cube (faces outward-cut 2 x 2) with a two-sided regular hexagon inside,
/// cut by a patch size: its back's own (u, v) frame runs along another edge than its
/// front's, so the back is cut by its own sides.
fn cube_with_hexagon() -> SceneDesc {
    let mut desc = scenes::cube(2);
    let mut hexagon = desc.polygons[0].clone();
    hexagon.name = "hexagon".into();
    hexagon.vertices = (0..6)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 6.0;
            glam::DVec3::new(0.5 + 0.3 * a.cos(), 0.45, 0.5 + 0.3 * a.sin())
        })
        .collect();
    hexagon.grid = PatchGrid::Size(0.05);
    hexagon.two_sided = true;
    desc.polygons.push(hexagon);
    desc
}

fn scene_to_scale() -> impl Strategy<Value = SceneDesc> {
    prop_oneof![
        Just(scenes::cube(3)),
        Just(scenes::cornell_box(150.0)),
        Just(cube_with_hexagon()),
        (rad_testkit::random_scene(8), rad_testkit::two_sided_flags())
            .prop_map(|(desc, sides)| rad_testkit::with_two_sided(desc, &sides)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]
    #[test]
    fn rows_do_not_depend_on_the_scale_from_1e_minus_6_to_1e6(
        desc in scene_to_scale(),
        exponent in -6.0f64..=6.0,
        method in prop_oneof![
            Just("exact/scan"),
            Just("exact/hierarchy"),
            Just("exact/grid"),
            Just("estimated/improved/hierarchy"),
            Just("estimated/faithful"),
        ],
    ) {
        // (Random polygons may overlap: such a scene is refused at every scale.)
        let base = Scene::new(desc.clone());
        prop_assume!(base.is_ok());
        let base = base.unwrap();
        let s = 10f64.powf(exponent);
        let other = Scene::new(scaled(&desc, s)).unwrap();
        let hemi = Hemisphere::new(HemisphereConfig::exact(24, 96)).unwrap();
        let method: RowMethod = method.parse().unwrap();
        let all: Vec<u32> = (0..base.patches().len() as u32).collect();
        let a = rows(&base, &hemi, method, &all, &|_| {}).unwrap();
        let b = rows(&other, &hemi, method, &all, &|_| {}).unwrap();
        let most = largest_difference(&a, &b, all.len());
        prop_assert!(most <= 1e-6, "scale {:e}: an entry moved by {:e}", s, most);
    }
}
