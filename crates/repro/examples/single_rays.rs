//! Single rays (improved estimation's real rays, rendering) through the hierarchy's own
//! binary tree and through `rad_accel::WideBvh` (`obvhs`'s eight-wide compressed BVH,
//! PLOC build, with our hit test and tie rule deciding), and through `FacetRays` (the
//! same BVH over facets), on the same rays: build time, rays a second on one thread,
//! and whether the closest hits agree to the bit.
//! `cargo run --release -p rad-repro --example single_rays`.

use glam::Vec3;
use rad_accel::WideBvh;
use rad_core::{Hit, Ray, RayCast};
use rad_geometry::scenes::{blob_room, loft, loft_fine_triangles, loft_triangles};
use rad_geometry::Scene;
use rad_hemisphere::{FacetRays, Hierarchy};
use std::time::Instant;

/// 200,000 rays from patch centres into their hemispheres (a fixed pseudo-random set).
fn rays(scene: &Scene) -> Vec<Ray> {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f32 / (1u64 << 53) as f32 * 2.0 - 1.0
    };
    let n = scene.patches().len();
    (0..200_000)
        .map(|_| {
            let p = &scene.patches()[((next() * 0.5 + 0.5) * (n - 1) as f32) as usize];
            let normal = scene.polygons()[p.polygon as usize].normal();
            let d = loop {
                let d = Vec3::new(next(), next(), next());
                if d.length() > 0.2 && d.length() <= 1.0 && d.dot(normal).abs() > 1e-3 {
                    break d.normalize();
                }
            };
            let mut ray = Ray::new(p.center, if d.dot(normal) > 0.0 { d } else { -d });
            ray.skip = p.polygon;
            ray
        })
        .collect()
}

/// Build time (ms), and the closest hits of `rays` with their rate (Mrays/s).
fn run<R: RayCast>(build: impl FnOnce() -> R, rays: &[Ray]) -> (f64, Vec<Option<Hit>>, f64) {
    let t = Instant::now();
    let caster = build();
    let built = t.elapsed().as_secs_f64() * 1e3;
    let mut scratch = caster.new_scratch();
    let t = Instant::now();
    let hits: Vec<Option<Hit>> = rays
        .iter()
        .map(|r| caster.closest_hit(r, &mut scratch))
        .collect();
    let rate = rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6;
    (built, hits, rate)
}

fn main() {
    for (name, desc) in [
        ("loft", loft()),
        ("loft_triangles", loft_triangles()),
        ("blob_room", blob_room()),
        ("loft_fine", loft_fine_triangles()),
    ] {
        let scene = Scene::new(desc).unwrap();
        let rays = rays(&scene);
        let tree = Hierarchy::new(&scene);
        let (own_build, own, own_rate) = run(|| tree.rays(&scene), &rays);
        // (The tree was built outside the closure: time its build alone.)
        let t = Instant::now();
        let _ = Hierarchy::new(&scene);
        let own_build = own_build + t.elapsed().as_secs_f64() * 1e3;
        let (wide_build, wide, wide_rate) = run(|| WideBvh::new(&scene), &rays);
        let (facet_build, facets, facet_rate) =
            run(|| FacetRays::new(&scene, rad_accel::WideTree::new), &rays);
        let differ = own.iter().zip(&wide).filter(|(a, b)| a != b).count();
        let differ_facets = own.iter().zip(&facets).filter(|(a, b)| a != b).count();
        println!(
            "{name}: {} polygons; build: hierarchy {own_build:.1} ms, wide BVH {wide_build:.1} ms, facets {facet_build:.1} ms; rays: hierarchy {own_rate:.2} Mrays/s, wide BVH {wide_rate:.2} Mrays/s, facets {facet_rate:.2} Mrays/s; {differ} (wide), {differ_facets} (facets) of {} closest hits differ",
            scene.polygons().len(),
            rays.len()
        );
    }
}
