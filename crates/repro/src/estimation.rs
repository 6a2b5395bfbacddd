//! The estimation-error experiment (report §4; docs/design.md, "Error measures"): every estimated
//! patch against our exact hemisphere of that patch, for each estimator setting.

use crate::accuracy::lambert;
use crate::stats::Summary;
use crate::Error;
use rad_accel::VoxelGrid;
use rad_core::{PatchId, RayCast};
use rad_estimator::{
    windows, Estimate, Estimator, EstimatorConfig, HoleFill, ImprovedEstimate, Mode, Outcome,
    Reprojection, SourceHemisphere, ThresholdTest, Window,
};
use rad_geometry::Scene;
use rad_hemisphere::{
    Caster, Hemisphere, HemisphereConfig, ItemBuffer, Row, RowAccumulator, ScanScratch,
};
use rad_pipeline::default_grid;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// A named estimator setting.
#[derive(Clone, Debug)]
pub struct Setting {
    pub name: String,
    pub config: EstimatorConfig,
}

/// The settings compared: faithful mode with each fill policy and reprojection rule,
/// improved mode with each real-ray threshold; each with and without boundary lists.
pub fn settings(quick: bool) -> Vec<Setting> {
    let mut out = Vec::new();
    let reproj: Vec<(&str, Reprojection)> = vec![
        ("exact", Reprojection::Exact),
        (
            "first-order R/d>10",
            Reprojection::FirstOrder {
                test: ThresholdTest::Distance,
                threshold: 10.0,
            },
        ),
        ("first-order R sin/d>10", Reprojection::LATERAL_10),
    ];
    for bl in [false, true] {
        let bl_name = if bl { ", lists" } else { "" };
        for (fill_name, fill) in [
            ("keep H1", HoleFill::KeepSource),
            ("ring neighbour", HoleFill::RingNeighbour),
        ] {
            for (r_name, r) in &reproj {
                if quick && (fill == HoleFill::KeepSource || !matches!(r, Reprojection::Exact)) {
                    continue;
                }
                // With lists, only the ring-neighbour settings (the others gain as much).
                if bl && fill == HoleFill::KeepSource {
                    continue;
                }
                out.push(Setting {
                    name: format!("faithful, {r_name}, {fill_name}{bl_name}"),
                    config: EstimatorConfig {
                        mode: Mode::Faithful,
                        fill,
                        reprojection: *r,
                        boundary_lists: bl,
                        max_real_ray_share: 1.0,
                        guess_stride: 1,
                    },
                });
            }
        }
        let default_stride = rad_pipeline::default_estimator(Mode::Improved).guess_stride;
        for (share, stride) in [(0.02, 1), (0.05, 1), (0.10, 1), (0.05, 2), (0.05, 3)] {
            // Quick, and with lists: the default setting only.
            if (quick || bl) && (share != 0.05 || stride != default_stride) {
                continue;
            }
            let stride_name = if stride > 1 {
                format!(", guesses /{stride}")
            } else {
                String::new()
            };
            out.push(Setting {
                name: format!(
                    "improved, real rays <= {:.0} %{stride_name}{bl_name}",
                    share * 100.0
                ),
                config: EstimatorConfig {
                    mode: Mode::Improved,
                    fill: HoleFill::RingNeighbour,
                    reprojection: Reprojection::LATERAL_10,
                    boundary_lists: bl,
                    max_real_ray_share: share,
                    guess_stride: stride,
                },
            });
        }
    }
    out
}

/// The settings run on the loft (fewer: each costs about ten seconds there): faithful
/// mode with exact and both first-order rules, improved mode at each threshold, and
/// both modes' defaults with boundary lists.
pub fn loft_settings(quick: bool) -> Vec<Setting> {
    let keep = [
        "faithful, exact, ring neighbour",
        "faithful, first-order R/d>10, ring neighbour",
        "faithful, first-order R sin/d>10, ring neighbour",
        "faithful, first-order R sin/d>10, ring neighbour, lists",
        "improved, real rays <= 2 %",
        "improved, real rays <= 5 %",
        "improved, real rays <= 10 %",
        "improved, real rays <= 5 %, guesses /2",
        "improved, real rays <= 5 %, guesses /3",
        "improved, real rays <= 5 %, guesses /3, lists",
    ];
    settings(false)
        .into_iter()
        .filter(|s| {
            keep.contains(&s.name.as_str())
                && (!quick
                    || s.name.contains("<= 5 %")
                    || s.name.ends_with("exact, ring neighbour"))
        })
        .collect()
}

