//! Table 2's ratio on a part of the loft, one thread: thread-time per estimated row over
//! thread-time per exact row, through the schedule (`estimate_rows`), both modes, the
//! default settings (`GUESS=s` for another guess stride): `STRIDE=7 cargo run --release -p rad-repro --example schedule_cost`
//! (every STRIDE-th window, whole).

use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_estimator::{
    estimate_rows, windows, EstimatorConfig, HoleFill, Mode, Reprojection, Schedule,
};
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig};

fn main() {
    let stride: usize = std::env::var("STRIDE").map_or(7, |s| s.parse().unwrap());
    let share: f64 = std::env::var("SHARE").map_or(0.05, |s| s.parse().unwrap());
    let scene = match std::env::var("SCENE").as_deref() {
        Ok("cube") => Scene::new(cube(10)),
        _ => Scene::new(loft()),
    }
    .unwrap();
    let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let patches: Vec<u32> = windows(&scene)
        .iter()
        .step_by(stride)
        .flat_map(|w| std::iter::once(w.centre).chain(w.estimated.iter().copied()))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for mode in [Mode::Faithful, Mode::Improved] {
        let config = EstimatorConfig {
            mode,
            fill: HoleFill::RingNeighbour,
            reprojection: Reprojection::LATERAL_10,
            boundary_lists: false,
            max_real_ray_share: share,
            guess_stride: std::env::var("GUESS").map_or(3, |s| s.parse().unwrap()),
        };
        let (_, s) = pool
            .install(|| {
                estimate_rows(
                    &scene,
                    &grid,
                    &hemi,
                    &config,
                    &Schedule::of(&scene),
                    &patches,
                    &|_| {},
                )
            })
            .unwrap();
        let exact = s.exact_seconds / s.exact as f64;
        let est = s.estimate_seconds / (s.estimated + s.fallback_exact) as f64;
        println!(
            "{mode:?}: {} exact at {:.2} ms, {} estimated ({} fallback) at {:.2} ms: ratio {:.3}, {:.0} real rays each",
            s.exact,
            1e3 * exact,
            s.estimated + s.fallback_exact,
            s.fallback_exact,
            1e3 * est,
            est / exact,
            s.real_rays as f64 / (s.estimated + s.fallback_exact) as f64
        );
    }
}
