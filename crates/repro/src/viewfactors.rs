//! View factors against closed forms (Howell's catalogue), with more origins a patch,
//! and surface matrices at scale (the loft; a 20,536-facet urban canyon):
//! viewfactors.json and the report's section.

use crate::closed_form::{
    coaxial_discs, obstructed_parallel_squares, parallel_rectangles, perpendicular_rectangles,
    unit_cube_face_factor,
};
use crate::Error;
use glam::Vec3;
use rad_core::Rgb;
use rad_geometry::scenes::{cube, loft, urban_canyon};
use rad_geometry::{Material, PatchGrid, PolygonDesc, Scene, SceneDesc};
use rad_pipeline::viewfactors::{
    view_factors, Grouping, ViewFactorConfig, ViewFactorMethod, DEFAULT_ORIGINS,
};
use rad_pipeline::{Enclosure, Hemisphere, HemisphereConfig};
use serde::Serialize;
use std::time::Instant;

fn polygon(name: &str, vertices: Vec<Vec3>, grid: PatchGrid) -> PolygonDesc {
    PolygonDesc {
        name: name.into(),
        vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
        material: 0,
        grid,
        group: None,
        obstruction: false,
        two_sided: false,
    }
}

fn square(z: f32, up: bool, shift: f32) -> Vec<Vec3> {
    let mut v: Vec<Vec3> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .iter()
        .map(|&(x, y)| Vec3::new(x + shift, y, z))
        .collect();
    if !up {
        v.reverse();
    }
    v
}

fn one_material_scene(polygons: Vec<PolygonDesc>) -> SceneDesc {
    SceneDesc {
        materials: vec![Material {
            name: "white".into(),
            reflectance: Rgb([0.5; 3]),
            emission: Rgb::BLACK,
        }],
        polygons,
        camera: None,
    }
}

/// A regular 96-gon of radius 1 at height `z`, facing up or down.
fn disc(z: f32, up: bool) -> Vec<Vec3> {
    let mut v: Vec<Vec3> = (0..96)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / 96.0;
            Vec3::new(a.cos(), a.sin(), z)
        })
        .collect();
    if !up {
        v.reverse();
    }
    v
}

/// The 96-gon's own F: between the unit discs' and that of discs of the 96-gon's area.
pub fn polygon_disc_bounds() -> (f64, f64) {
    let r = (96.0 * (std::f64::consts::TAU / 96.0).sin() / (2.0 * std::f64::consts::PI)).sqrt();
    (coaxial_discs(r, r, 1.0), coaxial_discs(1.0, 1.0, 1.0))
}

/// A closed-form case: its scene, the factor (row, column) measured, the reference,
/// and how far the reference itself may be from the polygonal scene's value.
pub struct ClosedFormCase {
    pub name: &'static str,
    pub scene: SceneDesc,
    pub from: usize,
    pub to: usize,
    pub reference: f64,
    pub slack: f64,
}