/// Time of one hemisphere, one thread: exact and each mode's default estimate.
#[derive(Clone, Debug, Serialize)]
pub struct EstimationTiming {
    pub scene: String,
    pub resolution: [u32; 2],
    pub hemispheres: usize,
    /// Exact: each cell's ray cast through the voxel grid (the report's way).
    pub median_ms_exact: f64,
    pub median_ms_faithful: f64,
    pub median_ms_improved: f64,
    /// Estimate over exact (grid), per mode: of the medians.
    pub ratio_faithful: f64,
    pub ratio_improved: f64,
    /// Estimate over exact (grid), per mode: of the total times (each estimate timed
    /// right after its patch's exact hemisphere, so that drifts in the machine's speed
    /// cancel). Improved mode's abandoned estimates, cast exactly, count here in full;
    /// the median does not see them.
    pub total_ratio_faithful: f64,
    pub total_ratio_improved: f64,
    /// The same exact item buffers by polygon scan ([`Hemisphere::scan`]).
    pub median_ms_scan: f64,
    /// Real rays the improved mode cast, per estimated hemisphere.
    pub improved_real_rays_per_hemisphere: f64,
}

/// Times exact and estimated hemispheres over `k` windows spread across the scene, on
/// one thread, one after the other in this process.
pub fn timing(
    name: &str,
    scene: &Scene,
    resolution: (u32, u32),
    k: usize,
) -> Result<EstimationTiming, Error> {
    let grid = VoxelGrid::build(scene, &default_grid())?;
    let hemi = Hemisphere::new(HemisphereConfig::exact(resolution.0, resolution.1))?;
    let est = Estimator::new(&hemi);
    let all = windows(scene);
    let picked: Vec<&Window> = (0..k)
        .map(|i| &all[i * all.len() / k])
        .filter(|w| !w.estimated.is_empty())
        .collect();
    let pool = crate::one_thread()?;
    let faithful = rad_pipeline::default_estimator(Mode::Faithful);
    let improved = rad_pipeline::default_estimator(Mode::Improved);
    Ok(pool.install(|| {
        let mut s = grid.new_scratch();
        let mut buf = ItemBuffer::default();
        let mut ss = ScanScratch::default();
        let (mut te, mut tf, mut ti, mut real) = (Vec::new(), Vec::new(), Vec::new(), 0usize);
        let mut ts = Vec::new();
        // Output buffers reused, as the schedule reuses them (and as `buf` is).
        let (mut fe, mut ie) = (Default::default(), Default::default());
        for w in &picked {
            let src = SourceHemisphere::cast(scene, &grid, &hemi, w.centre, false, &mut s);
            for &p in &w.estimated {
                let t = Instant::now();
                hemi.cast(scene, &grid, p, &mut s, &mut buf);
                te.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                hemi.scan(scene, p, &mut ss, &mut buf);
                ts.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                est.faithful(scene, &src, p, &faithful, &mut fe);
                std::hint::black_box(&fe);
                tf.push(t.elapsed().as_secs_f64());
                // An abandoned estimate costs its exact cast too, as in the schedule.
                let t = Instant::now();
                est.improved(scene, &grid, &src, p, &improved, &mut s, &mut ie);
                real += std::hint::black_box(&ie).real_rays;
                ti.push(t.elapsed().as_secs_f64());
            }
        }
        let (e, f, i) = (
            Summary::of(&te).median,
            Summary::of(&tf).median,
            Summary::of(&ti).median,
        );
        EstimationTiming {
            scene: name.to_string(),
            resolution: [resolution.0, resolution.1],
            hemispheres: te.len(),
            median_ms_exact: 1e3 * e,
            median_ms_faithful: 1e3 * f,
            median_ms_improved: 1e3 * i,
            ratio_faithful: f / e,
            ratio_improved: i / e,
            total_ratio_faithful: tf.iter().sum::<f64>() / te.iter().sum::<f64>(),
            total_ratio_improved: ti.iter().sum::<f64>() / te.iter().sum::<f64>(),
            median_ms_scan: 1e3 * Summary::of(&ts).median,
            improved_real_rays_per_hemisphere: real as f64 / ti.len().max(1) as f64,
        }
    }))
}

