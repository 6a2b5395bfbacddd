//! Runs the estimation-error experiment on one scene and prints a line per setting:
//! `cargo run --release -p rad-repro --example estimation -- cube 180x720 [quick]`
//! (`ONLY=improved` keeps the settings whose name holds that text;
//! `IMPROVED=3:0.05,3:1` runs improved mode's default with those guess strides and
//! real-ray shares instead; the loft's windows are those of the reproduction's
//! polygons).

use rad_estimator::Mode;
use rad_geometry::scenes::{cube, loft};
use rad_geometry::Scene;
use rad_repro::estimation::{scene_estimation, settings, Setting};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene_name = args.get(1).map_or("cube", String::as_str);
    let (nt, np) = rad_pipeline::parse_resolution(args.get(2).map_or("180x720", String::as_str))
        .expect("resolution");
    let quick = args.get(3).is_some_and(|a| a == "quick");
    let (scene, polys): (Scene, Option<Vec<u32>>) = match scene_name {
        "cube" => (Scene::new(cube(10)).unwrap(), None),
        _ => (Scene::new(loft()).unwrap(), Some(vec![4, 52, 91, 130, 182])),
    };
    let r = scene_estimation(
        scene_name,
        &scene,
        (nt, np),
        polys.as_deref(),
        scene_name == "cube",
        &std::env::var("IMPROVED").map_or_else(
            |_| {
                settings(quick)
                    .into_iter()
                    .filter(|s| std::env::var("ONLY").map_or(true, |o| s.name.contains(&o)))
                    .collect::<Vec<_>>()
            },
            |list| {
                // IMPROVED=stride:share,...: improved mode's default with these.
                list.split(',')
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
                    .collect()
            },
        ),
        &|_, _| {},
    )
    .unwrap();
    println!(
        "{} {}x{}: {} exact, {} estimated; noise L1 mean {:.4} rel mean {:.2} %",
        r.scene,
        nt,
        np,
        r.exact_hemispheres,
        r.estimated_hemispheres,
        r.noise_l1.mean,
        100.0 * r.noise_rel.mean
    );
    for s in &r.results {
        println!(
            "{:48} rel {:6.2} % (in {:5.2} edge {:5.2}) lam {:6.2} L1 {:.4} med {:.4} within-noise {:5.1} % holes {:4.1} % real {:5.2} % fb {} {:.1}s",
            s.setting,
            100.0 * s.rel_error.mean,
            100.0 * s.rel_error_interior.mean,
            100.0 * s.rel_error_edge.mean,
            s.rel_error_vs_lambert.map_or(f64::NAN, |l| 100.0 * l.mean),
            s.l1.mean,
            s.l1.median,
            100.0 * s.within_noise,
            100.0 * s.hole_fraction,
            100.0 * s.real_ray_fraction,
            s.fallback_exact,
            s.seconds
        );
    }
}
