//! The report's Table 1 and Table 2 on our loft, its figures 7-9 (images with and
//! without estimation and their relative difference), and the radiosity solutions of
//! the cube and the Cornell box with their energy balance.

use crate::Error;
use rad_accel::VoxelGrid;
use rad_core::PatchId;
use rad_estimator::{windows, Mode};
use rad_geometry::scenes::{cornell_box, cube, loft, CORNELL_PATCH_MM};
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, Row, Scan};
use rad_pipeline::solve::{solve, surfaces, SceneSolveConfig, Solved, SolverJson};
use rad_pipeline::{default_grid, CasterKind, RowMethod};
use rad_render::{relative_difference, render, DiffStats, Image, RenderConfig, Shading, View};
use rad_solver::{FormFactors, SolveConfig, Solver};
use serde::Serialize;
use std::time::Instant;

/// The estimator mode used for the loft's "with estimation" image and by default in
/// the CLI: improved (its rows are within noise of exact; see REPORT.md).
pub const DEFAULT_MODE: Mode = Mode::Improved;

/// Settings of the radiosity runs.
#[derive(Clone, Debug, Serialize)]
pub struct SpeedupConfig {
    pub resolution: (u32, u32),
    /// Loft image size and samples per pixel side.
    pub image: (u32, u32),
    pub samples: u32,
    pub cornell_image: (u32, u32),
    /// About this many hemispheres in the subset (the report's 500).
    pub subset_hemispheres: usize,
    pub tolerance: f64,
    /// Cornell box patch size (mm).
    pub cornell_patch_mm: f32,
}

impl SpeedupConfig {
    pub fn new(quick: bool) -> SpeedupConfig {
        if quick {
            SpeedupConfig {
                resolution: (24, 96),
                image: (160, 120),
                samples: 1,
                cornell_image: (128, 128),
                subset_hemispheres: 100,
                tolerance: 1e-9,
                cornell_patch_mm: 80.0,
            }
        } else {
            SpeedupConfig {
                resolution: (180, 720),
                image: (640, 480),
                samples: 2,
                cornell_image: (512, 512),
                subset_hemispheres: 500,
                tolerance: 1e-9,
                cornell_patch_mm: CORNELL_PATCH_MM,
            }
        }
    }
}

/// One way of computing all the rows asked for, timed.
#[derive(Clone, Debug, Serialize)]
pub struct MethodRun {
    /// [`RowMethod::name`].
    pub method: String,
    pub exact: bool,
    pub hemispheres: usize,
    /// Wall time of the rows, all threads.
    pub seconds: f64,
    /// `seconds / hemispheres`.
    pub ms_per_hemisphere: f64,
    /// Exact (grid) time over this method's time, same run.
    pub speedup_vs_exact: f64,
    /// Exact (scan) time over this method's time, same run.
    pub speedup_vs_scan: Option<f64>,
    /// A run through the scan: its rows equal the same method's through the grid, bit
    /// for bit (compared by hash).
    pub identical_to_grid: Option<bool>,
    pub exact_hemispheres: usize,
    pub estimated_hemispheres: usize,
    pub fallback_exact: usize,
    /// Thread-time per exact hemisphere and per estimated one (fallbacks included).
    pub ms_per_exact: f64,
    pub ms_per_estimate: f64,
    /// Improved mode: real rays per estimated hemisphere.
    pub real_rays_per_estimate: f64,
    /// Mean over the estimated rows of `Σ_j |F_e − F|` against the exact rows.
    pub mean_row_l1_vs_exact: Option<f64>,
    pub stored_entries: usize,
}