/// Errors of one estimated row against its exact row.
#[derive(Clone, Copy, Debug, Default)]
struct RowError {
    /// Mean over the exact row's targets of |F_e − F| / F (the report's metric).
    rel: f64,
    l1: f64,
    l1_polygon: f64,
    /// Against Lambert's point-to-patch values (cube only).
    rel_lambert: f64,
    /// This patch's own noise: L1 between two equally valid exact hemispheres.
    noise_l1: f64,
    interior: bool,
    holes: f64,
    real_rays: f64,
    fallback: bool,
}

/// Aggregates over the estimated patches, overall and apart for patches inside a
/// polygon and on its edges.
#[derive(Clone, Debug, Serialize)]
pub struct SettingResult {
    pub setting: String,
    pub mode: &'static str,
    pub boundary_lists: bool,
    pub rel_error: Summary,
    pub rel_error_interior: Summary,
    pub rel_error_edge: Summary,
    pub l1: Summary,
    pub l1_polygon: Summary,
    pub rel_error_vs_lambert: Option<Summary>,
    /// Share of estimated rows whose L1 is within their own noise.
    pub within_noise: f64,
    /// Mean share of H2's cells that were holes, before filling.
    pub hole_fraction: f64,
    /// Improved mode: real rays per estimated cell, and patches cast exactly instead.
    pub real_ray_fraction: f64,
    pub fallback_exact: usize,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct SceneEstimation {
    pub scene: String,
    pub resolution: [u32; 2],
    pub windows: usize,
    pub exact_hemispheres: usize,
    pub estimated_hemispheres: usize,
    /// Noise: L1 between exact and half-sector-turned exact rows of the estimated patches.
    pub noise_l1: Summary,
    pub noise_l1_polygon: Summary,
    pub noise_rel: Summary,
    pub results: Vec<SettingResult>,
}

fn rel_error(est: &Row, exact: &Row) -> f64 {
    let targets: Vec<f64> = exact
        .entries
        .iter()
        .map(|&(j, f)| (est.get(j) - f).abs() / f)
        .collect();
    targets.iter().sum::<f64>() / targets.len().max(1) as f64
}

pub(crate) fn l1(a: &Row, b: &Row) -> f64 {
    let mut s = 0.0;
    let (mut i, mut j) = (0, 0);
    while i < a.entries.len() || j < b.entries.len() {
        match (a.entries.get(i), b.entries.get(j)) {
            (Some(x), Some(y)) if x.0 == y.0 => {
                s += (x.1 - y.1).abs();
                i += 1;
                j += 1;
            }
            (Some(x), Some(y)) if x.0 < y.0 => {
                s += x.1;
                i += 1;
            }
            (Some(_), Some(y)) => {
                s += y.1;
                j += 1;
            }
            (Some(x), None) => {
                s += x.1;
                i += 1;
            }
            (None, Some(y)) => {
                s += y.1;
                j += 1;
            }
            (None, None) => break,
        }
    }
    s + (a.back - b.back).abs() + (a.escaped - b.escaped).abs()
}

fn per_polygon(scene: &Scene, r: &Row) -> Vec<f64> {
    let mut v = vec![0.0; scene.polygons().len()];
    for &(j, f) in &r.entries {
        v[scene.patches()[j as usize].polygon as usize] += f;
    }
    v
}

fn l1_polygon(scene: &Scene, a: &Row, b: &Row) -> f64 {
    per_polygon(scene, a)
        .iter()
        .zip(per_polygon(scene, b))
        .map(|(x, y)| (x - y).abs())
        .sum()
}

/// Mean of |F − F_Lambert| / F_Lambert over the patches of other polygons than `p`'s.
fn mean_rel_vs_lambert(scene: &Scene, p: PatchId, row: &Row) -> f64 {
    let own = scene.patches()[p as usize].polygon;
    let (mut sum, mut count) = (0.0, 0);
    for (q, target) in scene.patches().iter().enumerate() {
        if target.polygon != own {
            let f = lambert(scene, p as usize, q);
            sum += (row.get(q as u32) - f).abs() / f;
            count += 1;
        }
    }
    sum / count.max(1) as f64
}

/// Each target's exact row, and its noise: the row of the hemisphere `turned` (φ turned
/// half a cell).
fn reference_rows<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    turned: &Hemisphere,
    targets: &[(usize, PatchId)],
) -> Vec<(Row, Row)> {
    let n = scene.patches().len();
    targets
        .par_iter()
        .map_init(
            || {
                (
                    caster.scratch(),
                    ItemBuffer::default(),
                    RowAccumulator::new(n),
                )
            },
            |(s, buf, acc), &(_, p)| {
                caster.item_buffer(scene, hemi, p, s, buf);
                let exact = hemi.row_from_items(p, buf, acc);
                caster.item_buffer(scene, turned, p, s, buf);
                (exact, turned.row_from_items(p, buf, acc))
            },
        )
        .collect()
}

