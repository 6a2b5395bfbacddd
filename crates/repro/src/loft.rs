//! Checks on our loft: counts, closure, reciprocity, and the exact hemisphere's speed
//! (voxel grid against brute force, and the polygon scan, one thread).

use crate::reciprocity::{pairs, point_asymmetry, summarise, Reciprocity};
use crate::stats::Summary;
use crate::Error;
use rad_accel::{BruteForce, VoxelGrid};
use rad_core::RayCast;
use rad_geometry::scenes::loft;
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, ItemBuffer, Scan, ScanScratch};
use rad_pipeline::default_grid;
use serde::Serialize;
use std::time::Instant;

/// What the loft checks run.
#[derive(Clone, Debug, Serialize)]
pub struct LoftConfig {
    pub resolution: (u32, u32),
    /// Closure: rows of every `closure_stride`-th patch (200 patches at 72).
    pub closure_stride: usize,
    /// Reciprocity: rows of every `reciprocity_stride`-th patch.
    pub reciprocity_stride: usize,
    /// Timing: hemispheres cast on one thread with the grid, and with brute force.
    pub timed_grid: usize,
    pub timed_brute: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct Timing {
    pub method: &'static str,
    pub hemispheres: usize,
    pub rays_per_hemisphere: usize,
    pub median_seconds_per_hemisphere: f64,
    pub median_mrays_per_second: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct LoftChecks {
    pub config: LoftConfig,
    pub polygons: usize,
    pub patches: usize,
    pub grid_dims: [u32; 3],
    pub closure_rows: usize,
    /// Largest escaped and back form factor over the closure rows (0 in a closed,
    /// well-built scene), and the row sums.
    pub max_escaped: f64,
    pub max_back: f64,
    pub row_sum: Summary,
    pub reciprocity: Reciprocity,
    pub timing: Vec<Timing>,
    /// The scan's item buffers equal the grid's, cell for cell and bit for bit, on
    /// every hemisphere timed with the grid.
    pub scan_identical_to_grid: bool,
    /// (cell, polygon) tests per cell of the scan, over those hemispheres.
    pub scan_tests_per_cell: f64,
}

/// Median time of `fill` on each of `patches`, and the buffers it made.
fn time_hemispheres(
    patches: &[u32],
    mut fill: impl FnMut(u32, &mut ItemBuffer),
) -> (f64, Vec<ItemBuffer>) {
    let mut bufs = Vec::with_capacity(patches.len());
    let mut times: Vec<f64> = patches
        .iter()
        .map(|&p| {
            let mut buf = ItemBuffer::default();
            let t = Instant::now();
            fill(p, &mut buf);
            let dt = t.elapsed().as_secs_f64();
            bufs.push(buf);
            dt
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], bufs)
}

/// Median time of casting one hemisphere from each of `patches` through `caster`.
fn time_casts<C: RayCast>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    patches: &[u32],
) -> (f64, Vec<ItemBuffer>) {
    let mut scratch = caster.new_scratch();
    time_hemispheres(patches, |p, buf| {
        hemi.cast(scene, caster, p, &mut scratch, buf)
    })
}

/// Same bits in every cell (distances compared as bits: ∞ = ∞, and −0 ≠ 0).
fn same_items(a: &ItemBuffer, b: &ItemBuffer) -> bool {
    a.patch == b.patch
        && a.dist.len() == b.dist.len()
        && a.dist
            .iter()
            .zip(&b.dist)
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

pub fn loft_checks(
    config: &LoftConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<LoftChecks, Error> {
    let scene = Scene::new(loft())?;
    let grid = VoxelGrid::build(&scene, &default_grid())?;
    let (nt, np) = config.resolution;
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    let n = scene.patches().len();
    let closure: Vec<u32> = (0..n)
        .step_by(config.closure_stride)
        .map(|p| p as u32)
        .collect();
    let rows = compute_rows(&scene, &grid, &hemi, &closure, &|_| {})?;
    progress(1, 3);
    let max_escaped = rows.iter().map(|r| r.escaped).fold(0.0, f64::max);
    let max_back = rows.iter().map(|r| r.back).fold(0.0, f64::max);
    let row_sum = Summary::of(&rows.iter().map(|r| r.sum()).collect::<Vec<_>>());

    let subset: Vec<u32> = (0..n)
        .step_by(config.reciprocity_stride)
        .map(|p| p as u32)
        .collect();
    // (by scan: the grid's rows to the bit, faster)
    let rows = compute_rows(&scene, &Scan, &hemi, &subset, &|_| {})?;
    let reciprocity = summarise(
        &pairs(&scene, &rows, hemi.n_cells()),
        rows.len(),
        100.0,
        |i, j| point_asymmetry(&scene, i, j),
    );
    progress(2, 3);

    let spread =
        |k: usize| -> Vec<u32> { (0..k).map(|i| ((i * n) / k + n / (2 * k)) as u32).collect() };
    let rays = hemi.n_cells();
    let timing_of = |method, hemispheres, secs: f64| Timing {
        method,
        hemispheres,
        rays_per_hemisphere: rays,
        median_seconds_per_hemisphere: secs,
        median_mrays_per_second: rays as f64 / secs / 1e6,
    };
    let pool = crate::one_thread()?;
    let timed = spread(config.timed_grid);
    let (t_grid, t_brute, t_scan, identical, tests) = pool.install(|| {
        let (g, grid_bufs) = time_casts(&scene, &grid, &hemi, &timed);
        let b = time_casts(
            &scene,
            &BruteForce::new(&scene),
            &hemi,
            &spread(config.timed_brute),
        )
        .0;
        let mut ss = ScanScratch::default();
        let (s, scan_bufs) = time_hemispheres(&timed, |p, buf| hemi.scan(&scene, p, &mut ss, buf));
        let identical = grid_bufs
            .iter()
            .zip(&scan_bufs)
            .all(|(a, b)| same_items(a, b));
        let tests = ss.stats.tests as f64 / (ss.stats.hemispheres as f64 * rays as f64);
        (g, b, s, identical, tests)
    });
    progress(3, 3);
    Ok(LoftChecks {
        config: config.clone(),
        polygons: scene.polygons().len(),
        patches: n,
        grid_dims: grid.dims(),
        closure_rows: closure.len(),
        max_escaped,
        max_back,
        row_sum,
        reciprocity,
        timing: vec![
            timing_of("voxel grid, 1 thread", config.timed_grid, t_grid),
            timing_of("brute force, 1 thread", config.timed_brute, t_brute),
            timing_of("polygon scan, 1 thread", config.timed_grid, t_scan),
        ],
        scan_identical_to_grid: identical,
        scan_tests_per_cell: tests,
    })
}