/// The validation suite, each surface cut into 10 × 10 patches.
pub fn closed_form_cases() -> Vec<ClosedFormCase> {
    let grid = PatchGrid::Cells { nu: 10, nv: 10 };
    let wall = vec![Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 1.0, 1.0), Vec3::Z];
    let (lo, hi) = polygon_disc_bounds();
    let discs = |g: PatchGrid| {
        one_material_scene(vec![
            polygon("a", disc(0.0, true), g),
            polygon("b", disc(1.0, false), g),
        ])
    };
    vec![
        ClosedFormCase {
            name: "parallel unit squares 1 apart (Howell C-11)",
            scene: one_material_scene(vec![
                polygon("bottom", square(0.0, true, 0.0), grid),
                polygon("top", square(1.0, false, 0.0), grid),
            ]),
            from: 0,
            to: 1,
            reference: parallel_rectangles(1.0, 1.0),
            slack: 0.0,
        },
        ClosedFormCase {
            name: "perpendicular unit squares sharing an edge (C-14)",
            scene: one_material_scene(vec![
                polygon("floor", square(0.0, true, 0.0), grid),
                polygon("wall", wall, grid),
            ]),
            from: 0,
            to: 1,
            reference: perpendicular_rectangles(1.0, 1.0),
            slack: 0.0,
        },
        ClosedFormCase {
            name: "coaxial discs r = h = 1 as 96-gons, patches [10, 10] (C-41)",
            scene: discs(grid),
            from: 0,
            to: 1,
            reference: 0.5 * (lo + hi),
            slack: 0.5 * (hi - lo),
        },
        ClosedFormCase {
            name: "coaxial discs r = h = 1 as 96-gons, patch_size 0.2 (C-41)",
            scene: discs(PatchGrid::Size(0.2)),
            from: 0,
            to: 1,
            reference: 0.5 * (lo + hi),
            slack: 0.5 * (hi - lo),
        },
        ClosedFormCase {
            name: "parallel squares, a unit square half across between them",
            scene: one_material_scene(vec![
                polygon("bottom", square(0.0, true, 0.0), grid),
                polygon("top", square(1.0, false, 0.0), grid),
                polygon("obstruction", square(0.5, false, 0.5), grid),
            ]),
            from: 0,
            to: 1,
            reference: obstructed_parallel_squares(0.5),
            slack: 0.0,
        },
    ]
}

/// One case by one method (`hemisphere` at one origin count, or `auto`: in closed form
/// where no polygon comes between the pair, else from hemispheres at the default
/// origins).
#[derive(Clone, Debug, Serialize)]
pub struct OriginValue {
    pub method: &'static str,
    pub origins: u32,
    pub value: f64,
    /// |value − reference| less the reference's own slack (≥ 0).
    pub error: f64,
    pub seconds: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct CaseResult {
    pub name: &'static str,
    pub reference: f64,
    pub slack: f64,
    pub values: Vec<OriginValue>,
}

/// A surface matrix at scale.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRun {
    pub scene: &'static str,
    pub method: &'static str,
    /// Pairs of polygons in closed form and from hemispheres (auto).
    pub exact_pairs: usize,
    pub hemisphere_pairs: usize,
    pub by: &'static str,
    pub surfaces: usize,
    pub patches: usize,
    pub origins: u32,
    pub hemispheres: usize,
    pub resolution: [u32; 2],
    pub enclosure: &'static str,
    pub threads: usize,
    pub seconds: f64,
    pub nonzeros: usize,
    pub raw_row_sum_error_max: f64,
    pub raw_reciprocity_error_median: f64,
    pub raw_reciprocity_error_max: f64,
    pub max_change: f64,
}

/// viewfactors.json.
#[derive(Clone, Debug, Serialize)]
pub struct ViewFactorResults {
    pub resolution: [u32; 2],
    pub cases: Vec<CaseResult>,
    /// The unit cube (10 × 10 patches a face) at the default origins: the largest
    /// error of its opposite and adjacent face factors, from hemispheres and by auto.
    pub cube_max_error: f64,
    pub cube_max_error_auto: f64,
    pub scale: Vec<ScaleRun>,
}

fn options(
    scene: &Scene,
    method: ViewFactorMethod,
    origins: u32,
    enclosure: Enclosure,
) -> ViewFactorConfig {
    ViewFactorConfig {
        method,
        origins,
        enclosure,
        ..ViewFactorConfig::for_scene(scene)
    }
}