/// One setting's figures from its rows' errors.
fn summarise(
    setting: &Setting,
    errs: &[RowError],
    with_lambert: bool,
    seconds: f64,
) -> SettingResult {
    let cfg = &setting.config;
    let pick = |f: &dyn Fn(&RowError) -> Option<f64>| {
        Summary::of(&errs.iter().filter_map(f).collect::<Vec<_>>())
    };
    SettingResult {
        setting: setting.name.clone(),
        mode: cfg.mode.name(),
        boundary_lists: cfg.boundary_lists,
        rel_error: pick(&|e| Some(e.rel)),
        rel_error_interior: pick(&|e| e.interior.then_some(e.rel)),
        rel_error_edge: pick(&|e| (!e.interior).then_some(e.rel)),
        l1: pick(&|e| Some(e.l1)),
        l1_polygon: pick(&|e| Some(e.l1_polygon)),
        rel_error_vs_lambert: with_lambert.then(|| pick(&|e| Some(e.rel_lambert))),
        within_noise: errs.iter().filter(|e| e.l1 <= e.noise_l1).count() as f64
            / errs.len().max(1) as f64,
        hole_fraction: errs.iter().map(|e| e.holes).sum::<f64>() / errs.len().max(1) as f64,
        real_ray_fraction: errs.iter().map(|e| e.real_rays).sum::<f64>() / errs.len().max(1) as f64,
        fallback_exact: errs.iter().filter(|e| e.fallback).count(),
        seconds,
    }
}

/// Runs the experiment on `scene` for the windows of `polygons` (all if None), through
/// the voxel grid.
pub fn scene_estimation(
    name: &str,
    scene: &Scene,
    resolution: (u32, u32),
    polygons: Option<&[u32]>,
    with_lambert: bool,
    settings: &[Setting],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SceneEstimation, Error> {
    let grid = VoxelGrid::build(scene, &default_grid())?;
    let wins: Vec<Window> = windows(scene)
        .into_iter()
        .filter(|w| {
            polygons.is_none_or(|ps| ps.contains(&scene.patches()[w.centre as usize].polygon))
        })
        .collect();
    let job = EstimationJob {
        name,
        scene,
        resolution,
        with_lambert,
        settings,
    };
    estimation_of(&job, &grid, wins, progress)
}

/// What the experiment runs on: a scene, a resolution, the settings.
pub struct EstimationJob<'a> {
    pub name: &'a str,
    pub scene: &'a Scene,
    pub resolution: (u32, u32),
    /// Whether to compare with Lambert's formula (unoccluded scenes only).
    pub with_lambert: bool,
    pub settings: &'a [Setting],
}

