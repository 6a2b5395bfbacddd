//! Times one-thread estimated hemispheres against exact ones on a bench scene (best of
//! 3 passes): `cargo run --release -p rad-estimator --example estimate_timing -- loft`.

use rad_accel::{GridResolution, VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_estimator::{
    windows, Estimator, EstimatorConfig, HoleFill, Mode, Reprojection, SourceHemisphere,
    ThresholdTest,
};
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer};
use std::time::Instant;

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "loft".into());
    let scene = Scene::new(if name == "cube" { cube(10) } else { loft() }).unwrap();
    let grid = VoxelGrid::build(
        &scene,
        &VoxelGridConfig {
            resolution: GridResolution::Auto {
                density: 4.0,
                max_per_axis: 256,
            },
        },
    )
    .unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let mut s = grid.new_scratch();
    let all = windows(&scene);
    let picked: Vec<_> = (0..8).map(|k| all[k * all.len() / 8].clone()).collect();
    let sources: Vec<SourceHemisphere> = picked
        .iter()
        .map(|w| SourceHemisphere::cast(&scene, &grid, &hemi, w.centre, false, &mut s))
        .collect();
    let pairs: Vec<(usize, u32)> = picked
        .iter()
        .enumerate()
        .flat_map(|(k, w)| w.estimated.iter().map(move |&p| (k, p)))
        .collect();
    let cfg = |mode| EstimatorConfig {
        mode,
        fill: HoleFill::RingNeighbour,
        reprojection: Reprojection::FirstOrder {
            test: ThresholdTest::Lateral,
            threshold: 10.0,
        },
        boundary_lists: false,
        max_real_ray_share: 0.05,
    };
    let time = |f: &mut dyn FnMut(usize)| {
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t = Instant::now();
            for k in 0..pairs.len() {
                f(k);
            }
            best = best.min(t.elapsed().as_secs_f64() / pairs.len() as f64);
        }
        best * 1e3
    };
    let est = Estimator::new(&hemi);
    let mut buf = ItemBuffer::default();
    let exact = time(&mut |k| hemi.cast(&scene, &grid, pairs[k].1, &mut s, &mut buf));
    let (f, i) = (cfg(Mode::Faithful), cfg(Mode::Improved));
    let faithful = time(&mut |k| {
        std::hint::black_box(est.faithful(&scene, &sources[pairs[k].0], pairs[k].1, &f));
    });
    if std::env::var("ONLY").is_ok_and(|v| v == "faithful") {
        println!(
            "{name}: exact {exact:.2} ms, faithful {faithful:.2} ms ({:.3})",
            faithful / exact
        );
        return;
    }
    let improved = time(&mut |k| {
        std::hint::black_box(est.improved(
            &scene,
            &grid,
            &sources[pairs[k].0],
            pairs[k].1,
            &i,
            &mut s,
        ));
    });
    println!("{name}: exact {exact:.2} ms, faithful {faithful:.2} ms ({:.3}), improved {improved:.2} ms ({:.3})", faithful / exact, improved / exact);
}
