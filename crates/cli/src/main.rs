//! `coherad`: patches, form factors, radiosity solutions and images of any scene file,
//! from the command line.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rad_accel::VoxelGrid;
use rad_estimator::{estimate_rows, windows, Mode, Source};
use rad_geometry::file::load_scene;
use rad_hemisphere::{compute_rows, compute_rows_scan, Hemisphere, HemisphereConfig, Row};
use rad_render::{render, RenderConfig, Shading, View};
use rad_repro::images::{auto_exposure, write_exr, write_png};
use rad_repro::output::{
    write_atomic, write_patches_json, write_row_json, write_rows_footer, write_rows_header,
};
use rad_repro::radiosity::{
    read_solution, solve, surfaces, SolutionFile, SolveOptions, SolverJson, Timings,
};
use rad_repro::{default_estimator, default_grid, parse_patch_list, parse_resolution};
use rad_solver::{FormFactors, SolveConfig, Solver};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "coherad",
    version,
    about = "Radiosity form factors by hemisphere ray casting"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// Target patch size for OBJ files (and JSON polygons that give no grid), in scene units.
    #[arg(long, global = true)]
    patch_size: Option<f64>,
}

#[derive(Subcommand)]
enum Command {
    /// Every patch of a scene: id, polygon, centre, normal, corners, area (JSON).
    Patches {
        scene: PathBuf,
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Form-factor rows by hemisphere ray casting (JSON).
    Formfactors {
        scene: PathBuf,
        /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
        #[arg(long, default_value = "180x720")]
        resolution: String,
        /// Patches whose rows to compute: "all" or a list like 3,17,40-59.
        #[arg(long, default_value = "all")]
        patches: String,
        /// exact: every hemisphere ray cast; estimated: 3x3 windows, centres cast, the rest estimated.
        #[arg(long, value_enum, default_value_t = Method::Exact)]
        method: Method,
        /// With --method estimated: the report's method (faithful) or visibility estimation (improved).
        #[arg(long, value_enum, default_value_t = EstimatorMode::Improved)]
        estimator: EstimatorMode,
        /// How exact hemispheres are made: scan (each polygon tested on the cells it can
        /// cover; fastest) or grid (each cell's ray through the voxel grid, the report's
        /// way). Both give the same rows, to the bit.
        #[arg(long, value_enum, default_value_t = Caster::Scan)]
        caster: Caster,
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Radiosity of every patch: form factors (exact or estimated), made reciprocal, solved (JSON).
    Solve {
        scene: PathBuf,
        /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
        #[arg(long, default_value = "180x720")]
        resolution: String,
        #[arg(long, value_enum, default_value_t = Method::Exact)]
        method: Method,
        #[arg(long, value_enum, default_value_t = EstimatorMode::Improved)]
        estimator: EstimatorMode,
        /// How exact hemispheres are made: scan (each polygon tested on the cells it can
        /// cover; fastest) or grid (each cell's ray through the voxel grid, the report's
        /// way). Both give the same rows, to the bit.
        #[arg(long, value_enum, default_value_t = Caster::Scan)]
        caster: Caster,
        /// gauss-seidel (gathering) or progressive (shooting by unshot power).
        #[arg(long, value_enum, default_value_t = SolverKind::GaussSeidel)]
        solver: SolverKind,
        /// Stop when max |E + rho F B - B| / max B is at most this.
        #[arg(long, default_value_t = 1e-9)]
        tolerance: f64,
        /// Solve the rows as computed, without making them reciprocal first (energy is then
        /// conserved only to their reciprocity error).
        #[arg(long)]
        raw: bool,
        /// The solution file (atomically: all or nothing).
        #[arg(long)]
        out: PathBuf,
    },
    /// An image of a solution from the scene's camera: 32-bit float EXR, optional PNG preview.
    Render {
        scene: PathBuf,
        /// A solution file written by `coherad solve` for this scene.
        #[arg(long)]
        solution: PathBuf,
        /// The EXR image (linear RGB radiosity).
        #[arg(long)]
        out: PathBuf,
        /// Also a tone-mapped sRGB PNG preview here.
        #[arg(long)]
        png: Option<PathBuf>,
        #[arg(long, default_value_t = 640)]
        width: u32,
        #[arg(long, default_value_t = 480)]
        height: u32,
        /// SAMPLES x SAMPLES rays a pixel.
        #[arg(long, default_value_t = 2)]
        samples: u32,
        /// flat: each patch's own value; smooth: interpolated from patch corners.
        #[arg(long, value_enum, default_value_t = ShadingKind::Smooth)]
        shading: ShadingKind,
        /// PNG exposure (multiplier before tone mapping); default: the 95th percentile of lit pixels maps to 0.8.
        #[arg(long)]
        exposure: Option<f32>,
    },
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SolverKind {
    GaussSeidel,
    Progressive,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ShadingKind {
    Flat,
    Smooth,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Method {
    Exact,
    Estimated,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Caster {
    Scan,
    Grid,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum EstimatorMode {
    Faithful,
    Improved,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("error: --threads must be at least 1");
            return ExitCode::from(2);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("error: cannot start {n} threads: {e}");
            return ExitCode::FAILURE;
        }
    }
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Writes through `fill` to `out` (atomically) or to standard output.
fn emit(
    out: Option<&Path>,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), String> {
    match out {
        Some(path) => write_atomic(path, fill).map_err(|e| e.to_string()),
        None => {
            let stdout = std::io::stdout();
            let mut lock = std::io::BufWriter::new(stdout.lock());
            fill(&mut lock)
                .and_then(|_| lock.flush())
                .map_err(|e| format!("cannot write to standard output: {e}"))
        }
    }
}

fn run(cli: &Cli) -> Result<(), String> {
    match &cli.command {
        Command::Patches { scene, out } => {
            let scene = load_scene(scene, cli.patch_size).map_err(|e| e.to_string())?;
            emit(out.as_deref(), |w| write_patches_json(w, &scene))
        }
        Command::Formfactors {
            scene: path,
            resolution,
            patches,
            out,
            method,
            estimator,
            caster,
        } => {
            let (nt, np) = parse_resolution(resolution).map_err(|e| e.to_string())?;
            let hemi =
                Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(|e| e.to_string())?;
            let scene = load_scene(path, cli.patch_size).map_err(|e| e.to_string())?;
            let ids =
                parse_patch_list(patches, scene.patches().len()).map_err(|e| e.to_string())?;
            let (rows, sources, method_name) =
                form_factor_rows(&scene, &hemi, &ids, *method, *estimator, *caster)?;
            let leaked: Vec<u32> = rows
                .iter()
                .filter(|r| r.escaped > 0.0)
                .map(|r| r.patch)
                .collect();
            if !leaked.is_empty() {
                eprintln!(
                    "warning: {} row(s) lose form factor to rays that leave the scene (first: patch {}); the scene is not closed",
                    leaked.len(),
                    leaked[0]
                );
            }
            let backs = rows.iter().filter(|r| r.back > 0.0).count();
            if backs > 0 {
                eprintln!("warning: {backs} row(s) see polygons from behind (their \"back\" form factor is > 0)");
            }
            emit(out.as_deref(), |w| {
                write_rows_header(w, (nt, np), method_name, scene.patches().len())?;
                for (k, (r, src)) in rows.iter().zip(&sources).enumerate() {
                    write_row_json(w, r, *src, k == 0)?;
                }
                write_rows_footer(w)
            })
        }
        Command::Solve {
            scene: path,
            resolution,
            method,
            estimator,
            caster,
            solver,
            tolerance,
            raw,
            out,
        } => {
            if !(tolerance.is_finite() && *tolerance > 0.0) {
                return Err(format!(
                    "--tolerance must be finite and > 0, not {tolerance}"
                ));
            }
            if *raw && *solver == SolverKind::Progressive {
                return Err(
                    "--raw with --solver progressive cannot converge: shooting takes \
                     F_ji from F_ij by reciprocity, which raw rows hold only to their \
                     discretisation error; use --solver gauss-seidel, or drop --raw"
                        .into(),
                );
            }
            let (nt, np) = parse_resolution(resolution).map_err(|e| e.to_string())?;
            let hemi =
                Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(|e| e.to_string())?;
            let scene = load_scene(path, cli.patch_size).map_err(|e| e.to_string())?;
            let n = scene.patches().len();
            let all: Vec<u32> = (0..n as u32).collect();
            let t = std::time::Instant::now();
            let (rows, _, method_name) =
                form_factor_rows(&scene, &hemi, &all, *method, *estimator, *caster)?;
            let form_factors_seconds = t.elapsed().as_secs_f64();
            let ff = FormFactors::from_rows(n, rows.iter().map(|r| (r.patch, &r.entries[..])))
                .map_err(|e| e.to_string())?;
            drop(rows);
            let opts = SolveOptions {
                solver: match solver {
                    SolverKind::GaussSeidel => Solver::GaussSeidel,
                    SolverKind::Progressive => Solver::Progressive,
                },
                config: SolveConfig {
                    tolerance: *tolerance,
                    ..SolveConfig::default()
                },
                reciprocal: !raw,
            };
            eprintln!("solving {n} patches ({})", opts.solver.name());
            let surf = surfaces(&scene);
            let solved = solve(&ff, &surf, &opts).map_err(|e| e.to_string())?;
            if let Some(rec) = solved.reciprocity.filter(|r| !r.converged) {
                eprintln!(
                    "warning: the reciprocal scaling stopped after {} products with rows off their sums by up to {:.1e}; energy is conserved only to that",
                    rec.iterations, rec.max_row_sum_error
                );
            }
            let r = &solved.solution.report;
            eprintln!(
                "{} after {} iterations, residual {:.1e}; energy imbalance {:.1e}",
                if r.converged {
                    "converged"
                } else {
                    "NOT converged"
                },
                r.iterations,
                r.residual,
                solved.balance.relative_imbalance
            );
            let file = SolutionFile {
                scene: &path.display().to_string(),
                resolution: [nt, np],
                method: method_name,
                n_patches: n,
                solver: SolverJson::new(&solved, &opts),
                timings: Timings {
                    form_factors_seconds,
                    scaling_seconds: solved.scaling_seconds,
                    solve_seconds: solved.solve_seconds,
                },
                ambient: solved.solution.ambient,
                radiosity: solved.solution.radiosity.clone(),
            };
            let text = serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?;
            emit(Some(out), |w| w.write_all(text.as_bytes()))
        }
        Command::Render {
            scene: path,
            solution,
            out,
            png,
            width,
            height,
            samples,
            shading,
            exposure,
        } => {
            if let Some(x) = exposure {
                if png.is_none() {
                    return Err("--exposure sets the PNG preview's exposure: give --png too".into());
                }
                if !(x.is_finite() && *x > 0.0) {
                    return Err(format!("--exposure must be finite and > 0, not {x}"));
                }
            }
            let scene = load_scene(path, cli.patch_size).map_err(|e| e.to_string())?;
            let text = std::fs::read_to_string(solution)
                .map_err(|e| format!("cannot read {}: {e}", solution.display()))?;
            let b =
                read_solution(&text, &scene).map_err(|e| format!("{}: {e}", solution.display()))?;
            let view = View::of_scene(&scene, *width, *height).map_err(|e| e.to_string())?;
            let grid = VoxelGrid::build(&scene, &default_grid()).map_err(|e| e.to_string())?;
            let cfg = RenderConfig {
                samples: *samples,
                shading: match shading {
                    ShadingKind::Flat => Shading::Flat,
                    ShadingKind::Smooth => Shading::Smooth,
                },
            };
            let img = render(&scene, &grid, &view, &b, &cfg).map_err(|e| e.to_string())?;
            write_exr(out, &img).map_err(|e| e.to_string())?;
            if let Some(p) = png {
                let e = exposure.unwrap_or_else(|| auto_exposure(&img));
                write_png(p, &img, e).map_err(|e| e.to_string())?;
            }
            Ok(())
        }
    }
}

type Rows = (Vec<Row>, Vec<Option<u32>>, &'static str);

/// Rows of `ids` by `method`, with a progress bar on long jobs; sources are the patches
/// estimated rows came from. Exact rows come from `caster`; estimated rows' window
/// centres are always cast through the grid (the estimator reads its boundary lists).
fn form_factor_rows(
    scene: &rad_geometry::Scene,
    hemi: &Hemisphere,
    ids: &[u32],
    method: Method,
    estimator: EstimatorMode,
    caster: Caster,
) -> Result<Rows, String> {
    let (nt, np) = (hemi.n_theta(), hemi.n_phi());
    // The voxel grid, for the ways that cast rays (not the scan).
    let grid = || VoxelGrid::build(scene, &default_grid()).map_err(|e| e.to_string());
    // A bar when the job is long: over about 50 M rays.
    let rays = ids.len() as u64 * hemi.n_cells() as u64;
    let bar = if rays > 50_000_000 {
        ProgressBar::new(ids.len() as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{msg} [{bar:40}] {pos}/{len} {prefix}, {elapsed} elapsed, eta {eta}",
        )
        .expect("a valid template")
        .progress_chars("=> "),
    );
    let out: Rows = match method {
        Method::Exact => {
            bar.set_message(format!("exact form factors {nt}x{np}"));
            bar.set_prefix("rows");
            let progress = |n: usize| bar.set_position(n as u64);
            let rows = match caster {
                Caster::Scan => compute_rows_scan(scene, hemi, ids, &progress),
                Caster::Grid => compute_rows(scene, &grid()?, hemi, ids, &progress),
            }
            .map_err(|e| e.to_string())?;
            let n = rows.len();
            (rows, vec![None; n], "exact")
        }
        Method::Estimated => {
            let mode = match estimator {
                EstimatorMode::Faithful => Mode::Faithful,
                EstimatorMode::Improved => Mode::Improved,
            };
            let config = default_estimator(mode);
            bar.set_length(windows(scene).len() as u64);
            bar.set_prefix("windows");
            bar.set_message(format!("estimated form factors {nt}x{np}"));
            let (rows, stats) = estimate_rows(scene, &grid()?, hemi, &config, ids, &|n| {
                bar.set_position(n as u64)
            })
            .map_err(|e| e.to_string())?;
            bar.finish_and_clear();
            eprintln!(
                    "{} rows cast exactly (window centres), {} estimated, {} cast exactly after needing real rays for over {:.0} % of their cells ({} real rays)",
                    stats.exact,
                    stats.estimated,
                    stats.fallback_exact,
                    100.0 * config.max_real_ray_share,
                    stats.real_rays
                );
            let sources = rows
                .iter()
                .map(|r| match r.source {
                    Source::Exact | Source::ExactFallback { .. } => None,
                    Source::Estimated { from } => Some(from),
                })
                .collect();
            let name = if mode == Mode::Faithful {
                "estimated/faithful"
            } else {
                "estimated/improved"
            };
            (rows.into_iter().map(|r| r.row).collect(), sources, name)
        }
    };
    bar.finish_and_clear();
    Ok(out)
}
