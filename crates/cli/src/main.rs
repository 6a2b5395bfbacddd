//! `coherad`: patches and form factors of any scene file, from the command line.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rad_accel::VoxelGrid;
use rad_estimator::{estimate_rows, windows, Mode, Source};
use rad_geometry::file::load_scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig, Row};
use rad_repro::output::{
    write_atomic, write_patches_json, write_row_json, write_rows_footer, write_rows_header,
};
use rad_repro::{default_estimator, default_grid, parse_patch_list, parse_resolution};
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
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Method {
    Exact,
    Estimated,
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
        } => {
            let (nt, np) = parse_resolution(resolution).map_err(|e| e.to_string())?;
            let hemi =
                Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(|e| e.to_string())?;
            let scene = load_scene(path, cli.patch_size).map_err(|e| e.to_string())?;
            let ids =
                parse_patch_list(patches, scene.patches().len()).map_err(|e| e.to_string())?;
            let grid = VoxelGrid::build(&scene, &default_grid()).map_err(|e| e.to_string())?;
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
            let (rows, sources, method_name): (Vec<Row>, Vec<Option<u32>>, &str) = match method {
                Method::Exact => {
                    bar.set_message(format!("exact form factors {nt}x{np}"));
                    bar.set_prefix("rows");
                    let rows =
                        compute_rows(&scene, &grid, &hemi, &ids, &|n| bar.set_position(n as u64))
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
                    bar.set_length(windows(&scene).len() as u64);
                    bar.set_prefix("windows");
                    bar.set_message(format!("estimated form factors {nt}x{np}"));
                    let (rows, stats) = estimate_rows(&scene, &grid, &hemi, &config, &ids, &|n| {
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
    }
}
