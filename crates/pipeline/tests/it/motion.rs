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
