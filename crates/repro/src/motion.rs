//! Moving geometry: what a step of a motion costs against a whole computation of that
//! step, in one run, one thread, and whether the two are equal to the bit; the share of
//! cells cast again; the cost against the moving share of the area (a cube cart of
//! growing side in a room). motion.json and the report's section.

use crate::Error;
use rad_geometry::scenes::{
    blob_room, cart_motion, room_with_cart, satellite, satellite_motion, slide, with_cart,
};
use rad_geometry::{Motion, Scene, SceneDesc};
use rad_pipeline::viewfactors::{
    view_factors, view_factors_over_motion, Grouping, ViewFactorConfig, ViewFactorMethod,
};
use rad_pipeline::{Hemisphere, HemisphereConfig};
use serde::Serialize;
use std::time::Instant;

/// One step, both ways.
#[derive(Clone, Debug, Serialize)]
pub struct StepCost {
    pub step: usize,
    pub incremental_seconds: f64,
    pub whole_seconds: f64,
    /// Cells cast again (a whole patch's all) over every cell of the step's rows.
    pub cast_share: f64,
    pub patches_whole: usize,
    pub patches_in_part: usize,
    /// The step's factors equal the whole computation's, to the bit.
    pub identical: bool,
}

/// One moving scene.
#[derive(Clone, Debug, Serialize)]
pub struct MotionCase {
    pub scene: String,
    pub patches: usize,
    /// The moving groups' share of the area.
    pub moving_share: f64,
    pub steps: Vec<StepCost>,
    /// The median of incremental over whole over the steps after the first.
    pub median_ratio: f64,
    /// Bytes of item buffers and rows kept between steps (the last step's).
    pub kept_bytes: usize,
}

#[derive(Clone, Debug, Serialize)]
pub struct MotionCost {
    pub resolution: [u32; 2],
    pub origins: u32,
    pub cases: Vec<MotionCase>,
}

/// The scenes, their motions, the moving groups' prefix and the steps run.
fn cases(quick: bool) -> Vec<(String, SceneDesc, Motion, &'static str, usize)> {
    let mut out = vec![(
        "satellite (arrays turning 10 degrees a step)".to_string(),
        satellite(),
        satellite_motion(36),
        "array",
        if quick { 3 } else { 6 },
    )];
    let sides: &[f32] = if quick {
        &[0.5]
    } else {
        &[0.25, 0.5, 1.0, 1.5]
    };
    for &side in sides {
        out.push((
            format!("room, 19 polygons, cart of {side} m"),
            room_with_cart(side),
            cart_motion(10),
            "cart",
            if quick { 3 } else { 4 },
        ));
    }
    if !quick {
        let blob = with_cart(blob_room(), glam::Vec3::new(0.3, 0.01, 0.3), 0.5, 0);
        out.push((
            "blob room, 20,480 curved triangles, cart of 0.5 m".to_string(),
            blob,
            slide("cart", glam::DVec3::new(2.5, 0.0, 0.0), 10),
            "cart",
            3,
        ));
    }
    out
}

/// Runs every case on one thread.
pub fn run(
    quick: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<MotionCost, Error> {
    let (nt, np) = if quick { (30, 120) } else { (180, 720) };
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(Error::from)?;
    let origins = 1;
    let pool = crate::one_thread()?;
    let all = cases(quick);
    let n = all.len();
    let mut out = Vec::new();
    for (k, (name, desc, mut motion, moving, steps)) in all.into_iter().enumerate() {
        progress("motion", k, n);
        motion.steps.truncate(steps);
        let case = pool.install(|| measure(&name, &desc, &motion, moving, &hemi, origins, true))?;
        out.push(case);
    }
    progress("motion", n, n);
    Ok(MotionCost {
        resolution: [nt, np],
        origins,
        cases: out,
    })
}

/// One moving scene on the current pool: each step incrementally, then (with `whole`)
/// whole; `moving` is the prefix of the moving groups' names.
pub fn measure(
    name: &str,
    desc: &SceneDesc,
    motion: &Motion,
    moving: &str,
    hemi: &Hemisphere,
    origins: u32,
    whole: bool,
) -> Result<MotionCase, Error> {
    let cut = Scene::new(desc.clone()).map_err(Error::from)?;
    let opts = ViewFactorConfig {
        by: Grouping::Polygon,
        method: ViewFactorMethod::Hemisphere,
        origins,
        ..ViewFactorConfig::for_scene(&cut)
    };
    let area = |keep: &dyn Fn(Option<&str>) -> bool| -> f64 {
        cut.patches()
            .iter()
            .filter(|p| keep(cut.group(p.polygon as usize)))
            .map(|p| p.area)
            .sum()
    };
    let moving_share = area(&|g| g.is_some_and(|g| g.starts_with(moving))) / area(&|_| true);
    let unit = motion.unit(desc);
    let mut steps = Vec::new();
    let mut kept_bytes = 0;
    let mut t = Instant::now();
    view_factors_over_motion(desc, &cut, motion, hemi, &opts, &|_, _| {}, &mut |s| {
        let incremental_seconds = t.elapsed().as_secs_f64();
        let scene = motion
            .step_scene(desc, &cut, s.step, unit)
            .map_err(Error::from)?;
        let w = Instant::now();
        let (whole_seconds, identical) = if whole {
            let made = view_factors(&scene, hemi, &opts, &|_| {})?;
            let same = made.matrix.rows == s.vf.matrix.rows
                && made.escaped == s.vf.escaped
                && made.back == s.vf.back;
            (w.elapsed().as_secs_f64(), same)
        } else {
            (f64::NAN, true)
        };
        steps.push(StepCost {
            step: s.step,
            incremental_seconds,
            whole_seconds,
            cast_share: s.recast.cast_share(),
            patches_whole: s.recast.whole,
            patches_in_part: s.recast.partly,
            identical,
        });
        kept_bytes = s.recast.kept_bytes;
        t = Instant::now();
        Ok(())
    })?;
    let mut ratios: Vec<f64> = steps[1..]
        .iter()
        .map(|s| s.incremental_seconds / s.whole_seconds)
        .collect();
    ratios.sort_by(f64::total_cmp);
    Ok(MotionCase {
        scene: name.to_string(),
        patches: cut.patches().len(),
        moving_share,
        median_ratio: ratios.get(ratios.len() / 2).copied().unwrap_or(f64::NAN),
        steps,
        kept_bytes,
    })
}
