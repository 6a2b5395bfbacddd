//! Estimation across polygons on the mesh scenes: the error experiment (the report's
//! measures) on a sample of windows, the cost of an estimate against an exact hemisphere
//! by the best caster (one thread), and Table 1 for meshes: every patch's rows exact by
//! the best caster, then estimated with centres by the same caster, one after the other
//! in one process on all threads.

use crate::estimation::{estimation_of, l1, EstimationJob, SceneEstimation, Setting};
use crate::stats::Summary;
use crate::{one_thread, Error};
use rad_accel::VoxelGrid;
use rad_estimator::{Estimator, Schedule, SourceHemisphere};
use rad_geometry::scenes::{blob_room, loft_fine_triangles, loft_patches, loft_triangles};
use rad_geometry::{Scene, SceneDesc};
use rad_hemisphere::{
    Caster, FacetScan, Hemisphere, HemisphereConfig, Hierarchy, ItemBuffer, Row, Scan,
};
use rad_pipeline::{default_estimator, default_grid, rows_streamed, CasterKind, Mode, RowMethod};
use serde::Serialize;
use std::time::Instant;

/// The section (meshes.json).
#[derive(Clone, Debug, Serialize)]
pub struct MeshEstimation {
    pub resolution: [u32; 2],
    pub scenes: Vec<MeshScene>,
}

/// One mesh scene.
#[derive(Clone, Debug, Serialize)]
pub struct MeshScene {
    pub scene: &'static str,
    pub polygons: usize,
    pub patches: usize,
    /// Facets of several polygons (a mesh's flat pieces), and the polygons they hold.
    pub facets: usize,
    pub polygons_in_facets: usize,
    /// The schedule: windows, those that estimate something, patches a window.
    pub windows: usize,
    pub estimating_windows: usize,
    pub patches_per_window: f64,
    /// The caster of exact hemispheres (`CasterKind::fastest_for`).
    pub caster: &'static str,
    /// The error experiment on every `window_step`-th estimating window.
    pub window_step: usize,
    pub errors: SceneEstimation,
    pub cost: Cost,
    pub table1: Table1,
}

/// One thread, the median over the estimated patches of a few windows.
#[derive(Clone, Debug, Serialize)]
pub struct Cost {
    pub hemispheres: usize,
    pub median_ms_exact: f64,
    pub median_ms_improved: f64,
    pub median_ms_faithful: f64,
    /// Over the exact hemisphere's median.
    pub ratio_improved: f64,
    pub ratio_faithful: f64,
}

/// Every patch's rows, exact then estimated (improved), on all threads.
#[derive(Clone, Debug, Serialize)]
pub struct Table1 {
    pub rows: usize,
    pub exact_seconds: f64,
    pub estimated_seconds: f64,
    /// Exact time over estimated time.
    pub speedup: f64,
    pub exact_hemispheres: usize,
    pub estimated_hemispheres: usize,
    pub fallback_exact: usize,
    /// Real rays a row estimated (fallbacks included).
    pub real_rays_per_estimate: f64,
    /// Estimated rows against exact ones, every `sample_step`-th patch.
    pub sample_step: usize,
    pub sample_l1: Summary,
}

/// The mesh scenes by name, their builders.
pub const MESH_SCENES: [(&str, fn() -> SceneDesc); 4] = [
    ("loft_patches", loft_patches),
    ("loft_triangles", loft_triangles),
    ("loft_fine", loft_fine_triangles),
    ("blob_room", blob_room),
];

/// The mesh scene `name` ([`MESH_SCENES`]), built.
pub fn mesh_scene(name: &str) -> Option<SceneDesc> {
    MESH_SCENES.iter().find(|m| m.0 == name).map(|m| (m.1)())
}

