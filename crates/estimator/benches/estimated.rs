//! `hemisphere/estimated/{faithful,improved}/{cube,loft}/180x720` beside
//! `hemisphere/exact/{cube,loft}/180x720`, one thread, in the same run: the cost of one
//! estimated hemisphere against one exact hemisphere, over the same windows.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_estimator::{
    windows, Estimate, Estimator, EstimatorConfig, HoleFill, ImprovedEstimate, Mode, Reprojection,
    SourceHemisphere,
};
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer};
use std::hint::black_box;

const GRID: VoxelGridConfig = VoxelGridConfig::DEFAULT;

fn config(mode: Mode) -> EstimatorConfig {
    EstimatorConfig {
        mode,
        fill: HoleFill::RingNeighbour,
        reprojection: Reprojection::LATERAL_10,
        boundary_lists: false,
        max_real_ray_share: 0.05,
        // coherad's default (`rad_pipeline::default_estimator`).
        guess_stride: 3,
    }
}

fn bench(c: &mut Criterion) {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).expect("valid resolution");
    for (name, desc) in [("cube", cube(10)), ("loft", loft())] {
        let scene = Scene::new(desc).expect("bench scenes are valid");
        let grid = VoxelGrid::build(&scene, &GRID).expect("valid grid");
        let mut scratch = grid.new_scratch();
        // 16 windows spread over the scene, each with its source hemisphere.
        let all = windows(&scene);
        let picked: Vec<_> = (0..16)
            .map(|k| all[k * all.len() / 16].clone())
            .filter(|w| !w.estimated.is_empty())
            .collect();
        let sources: Vec<SourceHemisphere> = picked
            .iter()
            .map(|w| SourceHemisphere::cast(&scene, &grid, &hemi, w.centre, false, &mut scratch))
            .collect();
        let pairs: Vec<(usize, u32)> = picked
            .iter()
            .enumerate()
            .flat_map(|(k, w)| w.estimated.iter().map(move |&p| (k, p)))
            .collect();
        let mut group = c.benchmark_group("hemisphere");
        group.throughput(Throughput::Elements(hemi.n_cells() as u64));
        group.sample_size(30);
        let est = Estimator::new(&hemi);
        let mut k = 0;
        let mut buf = ItemBuffer::default();
        group.bench_function(
            BenchmarkId::from_parameter(format!("exact/{name}/180x720")),
            |b| {
                b.iter(|| {
                    k = (k + 1) % pairs.len();
                    hemi.cast(&scene, &grid, pairs[k].1, &mut scratch, &mut buf);
                    black_box(&buf);
                })
            },
        );
        // Output buffers reused, as the schedule reuses them (and as `buf` is).
        let (mut fe, mut ie) = (Estimate::default(), ImprovedEstimate::default());
        let faithful = config(Mode::Faithful);
        group.bench_function(
            BenchmarkId::from_parameter(format!("estimated/faithful/{name}/180x720")),
            |b| {
                b.iter(|| {
                    k = (k + 1) % pairs.len();
                    est.faithful(&scene, &sources[pairs[k].0], pairs[k].1, &faithful, &mut fe);
                    black_box(&fe);
                })
            },
        );
        let improved = config(Mode::Improved);
        group.bench_function(
            BenchmarkId::from_parameter(format!("estimated/improved/{name}/180x720")),
            |b| {
                b.iter(|| {
                    k = (k + 1) % pairs.len();
                    // An abandoned estimate (too many real rays) is cast exactly, as
                    // the schedule does: that is part of the mode's cost.
                    est.improved(
                        &scene,
                        &grid,
                        &sources[pairs[k].0],
                        pairs[k].1,
                        &improved,
                        &mut scratch,
                        &mut ie,
                    );
                    black_box(&ie);
                })
            },
        );
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
