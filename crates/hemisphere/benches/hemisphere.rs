//! `hemisphere/exact/{cube,loft}/180x720/{grid,brute,scan}`: one exact hemisphere on
//! one thread, cycling over patches spread across the scene (so each call is on another
//! polygon than the last); throughput in rays (cells).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rad_accel::{BruteForce, VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, ItemBuffer, ScanScratch};
use std::hint::black_box;

/// The voxel grid of `rad_pipeline::default_grid` (rad-pipeline is not a dev-dependency here).
const GRID: VoxelGridConfig = VoxelGridConfig::DEFAULT;

fn spread(scene: &Scene, k: usize) -> Vec<u32> {
    let n = scene.patches().len();
    (0..k).map(|i| ((i * n) / k + n / (2 * k)) as u32).collect()
}

fn bench_caster<C: RayCast>(
    c: &mut Criterion,
    id: &str,
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    samples: usize,
) {
    let patches = spread(scene, 64);
    let mut group = c.benchmark_group("hemisphere/exact");
    group.throughput(Throughput::Elements(hemi.n_cells() as u64));
    group.sample_size(samples);
    let mut scratch = caster.new_scratch();
    let mut buf = ItemBuffer::default();
    let mut k = 0;
    group.bench_function(BenchmarkId::from_parameter(id), |b| {
        b.iter(|| {
            k = (k + 1) % patches.len();
            hemi.cast(scene, caster, patches[k], &mut scratch, &mut buf);
            black_box(&buf);
        })
    });
    group.finish();
}

/// The polygon scan ([`Hemisphere::scan`]): the same item buffers as the grid's.
fn bench_scan(c: &mut Criterion, id: &str, scene: &Scene, hemi: &Hemisphere) {
    let patches = spread(scene, 64);
    let mut group = c.benchmark_group("hemisphere/exact");
    group.throughput(Throughput::Elements(hemi.n_cells() as u64));
    group.sample_size(60);
    let mut scratch = ScanScratch::default();
    let mut buf = ItemBuffer::default();
    let mut k = 0;
    group.bench_function(BenchmarkId::from_parameter(id), |b| {
        b.iter(|| {
            k = (k + 1) % patches.len();
            hemi.scan(scene, patches[k], &mut scratch, &mut buf);
            black_box(&buf);
        })
    });
    group.finish();
}

fn exact(c: &mut Criterion) {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).expect("valid resolution");
    for (name, desc) in [("cube", cube(10)), ("loft", loft())] {
        let scene = Scene::new(desc).expect("bench scenes are valid");
        let grid = VoxelGrid::build(&scene, &GRID).expect("valid grid");
        bench_caster(c, &format!("{name}/180x720/grid"), &scene, &grid, &hemi, 60);
        bench_scan(c, &format!("{name}/180x720/scan"), &scene, &hemi);
        bench_caster(
            c,
            &format!("{name}/180x720/brute"),
            &scene,
            &BruteForce::new(&scene),
            &hemi,
            10,
        );
    }
}

criterion_group!(benches, exact);
criterion_main!(benches);