/// The mesh scenes (`quick`: `loft_patches` and `blob_room` at 24 × 96).
pub fn run(
    quick: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<MeshEstimation, Error> {
    let (nt, np) = if quick { (24, 96) } else { (180, 720) };
    let mut scenes: Vec<(&'static str, fn() -> SceneDesc, usize)> = vec![
        ("loft_patches", loft_patches, 40),
        ("blob_room", blob_room, 4),
    ];
    if !quick {
        scenes.insert(1, ("loft_triangles", loft_triangles, 40));
        scenes.insert(2, ("loft_fine", loft_fine_triangles, 100));
    }
    let mut out = Vec::new();
    for (name, build, step) in scenes {
        let scene = Scene::new(build())?;
        let stage = format!("meshes, {name}");
        out.push(scene_section(name, &scene, (nt, np), step, &|s, n| {
            progress(&stage, s, n)
        })?);
    }
    Ok(MeshEstimation {
        resolution: [nt, np],
        scenes: out,
    })
}

fn scene_section(
    name: &'static str,
    scene: &Scene,
    resolution: (u32, u32),
    step: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<MeshScene, Error> {
    let facets = scene.facets();
    let several: Vec<u32> = (0..facets.len() as u32)
        .filter(|&f| facets.is_several(f))
        .collect();
    let schedule = Schedule::of(scene);
    let windows = schedule.windows();
    let estimating: Vec<_> = windows
        .iter()
        .filter(|w| !w.estimated.is_empty())
        .cloned()
        .collect();
    let best = CasterKind::fastest_for(scene);
    let tree = Hierarchy::new(scene);
    let settings = [Mode::Improved, Mode::Faithful].map(|mode| Setting {
        name: format!("{}, defaults", mode.name()),
        config: default_estimator(mode),
    });
    progress(0, 3);
    let job = EstimationJob {
        name,
        scene,
        resolution,
        with_lambert: false,
        settings: &settings,
    };
    let sample: Vec<_> = estimating.iter().step_by(step).cloned().collect();
    let errors = estimation_of(&job, &tree, sample, &|_, _| {})?;
    progress(1, 3);
    let hemi = Hemisphere::new(HemisphereConfig::exact(resolution.0, resolution.1))?;
    let k = 12.min(estimating.len());
    let timed: Vec<_> = (0..k)
        .map(|i| estimating[i * estimating.len() / k].clone())
        .collect();
    let cost = one_thread()?.install(|| cost_by(scene, best, &tree, &hemi, &timed))?;
    progress(2, 3);
    let table1 = table1(scene, &hemi, best)?;
    progress(3, 3);
    Ok(MeshScene {
        scene: name,
        polygons: scene.polygons().len(),
        patches: scene.patches().len(),
        facets: several.len(),
        polygons_in_facets: several.iter().map(|&f| facets.polygons(f).len()).sum(),
        windows: windows.len(),
        estimating_windows: estimating.len(),
        patches_per_window: scene.patches().len() as f64 / windows.len().max(1) as f64,
        caster: best.name(),
        window_step: step,
        errors,
        cost,
        table1,
    })
}

/// [`cost`] through the caster `kind` names (`tree`, the scene's hierarchy, where it
/// names the hierarchy).
pub fn cost_by(
    scene: &Scene,
    kind: CasterKind,
    tree: &Hierarchy,
    hemi: &Hemisphere,
    windows: &[rad_estimator::Window],
) -> Result<Cost, Error> {
    match kind {
        CasterKind::Scan => cost(scene, &Scan, hemi, windows),
        CasterKind::Grid => cost(
            scene,
            &VoxelGrid::build(scene, &default_grid())?,
            hemi,
            windows,
        ),
        CasterKind::Hierarchy => cost(scene, tree, hemi, windows),
        CasterKind::Facets => cost(scene, &FacetScan::new(scene), hemi, windows),
    }
}

/// The median thread time of an exact hemisphere (through `caster`) and of each mode's
/// estimate (an abandoned improved estimate with its exact cast), over the estimated
/// patches of `windows` (run it on one thread).
pub fn cost<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    windows: &[rad_estimator::Window],
) -> Result<Cost, Error> {
    let est = Estimator::new(hemi);
    let (improved, faithful) = (
        default_estimator(Mode::Improved),
        default_estimator(Mode::Faithful),
    );
    let mut s = caster.scratch();
    let mut buf = ItemBuffer::default();
    let (mut ie, mut fe) = (Default::default(), Default::default());
    let (mut te, mut ti, mut tf) = (Vec::new(), Vec::new(), Vec::new());
    for w in windows {
        let src = SourceHemisphere::cast(scene, caster, hemi, w.centre, false, &mut s);
        for &p in &w.estimated {
            let t = Instant::now();
            caster.item_buffer(scene, hemi, p, &mut s, &mut buf);
            te.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            est.improved(scene, caster, &src, p, &improved, &mut s, &mut ie);
            std::hint::black_box(&ie);
            ti.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            est.faithful(scene, &src, p, &faithful, &mut fe);
            std::hint::black_box(&fe);
            tf.push(t.elapsed().as_secs_f64());
        }
    }
    let (e, i, f) = (
        Summary::of(&te).median,
        Summary::of(&ti).median,
        Summary::of(&tf).median,
    );
    Ok(Cost {
        hemispheres: te.len(),
        median_ms_exact: 1e3 * e,
        median_ms_improved: 1e3 * i,
        median_ms_faithful: 1e3 * f,
        ratio_improved: i / e,
        ratio_faithful: f / e,
    })
}

/// Every patch's rows exact through `best`, then estimated (improved) with centres
/// through `best`, each timed whole (rows made and dropped chunk by chunk); the rows of
/// every k-th patch kept from both (about 400 of them) for their L1 distance.
fn table1(scene: &Scene, hemi: &Hemisphere, best: CasterKind) -> Result<Table1, Error> {
    let n = scene.patches().len();
    let step = n.div_ceil(400).max(1);
    let keep = |rows: &[Row], out: &mut Vec<Row>| {
        out.extend(
            rows.iter()
                .filter(|r| r.patch as usize % step == 0)
                .cloned(),
        );
    };
    let mut exact_rows = Vec::new();
    let t = Instant::now();
    let exact = rows_streamed(
        scene,
        hemi,
        RowMethod::Exact { caster: best },
        &|_| {},
        &mut |made| {
            keep(&made.rows, &mut exact_rows);
            Ok(())
        },
    )?;
    let exact_seconds = t.elapsed().as_secs_f64();
    let mut estimated_rows = Vec::new();
    let t = Instant::now();
    let estimated = rows_streamed(
        scene,
        hemi,
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: best,
        },
        &|_| {},
        &mut |made| {
            keep(&made.rows, &mut estimated_rows);
            Ok(())
        },
    )?;
    let estimated_seconds = t.elapsed().as_secs_f64();
    let l1s: Vec<f64> = exact_rows
        .iter()
        .zip(&estimated_rows)
        .map(|(a, b)| l1(a, b))
        .collect();
    let estimates = estimated.estimated + estimated.fallback_exact;
    Ok(Table1 {
        rows: n,
        exact_seconds,
        estimated_seconds,
        speedup: exact_seconds / estimated_seconds,
        exact_hemispheres: exact.exact,
        estimated_hemispheres: estimated.estimated,
        fallback_exact: estimated.fallback_exact,
        real_rays_per_estimate: estimated.real_rays as f64 / estimates.max(1) as f64,
        sample_step: step,
        sample_l1: Summary::of(&l1s),
    })
}
