//! `hemisphere/exact/{cube,loft}/180x720/{grid,brute,scan,hierarchy,facets}` and
//! `hemisphere/exact/{loft_patches,loft_triangles,loft_fine,blob_room}/180x720/{grid,scan,hierarchy,facets}`:
//! one exact hemisphere on
//! one thread, cycling over patches spread across the scene (so each call is on another
//! polygon than the last); throughput in rays (cells). And
//! `hemisphere/exact_row/{loft/180x720/scan,loft_fine/180x720/facets}`: the same with
//! the hemisphere's row summed from its item buffer, what the yardstick's Embree
//! `p16_full` times.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rad_accel::{BruteForce, VoxelGrid, VoxelGridConfig};
use rad_geometry::scenes::{
    blob_room, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
};
use rad_geometry::Scene;
use rad_hemisphere::{
    Caster, FacetScan, Hemisphere, HemisphereConfig, Hierarchy, ItemBuffer, RowAccumulator, Scan,
};
use std::hint::black_box;

/// The voxel grid of `rad_pipeline::default_grid` (rad-pipeline is not a dev-dependency here).
const GRID: VoxelGridConfig = VoxelGridConfig::DEFAULT;

fn spread(scene: &Scene, k: usize) -> Vec<u32> {
    let n = scene.patches().len();
    (0..k).map(|i| ((i * n) / k + n / (2 * k)) as u32).collect()
}

/// One exact hemisphere through `caster` (any [`Caster`]: the grid and brute force
/// through `RayCast`, or the polygon scan).
fn bench_caster<C: Caster>(
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
    let mut scratch = caster.scratch();
    let mut buf = ItemBuffer::default();
    let mut k = 0;
    group.bench_function(BenchmarkId::from_parameter(id), |b| {
        b.iter(|| {
            k = (k + 1) % patches.len();
            caster.item_buffer(scene, hemi, patches[k], &mut scratch, &mut buf);
            black_box(&buf);
        })
    });
    group.finish();
}

/// One exact hemisphere through `caster` and its row summed from the item buffer.
fn bench_row<C: Caster>(c: &mut Criterion, id: &str, scene: &Scene, caster: &C, samples: usize) {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).expect("valid resolution");
    let patches = spread(scene, 64);
    let mut group = c.benchmark_group("hemisphere/exact_row");
    group.throughput(Throughput::Elements(hemi.n_cells() as u64));
    group.sample_size(samples);
    let mut scratch = caster.scratch();
    let mut buf = ItemBuffer::default();
    let mut acc = RowAccumulator::new(scene.patches().len());
    let mut k = 0;
    group.bench_function(BenchmarkId::from_parameter(id), |b| {
        b.iter(|| {
            k = (k + 1) % patches.len();
            caster.item_buffer(scene, &hemi, patches[k], &mut scratch, &mut buf);
            black_box(hemi.row_from_items(patches[k], &buf, &mut acc));
        })
    });
    group.finish();
}

fn rows(c: &mut Criterion) {
    let scene = Scene::new(loft()).expect("bench scenes are valid");
    bench_row(c, "loft/180x720/scan", &scene, &Scan, 60);
    let scene = Scene::new(loft_fine_triangles()).expect("bench scenes are valid");
    bench_row(
        c,
        "loft_fine/180x720/facets",
        &scene,
        &FacetScan::new(&scene),
        10,
    );
}

/// The mesh scenes: every polygon a patch, thousands to 115,200 of them (grid, scan,
/// hierarchy and facet scan; brute force would take seconds a hemisphere).
fn meshes(c: &mut Criterion) {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).expect("valid resolution");
    for (name, desc) in [
        ("loft_patches", loft_patches()),
        ("loft_triangles", loft_triangles()),
        ("loft_fine", loft_fine_triangles()),
        ("blob_room", blob_room()),
    ] {
        let scene = Scene::new(desc).expect("bench scenes are valid");
        let grid = VoxelGrid::build(&scene, &GRID).expect("valid grid");
        bench_caster(c, &format!("{name}/180x720/grid"), &scene, &grid, &hemi, 10);
        bench_caster(c, &format!("{name}/180x720/scan"), &scene, &Scan, &hemi, 10);
        let tree = Hierarchy::new(&scene);
        bench_caster(
            c,
            &format!("{name}/180x720/hierarchy"),
            &scene,
            &tree,
            &hemi,
            10,
        );
        let facets = FacetScan::new(&scene);
        bench_caster(
            c,
            &format!("{name}/180x720/facets"),
            &scene,
            &facets,
            &hemi,
            10,
        );
    }
}

fn exact(c: &mut Criterion) {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).expect("valid resolution");
    for (name, desc) in [("cube", cube(10)), ("loft", loft())] {
        let scene = Scene::new(desc).expect("bench scenes are valid");
        let grid = VoxelGrid::build(&scene, &GRID).expect("valid grid");
        bench_caster(c, &format!("{name}/180x720/grid"), &scene, &grid, &hemi, 60);
        bench_caster(c, &format!("{name}/180x720/scan"), &scene, &Scan, &hemi, 60);
        let tree = Hierarchy::new(&scene);
        bench_caster(
            c,
            &format!("{name}/180x720/hierarchy"),
            &scene,
            &tree,
            &hemi,
            60,
        );
        bench_caster(
            c,
            &format!("{name}/180x720/facets"),
            &scene,
            &FacetScan::new(&scene),
            &hemi,
            60,
        );
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

criterion_group!(benches, exact, meshes, rows);
criterion_main!(benches);
