//! `render/<scene>/640x480/<caster>`: the loft from its camera, 640 × 480, 2 × 2 rays a
//! pixel, smooth shading, on one thread: the 185-polygon loft and the same room as
//! 115,200 triangles (`loft_fine`), each through the voxel grid (the way the loft was
//! rendered before), the hierarchy's tree, the wide BVH, and `FacetRays` (what
//! `render_image` uses for both at this size: its facets binned by direction from the
//! camera, within each render); every patch given a radiosity by its id, so that
//! shading does real work.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rad_accel::VoxelGrid;
use rad_geometry::scenes::{loft, loft_fine_triangles};
use rad_geometry::Scene;
use rad_hemisphere::Hierarchy;
use rad_pipeline::{default_grid, RenderConfig, Shading, View};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a thread pool");
    let config = RenderConfig {
        samples: 2,
        shading: Shading::Smooth,
    };
    let mut group = c.benchmark_group("render");
    group.sample_size(10);
    group.throughput(Throughput::Elements(640 * 480));
    for (name, desc) in [("loft", loft()), ("loft_fine", loft_fine_triangles())] {
        let scene = Scene::new(desc).expect("bench scenes are valid");
        let view = View::of_scene(&scene, 640, 480).expect("the loft has a camera");
        let b: Vec<[f64; 3]> = (0..scene.patches().len())
            .map(|k| [(k % 7) as f64, (k % 11) as f64, (k % 13) as f64])
            .collect();
        let grid = VoxelGrid::build(&scene, &default_grid()).expect("a grid");
        let tree = Hierarchy::new(&scene);
        let rays = tree.rays(&scene);
        let wide = rad_accel::WideBvh::new(&scene);
        let facets = rad_hemisphere::FacetRays::new(&scene, rad_accel::WideTree::new);
        group.bench_function(
            BenchmarkId::from_parameter(format!("{name}/640x480/grid")),
            |bench| {
                bench.iter(|| {
                    pool.install(|| {
                        black_box(rad_render::render(&scene, &grid, &view, &b, &config))
                    })
                })
            },
        );
        group.bench_function(
            BenchmarkId::from_parameter(format!("{name}/640x480/hierarchy")),
            |bench| {
                bench.iter(|| {
                    pool.install(|| {
                        black_box(rad_render::render(&scene, &rays, &view, &b, &config))
                    })
                })
            },
        );
        group.bench_function(
            BenchmarkId::from_parameter(format!("{name}/640x480/wide")),
            |bench| {
                bench.iter(|| {
                    pool.install(|| {
                        black_box(rad_render::render(&scene, &wide, &view, &b, &config))
                    })
                })
            },
        );
        group.bench_function(
            BenchmarkId::from_parameter(format!("{name}/640x480/facets")),
            |bench| {
                bench.iter(|| {
                    pool.install(|| {
                        black_box(rad_render::render(&scene, &facets, &view, &b, &config))
                    })
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
