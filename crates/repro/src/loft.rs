//! Checks on our loft: counts, closure, reciprocity, and the exact hemisphere's speed
//! (voxel grid against brute force, one thread).

use crate::reciprocity::{pairs, point_asymmetry, summarise, Reciprocity};
use crate::stats::Summary;
use crate::{default_grid, Error};
use rad_accel::{BruteForce, VoxelGrid};
use rad_core::RayCast;
use rad_geometry::scenes::loft;
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, ItemBuffer};
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
}

/// Median time of casting one hemisphere from each of `patches`, one thread.
fn time_hemispheres<C: RayCast>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    patches: &[u32],
) -> f64 {
    let mut scratch = caster.new_scratch();
    let mut buf = ItemBuffer::default();
    let mut times: Vec<f64> = patches
        .iter()
        .map(|&p| {
            let t = Instant::now();
            hemi.cast(scene, caster, p, &mut scratch, &mut buf);
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
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
    let rows = compute_rows(&scene, &grid, &hemi, &subset, &|_| {})?;
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
    let (t_grid, t_brute) = pool.install(|| {
        let g = time_hemispheres(&scene, &grid, &hemi, &spread(config.timed_grid));
        let b = time_hemispheres(
            &scene,
            &BruteForce::new(&scene),
            &hemi,
            &spread(config.timed_brute),
        );
        (g, b)
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
        ],
    })
}
