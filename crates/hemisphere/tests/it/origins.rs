//! Rows averaged over several origins a patch: one origin is the centre's row, to the
//! bit; every caster gives the same averaged rows; a closed scene's rows still sum to 1.

use rad_geometry::{scenes, PatchGrid, Scene};
use rad_hemisphere::{
    compute_area_rows, compute_rows, Hemisphere, HemisphereConfig, Hierarchy, Scan,
};

#[test]
fn one_origin_is_the_centre_and_casters_agree_with_more() {
    let scene = Scene::new(scenes::cube(4)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(30, 120)).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    let centre = compute_rows(&scene, &Scan, &hemi, &all, &|_| {}).unwrap();
    assert_eq!(
        compute_area_rows(&scene, &Scan, &hemi, &all, 1, &|_| {}).unwrap(),
        centre
    );
    let tree = Hierarchy::new(&scene);
    for n in [2, 3] {
        let scan = compute_area_rows(&scene, &Scan, &hemi, &all, n, &|_| {}).unwrap();
        let hier = compute_area_rows(&scene, &tree, &hemi, &all, n, &|_| {}).unwrap();
        assert_eq!(scan, hier, "{n} origins");
        for (r, c) in scan.iter().zip(&centre) {
            assert!(
                (r.sum() - 1.0).abs() < 1e-9,
                "row {} sums to {}",
                r.patch,
                r.sum()
            );
            assert_eq!(r.escaped, 0.0);
            // Averaging moves the row, by less than it holds.
            let l1: f64 = (0..scene.patches().len() as u32)
                .map(|j| (r.get(j) - c.get(j)).abs())
                .sum();
            assert!(l1 > 0.0 && l1 < 0.5, "row {}: L1 {l1}", r.patch);
        }
    }
    assert!(compute_area_rows(&scene, &Scan, &hemi, &all, 0, &|_| {}).is_err());
}

#[test]
fn origins_spread_over_the_patch_by_area() {
    // A many-sided polygon's boundary patches: their origins lie in them and their
    // shares add up to 1; one origin is the patch's centre.
    let mut desc = scenes::cube(4);
    desc.polygons[0].vertices = (0..12)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / 12.0;
            glam::Vec3::new(0.5 + 0.5 * a.cos(), 0.0, 0.5 - 0.5 * a.sin()).as_dvec3()
        })
        .collect();
    desc.polygons[0].grid = PatchGrid::Cells { nu: 3, nv: 3 };
    desc.polygons.truncate(1);
    let scene = Scene::new(desc).unwrap();
    let poly = &scene.polygons()[0];
    for p in scene.patches() {
        assert_eq!(poly.patch_origins(p.cell, 1), vec![(p.center, 1.0)]);
        let pts = poly.patch_origins(p.cell, 4);
        assert!(!pts.is_empty() && pts.len() <= 16);
        let share: f64 = pts.iter().map(|q| q.1).sum();
        assert!((share - 1.0).abs() < 1e-12);
        // The area-weighted mean of the origins is the patch's centroid.
        let mean = pts
            .iter()
            .fold(glam::DVec3::ZERO, |m, q| m + q.0.as_dvec3() * q.1);
        assert!(
            (mean - p.center.as_dvec3()).length() < 1e-6,
            "{mean} vs {}",
            p.center
        );
    }
}
