//! The exact hemisphere's accuracy in the empty cube against Lambert's formula (docs/design.md,
//! "Closed forms used in tests"), and the cube's face-to-face factors against their closed forms.

use crate::closed_form::{parallel_rectangles, perpendicular_rectangles};
use crate::stats::Summary;
use crate::Error;
use glam::DVec3;
use rad_accel::VoxelGrid;
use rad_geometry::scenes::{cube, CUBE_FACES};
use rad_geometry::Scene;
use rad_hemisphere::{
    compute_rows, point_to_polygon_form_factor, DeltaRule, Hemisphere, HemisphereConfig, Row,
};
use rad_pipeline::default_grid;
use serde::Serialize;
use std::time::Instant;

/// A patch of the cube named by face and cell.
#[derive(Clone, Debug, Serialize)]
pub struct NamedPatch {
    pub name: String,
    pub face: usize,
    pub cell: [u32; 2],
}

impl NamedPatch {
    pub fn new(face: usize, cell: [u32; 2]) -> NamedPatch {
        NamedPatch {
            name: format!("{} ({},{})", CUBE_FACES[face], cell[0], cell[1]),
            face,
            cell,
        }
    }
}

/// What the accuracy experiment runs.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyConfig {
    /// Patches per cube edge (the report: 10).
    pub n: u64,
    pub resolutions: Vec<(u32, u32)>,
    pub patches: Vec<NamedPatch>,
    /// Also the report's midpoint delta form factors at this resolution.
    pub midpoint_at: Option<(u32, u32)>,
    /// Compute every row at this resolution for the face-to-face factors.
    pub face_factors_at: Option<(u32, u32)>,
}

/// One patch at one resolution against Lambert.
#[derive(Clone, Debug, Serialize)]
pub struct AccuracyRow {
    pub patch: String,
    pub patch_id: u32,
    pub resolution: [u32; 2],
    pub delta: &'static str,
    /// Relative error |F − F_Lambert| / F_Lambert over the patches off its own face
    /// (500 for a 10 × 10 cube).
    pub rel_error: Summary,
    /// Σ_j |F_j − F_Lambert,j|.
    pub l1: f64,
    pub row_sum: f64,
    pub back: f64,
    pub escaped: f64,
    pub seconds_per_hemisphere: f64,
}

/// Area-weighted face-to-face factors from the floor, against the closed forms.
#[derive(Clone, Debug, Serialize)]
pub struct FaceFactors {
    pub resolution: [u32; 2],
    pub opposite: f64,
    pub opposite_closed_form: f64,
    /// The four adjacent faces, in CUBE_FACES order (walls).
    pub adjacent: Vec<f64>,
    pub adjacent_closed_form: f64,
    /// Largest |Σ_j F_ij − 1| over all 600 rows.
    pub max_row_sum_error: f64,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct CubeAccuracy {
    pub config: AccuracyConfig,
    pub rows: Vec<AccuracyRow>,
    pub face_factors: Option<FaceFactors>,
    /// Rows of every patch at `face_factors_at`, kept for the reciprocity table.
    #[serde(skip)]
    pub all_rows: Vec<Row>,
}

/// Lambert's unoccluded point-to-patch form factor from patch `from`'s centre.
pub fn lambert(scene: &Scene, from: usize, to: usize) -> f64 {
    let p = &scene.patches()[from];
    let corners: Vec<DVec3> = scene.patches()[to]
        .corners
        .iter()
        .map(|c| c.as_dvec3())
        .collect();
    point_to_polygon_form_factor(p.center.as_dvec3(), p.normal.as_dvec3(), &corners)
}

/// Runs the experiment; `progress(step, of)` after each step.
pub fn cube_accuracy(
    config: &AccuracyConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<CubeAccuracy, Error> {
    let scene = Scene::new(cube(config.n))?;
    let grid = VoxelGrid::build(&scene, &default_grid())?;
    let per_face = (config.n * config.n) as usize;
    let mut runs: Vec<((u32, u32), DeltaRule)> = config
        .resolutions
        .iter()
        .map(|&r| (r, DeltaRule::Exact))
        .collect();
    runs.extend(config.midpoint_at.map(|r| (r, DeltaRule::Midpoint)));
    let steps = runs.len() + usize::from(config.face_factors_at.is_some());
    let mut rows = Vec::new();
    for (step, &((nt, np), delta)) in runs.iter().enumerate() {
        let hemi = Hemisphere::new(HemisphereConfig {
            n_theta: nt,
            n_phi: np,
            delta,
            phi_shift: 0.0,
        })?;
        for named in &config.patches {
            let id =
                (named.face * per_face) as u32 + named.cell[1] * config.n as u32 + named.cell[0];
            let t = Instant::now();
            let row = compute_rows(&scene, &grid, &hemi, &[id], &|_| {})?.remove(0);
            let seconds = t.elapsed().as_secs_f64();
            // Targets: every patch off the source's face (coplanar patches see nothing).
            let (mut errs, mut l1) = (Vec::new(), 0.0);
            let source_face = scene.patches()[id as usize].polygon;
            for (q, target) in scene.patches().iter().enumerate() {
                if target.polygon == source_face {
                    continue;
                }
                let exact = lambert(&scene, id as usize, q);
                l1 += (row.get(q as u32) - exact).abs();
                errs.push((row.get(q as u32) - exact).abs() / exact);
            }
            rows.push(AccuracyRow {
                patch: named.name.clone(),
                patch_id: id,
                resolution: [nt, np],
                delta: match delta {
                    DeltaRule::Exact => "exact",
                    DeltaRule::Midpoint => "midpoint",
                },
                rel_error: Summary::of(&errs),
                l1,
                row_sum: row.sum(),
                back: row.back,
                escaped: row.escaped,
                seconds_per_hemisphere: seconds,
            });
        }
        progress(step + 1, steps);
    }
    let (mut face_factors, mut all_rows) = (None, Vec::new());
    if let Some((nt, np)) = config.face_factors_at {
        let t = Instant::now();
        let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
        let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
        all_rows = compute_rows(&scene, &grid, &hemi, &all, &|_| {})?;
        let mut face = [0.0f64; 6];
        for r in &all_rows[..per_face] {
            for &(j, f) in &r.entries {
                face[scene.patches()[j as usize].polygon as usize] += f / per_face as f64;
            }
        }
        let max_row_sum_error = all_rows
            .iter()
            .map(|r| (r.sum() - 1.0).abs())
            .fold(0.0, f64::max);
        face_factors = Some(FaceFactors {
            resolution: [nt, np],
            opposite: face[1],
            opposite_closed_form: parallel_rectangles(1.0, 1.0),
            adjacent: face[2..].to_vec(),
            adjacent_closed_form: perpendicular_rectangles(1.0, 1.0),
            max_row_sum_error,
            seconds: t.elapsed().as_secs_f64(),
        });
        progress(steps, steps);
    }
    Ok(CubeAccuracy {
        config: config.clone(),
        rows,
        face_factors,
        all_rows,
    })
}
