//! `coherad`: patches and form factors of any scene file, from the command line.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rad_accel::VoxelGrid;
use rad_geometry::file::load_scene;
use rad_hemisphere::{compute_rows, Hemisphere, HemisphereConfig};
use rad_repro::output::{
    write_atomic, write_patches_json, write_row_json, write_rows_footer, write_rows_header,
};
use rad_repro::{default_grid, parse_patch_list, parse_resolution};
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
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
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
                    "{msg} [{bar:40}] {pos}/{len} rows, {elapsed} elapsed, eta {eta}",
                )
                .expect("a valid template")
                .progress_chars("=> "),
            );
            bar.set_message(format!("form factors {nt}x{np}"));
            let rows = compute_rows(&scene, &grid, &hemi, &ids, &|n| bar.set_position(n as u64))
                .map_err(|e| e.to_string())?;
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
                write_rows_header(w, (nt, np), "exact", scene.patches().len())?;
                for (k, r) in rows.iter().enumerate() {
                    write_row_json(w, r, k == 0)?;
                }
                write_rows_footer(w)
            })
        }
    }
}
