//! Estimates hemispheres at 180 × 720 (or RES=NθxNφ) in one mode, for instruction counts under
//! `valgrind --tool=callgrind`: `MODE=none|exact|faithful|improved SCENE=loft|cube [GUESS=3] [SHARE=0.05] [RES=90x360] cargo run
//! --release -p rad-repro --example profile_estimate`.

use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_estimator::{
    windows, Estimator, EstimatorConfig, HoleFill, Mode, Reprojection, SourceHemisphere,
};
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig};

fn main() {
    // MODE=exact casts the same hemispheres through the grid (the estimates' baseline);
    // MODE=none does only the set-up and the sources (to subtract from instruction
    // counts).
    let exact = std::env::var("MODE").as_deref() == Ok("exact");
    let none = std::env::var("MODE").as_deref() == Ok("none");
    let mode = match std::env::var("MODE").as_deref() {
        Ok("faithful") => Mode::Faithful,
        _ => Mode::Improved,
    };
    let mut exact_buf = rad_hemisphere::ItemBuffer::default();
    let config = EstimatorConfig {
        mode,
        fill: HoleFill::RingNeighbour,
        reprojection: Reprojection::LATERAL_10,
        boundary_lists: false,
        max_real_ray_share: std::env::var("SHARE").map_or(0.05, |s| s.parse().unwrap()),
        guess_stride: std::env::var("GUESS").map_or(3, |s| s.parse().unwrap()),
    };
    // RES=NθxNφ (180x720 unless given).
    let (n_theta, n_phi) = std::env::var("RES").map_or((180, 720), |r| {
        let (a, b) = r.split_once('x').expect("RES is NθxNφ");
        (a.parse().expect("a number"), b.parse().expect("a number"))
    });
    let hemi = Hemisphere::new(HemisphereConfig::exact(n_theta, n_phi)).expect("valid resolution");
    let scene = match std::env::var("SCENE").as_deref() {
        Ok("cube") => Scene::new(cube(10)),
        _ => Scene::new(loft()),
    }
    .expect("valid scene");
    let grid_cfg = VoxelGridConfig::DEFAULT;
    let grid = VoxelGrid::build(&scene, &grid_cfg).expect("valid grid");
    let mut scratch = grid.new_scratch();
    let all = windows(&scene);
    let est = Estimator::new(&hemi);
    let mut cells = 0usize;
    let mut seconds = 0.0;
    let windows_used: usize = std::env::var("WINDOWS")
        .map(|w| w.parse().unwrap())
        .unwrap_or(4);
    let (mut faithful, mut improved) = Default::default();
    let (mut tests, mut real, mut holes, mut n_est, mut abandoned) = (0, 0, 0, 0, 0);
    for k in 0..windows_used {
        let w = &all[(k * 509 + 100) % all.len()];
        let src = SourceHemisphere::cast(&scene, &grid, &hemi, w.centre, false, &mut scratch);
        for &p in &w.estimated {
            let t = std::time::Instant::now();
            let n = match mode {
                _ if none => 0,
                _ if exact => {
                    hemi.cast(&scene, &grid, p, &mut scratch, &mut exact_buf);
                    exact_buf.patch.len()
                }
                Mode::Faithful => {
                    est.faithful(&scene, &src, p, &config, &mut faithful);
                    faithful.items.patch.len()
                }
                Mode::Improved => {
                    // Abandoned estimates cast exactly, as the schedule and the bench do.
                    let outcome =
                        est.improved(&scene, &grid, &src, p, &config, &mut scratch, &mut improved);
                    tests += improved.tests;
                    real += improved.real_rays;
                    holes += improved.holes;
                    n_est += 1;
                    abandoned += usize::from(outcome == rad_estimator::Outcome::CastExactly);
                    improved.items.patch.len()
                }
            };
            seconds += t.elapsed().as_secs_f64();
            cells += n;
        }
    }
    if n_est > 0 {
        let per = |x: usize| x as f64 / n_est as f64 / hemi.n_cells() as f64;
        println!(
            "improved: {:.3} tests, {:.4} real rays, {:.3} holes a cell; {abandoned} of {n_est} cast exactly",
            per(tests),
            per(real),
            per(holes)
        );
    }
    println!(
        "{cells} cells estimated, {:.3} ms per estimate",
        1e3 * seconds / (cells as f64 / hemi.n_cells() as f64)
    );
}
