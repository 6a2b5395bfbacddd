//! View factors over a motion: each step's the very factors a whole run gives that
//! step's scene (in the motion's unit), to the bit, by polygon in closed form and from
//! hemispheres; a step re-casts a share of the cells only; bad motions are refused by
//! step and group.

use rad_geometry::{scenes, Motion, Scene};
use rad_pipeline::viewfactors::{
    view_factors, view_factors_over_motion, Grouping, ViewFactorConfig, ViewFactorMethod,
};
use rad_pipeline::{Hemisphere, HemisphereConfig};

fn steps_match(
    desc: &rad_geometry::SceneDesc,
    motion: &Motion,
    opts_of: impl Fn(&Scene) -> ViewFactorConfig,
) -> Vec<f64> {
    let cut = Scene::new(desc.clone()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(20, 80)).unwrap();
    let opts = opts_of(&cut);
    let unit = motion.unit(desc);
    let mut shares = Vec::new();
    view_factors_over_motion(desc, &cut, motion, &hemi, &opts, &|_, _| {}, &mut |s| {
        let scene = motion.step_scene(desc, &cut, s.step, unit).unwrap();
        let whole = view_factors(&scene, &hemi, &opts, &|_| {}).unwrap();
        assert_eq!(s.vf.matrix.rows, whole.matrix.rows, "step {}", s.step);
        assert_eq!(s.vf.matrix.area, whole.matrix.area);
        assert_eq!(s.vf.escaped, whole.escaped);
        assert_eq!(s.vf.back, whole.back);
        assert_eq!(s.vf.names, whole.names);
        shares.push(s.recast.cast_share());
        Ok(())
    })
    .unwrap();
    shares
}

#[test]
fn a_turning_satellite_gives_each_step_s_own_factors() {
    let desc = scenes::satellite();
    let mut motion = scenes::satellite_motion(36);
    motion.steps.truncate(3);
    for method in [ViewFactorMethod::Hemisphere, ViewFactorMethod::Auto] {
        let shares = steps_match(&desc, &motion, |s| ViewFactorConfig {
            by: Grouping::Group,
            method,
            origins: 1,
            ..ViewFactorConfig::for_scene(s)
        });
        assert_eq!(shares.len(), 3);
        assert!(shares[1] < 0.9 && shares[2] < 0.9, "{method:?}: {shares:?}");
    }
}

#[test]
fn a_sliding_cart_recasts_a_small_share() {
    let desc = scenes::room_with_cart(0.5);
    let mut motion = scenes::cart_motion(10);
    motion.steps.truncate(3);
    let shares = steps_match(&desc, &motion, |s| ViewFactorConfig {
        method: ViewFactorMethod::Hemisphere,
        origins: 2,
        ..ViewFactorConfig::for_scene(s)
    });
    assert_eq!(shares[0], 1.0);
    // (The cart holds 1.5 % of the area; the patches near it, which would cast over 5 %
    // of their cells again, are cast whole by the scan, and count whole.)
    assert!(shares[1] < 0.2 && shares[2] < 0.2, "{shares:?}");
}

#[test]
fn a_motion_naming_an_unknown_group_is_refused() {
    let desc = scenes::satellite();
    let cut = Scene::new(desc.clone()).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(4, 16)).unwrap();
    let motion = Motion::parse(
        r#"{"steps": [{"groups": {"bus": {}}}, {"name": "deploy", "groups": {"boom": {"translate": [0, 0, 1]}}}]}"#,
        std::path::Path::new("m.json"),
    )
    .unwrap();
    let opts = ViewFactorConfig::for_scene(&cut);
    let mut steps = 0;
    let e = view_factors_over_motion(&desc, &cut, &motion, &hemi, &opts, &|_, _| {}, &mut |_| {
        steps += 1;
        Ok(())
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("step 1") && e.contains("\"deploy\"") && e.contains("\"boom\""),
        "{e}"
    );
    assert_eq!(steps, 0, "checked before any step is made");
}

/// A motion's solves: each step's rows those of the step's scene made whole (the warm
/// start given the same rows gives the very radiosities), the first step a cold solve
/// to the bit, the later ones warm and within the tolerance of a cold solve in fewer
/// sweeps.
#[test]
fn a_sliding_cart_is_solved_step_by_step_from_the_step_before() {
    use rad_pipeline::solve::SceneSolveConfig;
    use rad_pipeline::solve::{solve_over_motion, solve_pairs, solve_pairs_from, surfaces};
    use rad_pipeline::{CasterKind, RowMethod, SceneFile};
    use rad_solver::PairBuilder;
    let desc = scenes::room_with_cart(0.5);
    let mut motion = scenes::cart_motion(10);
    motion.steps.truncate(3);
    let file = SceneFile::of_scene("room_cart.json", Scene::new(desc.clone()).unwrap());
    let hemi = Hemisphere::new(HemisphereConfig::exact(20, 80)).unwrap();
    let opts = SceneSolveConfig::default();
    let unit = motion.unit(&desc);
    let caster = CasterKind::Scan;
    let mut before: Option<Vec<[f64; 3]>> = None;
    let mut seen = 0;
    solve_over_motion(
        (&file, &desc),
        &motion,
        &hemi,
        caster,
        &opts,
        &|_, _| {},
        &mut |s| {
            let scene = motion.step_scene(&desc, &file.scene, s.step, unit).unwrap();
            let n = scene.patches().len() as u32;
            let all: Vec<u32> = (0..n).collect();
            let made =
                rad_pipeline::rows(&scene, &hemi, RowMethod::Exact { caster }, &all, &|_| {})
                    .unwrap();
            let mut b = PairBuilder::new(n as usize);
            for r in &made.rows {
                b.push_row(r.patch, &r.entries).unwrap();
            }
            let whole = b.finish().unwrap();
            let surf = surfaces(&scene);
            let cold = solve_pairs(&whole, &surf, &opts).unwrap();
            let got = &s.solved.solution;
            assert_eq!(s.warm, s.step > 0);
            if s.step == 0 {
                assert_eq!(got.radiosity, cold.solution.radiosity);
            } else {
                let again = solve_pairs_from(&whole, &surf, &opts, before.clone()).unwrap();
                assert_eq!(got.radiosity, again.solution.radiosity, "step {}", s.step);
                assert!(got.report.converged);
                assert!(
                    got.report.iterations < cold.solution.report.iterations,
                    "step {}: warm {} sweeps, cold {}",
                    s.step,
                    got.report.iterations,
                    cold.solution.report.iterations
                );
                let top = cold
                    .solution
                    .radiosity
                    .iter()
                    .flatten()
                    .fold(0.0f64, |m, v| m.max(*v));
                for (w, c) in got.radiosity.iter().zip(&cold.solution.radiosity) {
                    for k in 0..3 {
                        assert!((w[k] - c[k]).abs() <= 1e-7 * top, "{w:?} vs {c:?}");
                    }
                }
            }
            assert!(s.solved.balance.relative_imbalance < 1e-6);
            assert!(
                s.file.scene.contains(&format!("at step {}", s.step)),
                "{}",
                s.file.scene
            );
            before = Some(got.radiosity.clone());
            seen += 1;
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(seen, 3);
    // The storages that make rows anew are refused, by name.
    let matrix_free = SceneSolveConfig {
        storage: Some(rad_pipeline::Storage::MatrixFree),
        ..SceneSolveConfig::default()
    };
    let e = solve_over_motion(
        (&file, &desc),
        &motion,
        &hemi,
        caster,
        &matrix_free,
        &|_, _| {},
        &mut |_| Ok(()),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("matrix-free") && e.contains("--storage stored"),
        "{e}"
    );
}