/// The suite at origins 1, 2 and 4 (quick: 45 × 180, origins 1 and 2), the cube, and
/// the loft's and the canyon's surface matrices (quick: at 9 × 36).
pub fn run(
    quick: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<ViewFactorResults, Error> {
    let (nt, np) = if quick { (45, 180) } else { (180, 720) };
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    let origins: &[u32] = if quick { &[1, 2] } else { &[1, 2, 4] };
    let cases = closed_form_cases();
    let mut out = Vec::new();
    for (k, case) in cases.into_iter().enumerate() {
        progress("view factors: closed forms", k, 5);
        let scene = Scene::new(case.scene)?;
        let mut values = Vec::new();
        let ways = origins
            .iter()
            .map(|&n| (ViewFactorMethod::Hemisphere, n))
            .chain([(ViewFactorMethod::Auto, DEFAULT_ORIGINS)]);
        for (method, n) in ways {
            let t = Instant::now();
            let config = options(&scene, method, n, Enclosure::Raw);
            let vf = view_factors(&scene, &hemi, &config, &|_| {})?;
            let value = vf.matrix.get(case.from, case.to);
            values.push(OriginValue {
                method: method.name(),
                origins: n,
                value,
                error: ((value - case.reference).abs() - case.slack).max(0.0),
                seconds: t.elapsed().as_secs_f64(),
            });
        }
        out.push(CaseResult {
            name: case.name,
            reference: case.reference,
            slack: case.slack,
            values,
        });
    }
    let scene = Scene::new(cube(10))?;
    let cube_error = |method| -> Result<f64, Error> {
        let config = options(&scene, method, DEFAULT_ORIGINS, Enclosure::Raw);
        let vf = view_factors(&scene, &hemi, &config, &|_| {})?;
        let mut worst: f64 = 0.0;
        for i in 0..6 {
            for j in 0..6 {
                let want = unit_cube_face_factor(&scene, i, j);
                worst = worst.max((vf.matrix.get(i, j) - want).abs());
            }
        }
        Ok(worst)
    };
    let cube_max_error = cube_error(ViewFactorMethod::Hemisphere)?;
    let cube_max_error_auto = cube_error(ViewFactorMethod::Auto)?;
    let big = if quick { (9, 36) } else { (nt, np) };
    let big_hemi = Hemisphere::new(HemisphereConfig::exact(big.0, big.1))?;
    let mut scale = Vec::new();
    let (hemisphere, auto) = (ViewFactorMethod::Hemisphere, ViewFactorMethod::Auto);
    let loft_n = if quick { 1 } else { 2 };
    let runs: [(&'static str, SceneDesc, ViewFactorMethod, u32, Enclosure); 3] = [
        ("loft", loft(), hemisphere, loft_n, Enclosure::Closed),
        ("loft", loft(), auto, loft_n, Enclosure::Closed),
        ("canyon", urban_canyon(), hemisphere, 1, Enclosure::Raw),
    ];
    for (k, (name, desc, method, n, enclosure)) in runs.into_iter().enumerate() {
        progress("view factors: at scale", k, 3);
        let scene = Scene::new(desc)?;
        let t = Instant::now();
        let config = options(&scene, method, n, enclosure);
        let vf = view_factors(&scene, &big_hemi, &config, &|_| {})?;
        let seconds = t.elapsed().as_secs_f64();
        let r = &vf.report;
        scale.push(ScaleRun {
            scene: name,
            method: method.name(),
            exact_pairs: vf.exact_pairs,
            hemisphere_pairs: vf.hemisphere_pairs,
            by: Grouping::Polygon.name(),
            surfaces: vf.names.len(),
            patches: scene.patches().len(),
            origins: n,
            hemispheres: scene.patches().len() * (n * n) as usize,
            resolution: [big.0, big.1],
            enclosure: enclosure.name(),
            threads: rayon::current_num_threads(),
            seconds,
            nonzeros: vf.matrix.rows.iter().map(Vec::len).sum(),
            raw_row_sum_error_max: r.raw.row_sum.max,
            raw_reciprocity_error_median: r.raw.reciprocity.median,
            raw_reciprocity_error_max: r.raw.reciprocity.max,
            max_change: r.max_change,
        });
    }
    progress("view factors", 1, 1);
    Ok(ViewFactorResults {
        resolution: [nt, np],
        cases: out,
        cube_max_error,
        cube_max_error_auto,
        scale,
    })
}