/// A solve and the image it gives.
#[derive(Clone, Debug, Serialize)]
pub struct SolveRun {
    pub method: String,
    pub solver: SolverJson,
    pub scaling_seconds: f64,
    pub solve_seconds: f64,
    pub render_seconds: f64,
    /// Against the exact image (None for the exact one).
    pub image_difference: Option<DiffJson>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct DiffJson {
    pub pixels: u64,
    pub mean: f64,
    pub p99: f64,
    pub max: f64,
    pub over_10_percent: f64,
}

impl From<DiffStats> for DiffJson {
    fn from(d: DiffStats) -> Self {
        DiffJson {
            pixels: d.pixels,
            mean: d.mean,
            p99: d.p99,
            max: d.max,
            over_10_percent: d.over_10_percent,
        }
    }
}

/// The report's own figures, for the tables.
#[derive(Clone, Debug, Serialize)]
pub struct ReportFigures {
    pub hemispheres: usize,
    pub seconds_with_estimation: f64,
    pub seconds_without_estimation: f64,
    pub exact_hemispheres: usize,
    pub estimated_hemispheres: usize,
    pub seconds_per_exact: f64,
    pub seconds_per_estimate: f64,
}

pub const REPORT_FIGURES: ReportFigures = ReportFigures {
    hemispheres: 500,
    seconds_with_estimation: 103.0 * 60.0 + 55.0,
    seconds_without_estimation: 313.0 * 60.0 + 46.0,
    exact_hemispheres: 66,
    estimated_hemispheres: 434,
    seconds_per_exact: 37.65,
    seconds_per_estimate: 5.73,
};

/// Table 1, Table 2 and the loft's images (loft_speedup.json).
#[derive(Clone, Debug, Serialize)]
pub struct LoftSpeedup {
    pub config: SpeedupConfig,
    pub polygons: usize,
    pub patches: usize,
    pub windows: usize,
    pub threads: usize,
    pub default_mode: &'static str,
    /// All patches: each method of Table 1, one after the other.
    pub all: Vec<MethodRun>,
    /// The report-like subset: whole windows, every k-th.
    pub subset: Vec<MethodRun>,
    pub subset_window_stride: usize,
    pub solves: Vec<SolveRun>,
    pub report: ReportFigures,
    pub wall_seconds: f64,
}

/// The cube's and Cornell box's solutions (solutions in loft_speedup.json's sibling
/// radiosity.json).
#[derive(Clone, Debug, Serialize)]
pub struct SceneSolves {
    pub scene: String,
    pub patches: usize,
    pub resolution: (u32, u32),
    pub form_factor_seconds: f64,
    pub gauss_seidel: SolverJson,
    pub progressive: SolverJson,
    /// `max |B_gs − B_prog| / max B`.
    pub solver_difference: f64,
    /// Furnace: every patch emits 1 with reflectance 0.5 (closed scenes only):
    /// `max |B − 2| / 2`.
    pub furnace_max_rel_error: Option<f64>,
}

/// Everything this module produces: JSON-able results and images.
pub struct Radiosity {
    pub loft: LoftSpeedup,
    pub scenes: Vec<SceneSolves>,
    /// (file stem, image, exposure group): images of a group share the exposure of the
    /// group's first.
    pub images: Vec<(String, Image, bool)>,
}

/// `Σ_i Σ_j |a_ij − b_ij|` over rows `rows`, divided by their number: the mean L1
/// distance of two matrices' rows.
pub fn mean_row_l1(a: &FormFactors, b: &FormFactors, rows: &[PatchId]) -> f64 {
    let total: f64 = rows.iter().map(|&i| a.row_l1_distance(b, i)).sum();
    total / rows.len().max(1) as f64
}

fn rows_to_matrix(n: usize, rows: &[Row]) -> Result<FormFactors, Error> {
    Ok(FormFactors::from_rows(
        n,
        rows.iter().map(|r| (r.patch, &r.entries[..])),
    )?)
}

/// Table 1's methods, in the order they run: exact through the grid (the report's
/// "without estimation") and by scan, the report's schedule with each estimator mode
/// with centres through the grid (the report's "with estimation"), then with centres
/// (and fallbacks and real rays) through the scan, our fastest caster.
const TABLE_1: [RowMethod; 6] = [
    RowMethod::Exact {
        caster: CasterKind::Grid,
    },
    RowMethod::Exact {
        caster: CasterKind::Scan,
    },
    RowMethod::Estimated {
        mode: Mode::Faithful,
        centres: CasterKind::Grid,
    },
    RowMethod::Estimated {
        mode: Mode::Improved,
        centres: CasterKind::Grid,
    },
    RowMethod::Estimated {
        mode: Mode::Faithful,
        centres: CasterKind::Scan,
    },
    RowMethod::Estimated {
        mode: Mode::Improved,
        centres: CasterKind::Scan,
    },
];

/// A hash of a row's every bit, to compare two runs' rows without keeping both.
fn row_hash(r: &Row) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    r.patch.hash(&mut h);
    for (j, f) in &r.entries {
        (j, f.to_bits()).hash(&mut h);
    }
    (r.back.to_bits(), r.escaped.to_bits()).hash(&mut h);
    h.finish()
}