/// Runs the experiment on the windows `wins` of `job.scene`, casting (sources, exact
/// and noise rows, real rays, fallbacks) through `caster`: every caster gives the same
/// hemispheres, so the figures do not depend on it, only the time they take.
pub fn estimation_of<C: Caster>(
    job: &EstimationJob,
    caster: &C,
    wins: Vec<Window>,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SceneEstimation, Error> {
    let EstimationJob {
        name,
        scene,
        resolution,
        with_lambert,
        settings,
    } = *job;
    let hemi = Hemisphere::new(HemisphereConfig::exact(resolution.0, resolution.1))?;
    let turned = Hemisphere::new(HemisphereConfig {
        phi_shift: 0.5,
        ..HemisphereConfig::exact(resolution.0, resolution.1)
    })?;
    let n = scene.patches().len();
    // Sources with boundary lists (cleared for settings without), exact and noise rows.
    let sources: Vec<SourceHemisphere> = wins
        .par_iter()
        .map_init(
            || caster.scratch(),
            |s, w| SourceHemisphere::cast(scene, caster, &hemi, w.centre, true, s),
        )
        .collect();
    let targets: Vec<(usize, PatchId)> = wins
        .iter()
        .enumerate()
        .flat_map(|(k, w)| w.estimated.iter().map(move |&p| (k, p)))
        .collect();
    let reference = reference_rows(scene, caster, &hemi, &turned, &targets);
    progress(1, settings.len() + 1);
    let est = Estimator::new(&hemi);
    let mut results = Vec::new();
    for (k, setting) in settings.iter().enumerate() {
        let t = Instant::now();
        let cfg = &setting.config;
        let errs: Vec<RowError> = targets
            .par_iter()
            .zip(&reference)
            .map_init(
                || (caster.scratch(), RowAccumulator::new(n)),
                |(s, acc), (&(w, p), (exact, noise))| {
                    let stripped;
                    let src = if cfg.boundary_lists {
                        &sources[w]
                    } else {
                        stripped = sources[w].without_lists();
                        &stripped
                    };
                    let (items, holes, real, fallback) = match cfg.mode {
                        Mode::Faithful => {
                            let mut e = Estimate::default();
                            est.faithful(scene, src, p, cfg, &mut e);
                            (e.items, e.holes, 0, false)
                        }
                        Mode::Improved => {
                            let mut e = ImprovedEstimate::default();
                            let outcome = est.improved(scene, caster, src, p, cfg, s, &mut e);
                            let cast = outcome == Outcome::CastExactly;
                            (e.items, e.holes, e.real_rays, cast)
                        }
                    };
                    // (A fallback's items are the patch's exact hemisphere.)
                    let row = hemi.row_from_items(p, &items, acc);
                    let rel_lambert = if with_lambert {
                        mean_rel_vs_lambert(scene, p, &row)
                    } else {
                        0.0
                    };
                    RowError {
                        rel: rel_error(&row, exact),
                        l1: l1(&row, exact),
                        l1_polygon: l1_polygon(scene, &row, exact),
                        rel_lambert,
                        noise_l1: l1(noise, exact),
                        interior: !scene.patches()[p as usize].on_boundary,
                        holes: holes as f64 / hemi.n_cells() as f64,
                        real_rays: real as f64 / hemi.n_cells() as f64,
                        fallback,
                    }
                },
            )
            .collect();
        results.push(summarise(
            setting,
            &errs,
            with_lambert,
            t.elapsed().as_secs_f64(),
        ));
        progress(k + 2, settings.len() + 1);
    }
    let noise_l1: Vec<f64> = reference.iter().map(|(e, n)| l1(n, e)).collect();
    let noise_l1_polygon: Vec<f64> = reference
        .iter()
        .map(|(e, n)| l1_polygon(scene, n, e))
        .collect();
    let noise_rel: Vec<f64> = reference.iter().map(|(e, n)| rel_error(n, e)).collect();
    Ok(SceneEstimation {
        scene: name.to_string(),
        resolution: [resolution.0, resolution.1],
        windows: wins.len(),
        exact_hemispheres: wins.len(),
        estimated_hemispheres: targets.len(),
        noise_l1: Summary::of(&noise_l1),
        noise_l1_polygon: Summary::of(&noise_l1_polygon),
        noise_rel: Summary::of(&noise_rel),
        results,
    })
}
