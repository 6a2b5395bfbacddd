//! The estimation-error experiment on a mesh scene's windows across polygons, through the
//! hierarchy: `cargo run --release -p rad-repro --example mesh_estimation -- loft_fine
//! 180x720 [STEP]` (every STEP-th window that estimates something; 200 unless given).
//! `IMPROVED=3:0.05,1:0.05` runs improved mode's default with those guess strides and
//! real-ray shares; `FAITHFUL=1` adds faithful mode.

use rad_estimator::{windows, Mode};
use rad_geometry::Scene;
use rad_hemisphere::Hierarchy;
use rad_repro::estimation::{estimation_of, EstimationJob, Setting};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("loft_fine", String::as_str);
    let (nt, np) = rad_pipeline::parse_resolution(args.get(2).map_or("180x720", String::as_str))
        .expect("resolution");
    let step: usize = args.get(3).map_or(200, |s| s.parse().expect("a step"));
    let desc = rad_repro::meshes::mesh_scene(name)
        .expect("a mesh scene: loft_patches, loft_triangles, loft_fine or blob_room");
    let scene = Scene::new(desc).expect("a valid scene");
    let t = std::time::Instant::now();
    let all = windows(&scene);
    let across = all.iter().filter(|w| !w.estimated.is_empty()).count();
    let sizes: usize = all.iter().map(|w| w.estimated.len() + 1).sum();
    println!(
        "{name}: {} windows ({across} estimating), {:.2} patches a window, schedule {:.2} s",
        all.len(),
        sizes as f64 / all.len() as f64,
        t.elapsed().as_secs_f64()
    );
    let wins: Vec<_> = all
        .into_iter()
        .filter(|w| !w.estimated.is_empty())
        .step_by(step)
        .collect();
    let mut settings: Vec<Setting> = std::env::var("IMPROVED")
        .unwrap_or_else(|_| "3:0.05".into())
        .split(',')
        .map(|item| {
            let (stride, share) = item.split_once(':').expect("stride:share");
            let mut config = rad_pipeline::default_estimator(Mode::Improved);
            config.guess_stride = stride.parse().expect("a stride");
            config.max_real_ray_share = share.parse().expect("a share");
            Setting {
                name: format!("improved, guesses /{stride}, real rays <= {share}"),
                config,
            }
        })
        .collect();
    if std::env::var("FAITHFUL").is_ok() {
        settings.push(Setting {
            name: "faithful".into(),
            config: rad_pipeline::default_estimator(Mode::Faithful),
        });
    }
    let t = std::time::Instant::now();
    let caster = Hierarchy::new(&scene);
    println!("hierarchy built in {:.2} s", t.elapsed().as_secs_f64());
    let job = EstimationJob {
        name,
        scene: &scene,
        resolution: (nt, np),
        with_lambert: false,
        settings: &settings,
    };
    let r = estimation_of(&job, &caster, wins, &|_, _| {}).expect("the experiment runs");
    println!(
        "{} {}x{}: {} exact, {} estimated; noise L1 mean {:.4} (per polygon {:.4})",
        r.scene,
        nt,
        np,
        r.exact_hemispheres,
        r.estimated_hemispheres,
        r.noise_l1.mean,
        r.noise_l1_polygon.mean,
    );
    for s in &r.results {
        println!(
            "{:40} L1 {:.4} med {:.4} max {:.3} within-noise {:5.1} % holes {:4.1} % real {:5.2} % fb {} {:.1}s",
            s.setting,
            s.l1.mean,
            s.l1.median,
            s.l1.max,
            100.0 * s.within_noise,
            100.0 * s.hole_fraction,
            100.0 * s.real_ray_fraction,
            s.fallback_exact,
            s.seconds
        );
    }
}