/// Rows of `patches` by one method, timed.
fn run_method(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Vec<Row>, MethodRun), Error> {
    let t = Instant::now();
    let made = rad_pipeline::rows(scene, hemi, method, patches, progress)?;
    let (rows, stats) = (made.rows, made.stats);
    let seconds = t.elapsed().as_secs_f64();
    let per = |s: f64, n: usize| if n > 0 { 1e3 * s / n as f64 } else { 0.0 };
    let exact_ms = if method.is_exact() {
        // Thread-time of an exact hemisphere: wall time times threads over count.
        per(seconds * rayon::current_num_threads() as f64, stats.exact)
    } else {
        per(stats.exact_seconds, stats.exact)
    };
    let estimated = stats.estimated + stats.fallback_exact;
    let run = MethodRun {
        method: method.name(),
        exact: method.is_exact(),
        hemispheres: rows.len(),
        seconds,
        ms_per_hemisphere: per(seconds, rows.len()),
        speedup_vs_exact: 1.0,
        speedup_vs_scan: None,
        identical_to_grid: None,
        exact_hemispheres: stats.exact,
        estimated_hemispheres: stats.estimated,
        fallback_exact: stats.fallback_exact,
        ms_per_exact: exact_ms,
        ms_per_estimate: per(stats.estimate_seconds, estimated),
        real_rays_per_estimate: if estimated > 0 {
            stats.real_rays as f64 / estimated as f64
        } else {
            0.0
        },
        mean_row_l1_vs_exact: None,
        stored_entries: rows.iter().map(|r| r.entries.len()).sum(),
    };
    Ok((rows, run))
}

/// Every method's run, and the matrices of the rows through the grid (exact, and each
/// estimator mode's).
type Runs = (Vec<MethodRun>, Vec<(RowMethod, FormFactors)>);

