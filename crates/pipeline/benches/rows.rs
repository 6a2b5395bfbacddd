//! `rows/<method>/loft/45x180`: the rows of whole windows of the loft (about 180
//! patches), by every [`RowMethod`], named by its stable name, on one thread; the same
//! rows whatever the method's caster.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rad_estimator::windows;
use rad_geometry::scenes::loft;
use rad_geometry::Scene;
use rad_pipeline::{rows, Hemisphere, HemisphereConfig, RowMethod};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let scene = Scene::new(loft()).expect("the loft is valid");
    let hemi = Hemisphere::new(HemisphereConfig::exact(45, 180)).expect("valid resolution");
    // Whole windows spread over the loft, so that estimated rows have their centres.
    let all = windows(&scene);
    let patches: Vec<u32> = all
        .iter()
        .step_by(all.len() / 20)
        .flat_map(|w| std::iter::once(w.centre).chain(w.estimated.iter().copied()))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a thread pool");
    let mut group = c.benchmark_group("rows");
    group.throughput(Throughput::Elements(patches.len() as u64));
    group.sample_size(10);
    for method in RowMethod::all() {
        let id = format!("{}/loft/45x180", method.name());
        group.bench_function(BenchmarkId::from_parameter(id), |b| {
            b.iter(|| pool.install(|| black_box(rows(&scene, &hemi, method, &patches, &|_| {}))))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