/// Runs every method of [`TABLE_1`] on `patches`, in this order, in this process; the
/// rows through the scan are compared with the same method's through the grid (by
/// hash: they must be equal, bit for bit); the matrices of the grid's runs come back
/// (on all patches).
fn all_methods(
    scene: &Scene,
    hemi: &Hemisphere,
    patches: &[PatchId],
    estimated_ids: &[PatchId],
    stage: &str,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Runs, Error> {
    let n = scene.patches().len();
    let full = patches.len() == n;
    let mut runs: Vec<MethodRun> = Vec::new();
    let mut matrices = Vec::new();
    let mut grid_hashes: Vec<(&'static str, Vec<u64>)> = Vec::new();
    for method in TABLE_1 {
        let label = format!("{stage}, {method}");
        let total = patches.len();
        // (Every 500 rows or so: estimated rows arrive a window at a time.)
        let reported = std::sync::atomic::AtomicUsize::new(0);
        let (rows, mut run) = run_method(scene, hemi, method, patches, &|k| {
            let step = k / 500;
            if reported.fetch_max(step, std::sync::atomic::Ordering::Relaxed) < step || k == total {
                progress(&label, k, total)
            }
        })?;
        if let Some(exact) = runs.first() {
            run.speedup_vs_exact = exact.seconds / run.seconds;
        }
        if let Some(scan) = runs.get(1) {
            run.speedup_vs_scan = Some(scan.seconds / run.seconds);
        }
        let hashes: Vec<u64> = rows.iter().map(row_hash).collect();
        match method.caster() {
            CasterKind::Grid => grid_hashes.push((method.rows_name(), hashes)),
            CasterKind::Scan | CasterKind::Hierarchy | CasterKind::Facets => {
                run.identical_to_grid = grid_hashes
                    .iter()
                    .find(|(name, _)| *name == method.rows_name())
                    .map(|(_, h)| *h == hashes);
            }
        }
        if method == TABLE_1[1] {
            run.speedup_vs_scan = Some(1.0);
        }
        if full && method.caster() == CasterKind::Grid {
            let m = rows_to_matrix(n, &rows)?;
            drop(rows);
            if let Some((_, exact)) = matrices.first() {
                run.mean_row_l1_vs_exact = Some(mean_row_l1(exact, &m, estimated_ids));
            }
            matrices.push((method, m));
        }
        runs.push(run);
    }
    Ok((runs, matrices))
}

/// Table 1, Table 2, the loft images, and the cube's and Cornell box's solutions.
pub fn run(
    quick: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<Radiosity, Error> {
    let wall = Instant::now();
    let cfg = SpeedupConfig::new(quick);
    let scene = Scene::new(loft())?;
    let n = scene.patches().len();
    let grid = VoxelGrid::build(&scene, &default_grid())?;
    let hemi = Hemisphere::new(HemisphereConfig::exact(cfg.resolution.0, cfg.resolution.1))?;
    let all: Vec<PatchId> = (0..n as PatchId).collect();
    let wins = windows(&scene);
    let estimated_ids: Vec<PatchId> = wins
        .iter()
        .flat_map(|w| w.estimated.iter().copied())
        .collect();

    let (runs_all, matrices) = all_methods(
        &scene,
        &hemi,
        &all,
        &estimated_ids,
        "Table 1, all loft patches",
        progress,
    )?;

    // The subset: every k-th window, about `subset_hemispheres` hemispheres.
    let per_window = n as f64 / wins.len() as f64;
    let stride =
        ((wins.len() as f64 * per_window / cfg.subset_hemispheres as f64).round() as usize).max(1);
    let subset: Vec<PatchId> = wins
        .iter()
        .step_by(stride)
        .flat_map(|w| std::iter::once(w.centre).chain(w.estimated.iter().copied()))
        .collect();
    let (runs_subset, _) = all_methods(&scene, &hemi, &subset, &[], "Table 1, subset", progress)?;

    // Solve and render each.
    let (solves, mut images) = solve_and_render(&scene, &grid, &cfg, &matrices, progress)?;
    drop(matrices);

    let mut scenes = Vec::new();
    let cube_scene = Scene::new(cube(10))?;
    scenes.push(scene_solves(
        "cube",
        &cube_scene,
        cfg.resolution,
        cfg.tolerance,
        true,
        progress,
    )?);
    let cornell = Scene::new(cornell_box(cfg.cornell_patch_mm))?;
    let (solves_c, b) = scene_solves_with_b(
        "cornell",
        &cornell,
        cfg.resolution,
        cfg.tolerance,
        false,
        progress,
    )?;
    scenes.push(solves_c);
    progress("render the Cornell box", 1, 1);
    let cgrid = VoxelGrid::build(&cornell, &default_grid())?;
    let cview = View::of_scene(&cornell, cfg.cornell_image.0, cfg.cornell_image.1)?;
    let cimg = render(
        &cornell,
        &cgrid,
        &cview,
        &b,
        &RenderConfig {
            samples: cfg.samples.max(2),
            shading: Shading::Smooth,
        },
    )?;
    images.push(("cornell".to_string(), cimg, false));

    Ok(Radiosity {
        loft: LoftSpeedup {
            polygons: scene.polygons().len(),
            patches: n,
            windows: wins.len(),
            threads: rayon::current_num_threads(),
            default_mode: DEFAULT_MODE.name(),
            all: runs_all,
            subset: runs_subset,
            subset_window_stride: stride,
            solves,
            report: REPORT_FIGURES,
            wall_seconds: wall.elapsed().as_secs_f64(),
            config: cfg,
        },
        scenes,
        images,
    })
}

/// Solves each matrix of the loft (the grid's exact rows first) and renders it; each
/// image after the first is compared with the first (the report's figures 7 to 9).
fn solve_and_render(
    scene: &Scene,
    grid: &VoxelGrid,
    cfg: &SpeedupConfig,
    matrices: &[(RowMethod, FormFactors)],
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<(Vec<SolveRun>, Vec<(String, Image, bool)>), Error> {
    let s = surfaces(scene);
    let opts = SceneSolveConfig {
        solver: Solver::GaussSeidel,
        config: SolveConfig {
            tolerance: cfg.tolerance,
            ..SolveConfig::default()
        },
        reciprocal: true,
        ..SceneSolveConfig::default()
    };
    let view = View::of_scene(scene, cfg.image.0, cfg.image.1)?;
    let rcfg = RenderConfig {
        samples: cfg.samples,
        shading: Shading::Smooth,
    };
    let mut solves = Vec::new();
    let mut images = Vec::new();
    let mut exact_image: Option<Image> = None;
    for (k, (method, m)) in matrices.iter().enumerate() {
        progress(
            &format!("solve and render the loft, {method}"),
            k + 1,
            matrices.len(),
        );
        let solved: Solved = solve(m, &s, &opts)?;
        let t = Instant::now();
        let img = render(scene, grid, &view, &solved.solution.display(&s), &rcfg)?;
        let render_seconds = t.elapsed().as_secs_f64();
        let mut image_difference = None;
        let mode = method.mode();
        match &exact_image {
            None => {
                images.push(("loft_exact".to_string(), img.clone(), true));
                exact_image = Some(img);
            }
            Some(exact) => {
                let (diff, stats) = relative_difference(exact, &img)?;
                image_difference = Some(stats.into());
                let name = mode.expect("estimated").name();
                let (stem, diff_stem) = if mode == Some(DEFAULT_MODE) {
                    ("loft_estimated".to_string(), "loft_reldiff".to_string())
                } else {
                    (
                        format!("loft_estimated_{name}"),
                        format!("loft_reldiff_{name}"),
                    )
                };
                images.push((stem, img, true));
                images.push((diff_stem, diff, false));
            }
        }
        solves.push(SolveRun {
            method: method.name(),
            solver: SolverJson::new(&solved, &opts),
            scaling_seconds: solved.scaling_seconds,
            solve_seconds: solved.solve_seconds,
            render_seconds,
            image_difference,
        });
    }
    Ok((solves, images))
}

fn scene_solves(
    name: &str,
    scene: &Scene,
    res: (u32, u32),
    tolerance: f64,
    closed: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<SceneSolves, Error> {
    Ok(scene_solves_with_b(name, scene, res, tolerance, closed, progress)?.0)
}

/// Exact rows of every patch (by scan), both solvers, the furnace if the scene is closed; the
/// Gauss-Seidel radiosities (for display) come back too.
fn scene_solves_with_b(
    name: &str,
    scene: &Scene,
    res: (u32, u32),
    tolerance: f64,
    closed: bool,
    progress: &(dyn Fn(&str, usize, usize) + Sync),
) -> Result<(SceneSolves, Vec<[f64; 3]>), Error> {
    let n = scene.patches().len();
    progress(&format!("{name}: form factors and solutions"), 0, 1);
    let hemi = Hemisphere::new(HemisphereConfig::exact(res.0, res.1))?;
    let all: Vec<PatchId> = (0..n as PatchId).collect();
    let t = Instant::now();
    // Exact rows by polygon scan: the grid's rows to the bit (checked on the loft in
    // Table 1), in a fraction of the time.
    let rows = compute_rows(scene, &Scan, &hemi, &all, &|_| {})?;
    let form_factor_seconds = t.elapsed().as_secs_f64();
    let ff = rows_to_matrix(n, &rows)?;
    drop(rows);
    let mut s = surfaces(scene);
    if s.emission.iter().all(|e| e.iter().all(|c| *c == 0.0)) {
        // The cube has no light: the four ceiling patches around its centre emit 1.
        let ceiling = 1;
        let (nu, _) = scene.polygons()[ceiling].grid();
        let mid = nu as usize / 2;
        for (i, j) in [
            (mid - 1, mid - 1),
            (mid, mid - 1),
            (mid - 1, mid),
            (mid, mid),
        ] {
            s.emission[scene.polygons()[ceiling].cell_patch(i as u32, j as u32) as usize] =
                [1.0; 3];
        }
    }
    let opts = |solver| SceneSolveConfig {
        solver,
        config: SolveConfig {
            tolerance,
            ..SolveConfig::default()
        },
        reciprocal: true,
        ..SceneSolveConfig::default()
    };
    let gs = solve(&ff, &s, &opts(Solver::GaussSeidel))?;
    let pr = solve(&ff, &s, &opts(Solver::Progressive))?;
    let scale = gs
        .solution
        .radiosity
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(*v));
    let solver_difference = gs
        .solution
        .radiosity
        .iter()
        .zip(&pr.solution.radiosity)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
        .fold(0.0f64, f64::max)
        / scale;
    let furnace_max_rel_error = if closed {
        let f = rad_solver::Surfaces {
            area: s.area.clone(),
            emission: vec![[1.0; 3]; n],
            reflectance: vec![[0.5; 3]; n],
        };
        let sol = solve(&ff, &f, &opts(Solver::GaussSeidel))?;
        Some(
            sol.solution
                .radiosity
                .iter()
                .flatten()
                .map(|b| (b - 2.0).abs() / 2.0)
                .fold(0.0f64, f64::max),
        )
    } else {
        None
    };
    let b = gs.solution.display(&s);
    Ok((
        SceneSolves {
            scene: name.to_string(),
            patches: n,
            resolution: res,
            form_factor_seconds,
            gauss_seidel: SolverJson::new(&gs, &opts(Solver::GaussSeidel)),
            progressive: SolverJson::new(&pr, &opts(Solver::Progressive)),
            solver_difference,
            furnace_max_rel_error,
        },
        b,
    ))
}
