//! `coherad`: patches, form factors, radiosity solutions and images of any scene file,
//! from the command line.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use rad_pipeline::images::{radiance_of, render_to_files};
use rad_pipeline::output::{
    write_atomic, write_patches_json, write_row_json, write_rows_footer, write_rows_header,
};
use rad_pipeline::share::{self, Peers};
use rad_pipeline::solve::{read_solution, settle_auto, solve_scene_shared, SolveOptions};
use rad_pipeline::viewfactors::{
    area_rows, check_format, count_surfaces, row_patches, stream_patch_matrix, view_factors,
    view_factors_of_rows, write_view_factors, Grouping, MatrixFormat, ViewFactorOptions,
    ViewFactorRun,
};
use rad_pipeline::{
    parse_patch_list, parse_resolution, Camera, CasterKind, Enclosure, EstimateStats, Hemisphere,
    HemisphereConfig, LoadOptions, Mode, Progress, RenderConfig, Rgb, RowMethod, SceneFile,
    Shading, Solver, Storage, View,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by `--quiet`: notes, summaries and progress bars are not shown (warnings and
/// errors are).
static QUIET: AtomicBool = AtomicBool::new(false);

/// Set on MPI ranks but the first: rank 0 speaks for the run, so the others show no
/// warnings either (each would repeat rank 0's).
static SILENT: AtomicBool = AtomicBool::new(false);

/// Set when a solve did not converge: its file is written, and the exit code is
/// [`EXIT_NOT_CONVERGED`].
static NOT_CONVERGED: AtomicBool = AtomicBool::new(false);

/// The exit codes (README, "Exit codes"): 0 done, 1 an error, 2 a usage error (clap's),
/// 3 a solve that did not converge (its file written all the same).
const EXIT_ERROR: u8 = 1;
const EXIT_USAGE: u8 = 2;
const EXIT_NOT_CONVERGED: u8 = 3;

// The processes sharing a run: MPI's ranks with the `mpi` feature, else one.
#[cfg(feature = "mpi")]
#[path = "ranks_mpi.rs"]
mod ranks;
#[cfg(not(feature = "mpi"))]
#[path = "ranks_one.rs"]
mod ranks;
use ranks::Ranks;

/// A warning on standard error (even with `--quiet`; not on MPI ranks but the first).
macro_rules! warn {
    ($($arg:tt)*) => {
        if !SILENT.load(Ordering::Relaxed) {
            eprintln!($($arg)*);
        }
    };
}

/// A note or summary on standard error, unless `--quiet`.
macro_rules! say {
    ($($arg:tt)*) => {
        if !QUIET.load(Ordering::Relaxed) {
            eprintln!($($arg)*);
        }
    };
}

/// What `--version` prints: the crate's version and the git revision it was built from.
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (git ",
    env!("COHERAD_GIT_REVISION"),
    ")"
);

#[derive(Parser)]
#[command(
    name = "coherad",
    version = VERSION,
    about = "Radiosity form factors by hemisphere ray casting"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    threads: Option<usize>,
    /// Show only warnings and errors: no notes, summaries or progress bars.
    #[arg(long, short, global = true)]
    quiet: bool,
    /// Target patch size, in scene units, for mesh files (OBJ, PLY, STL, glTF: required)
    /// and JSON polygons that give no grid.
    #[arg(long, global = true)]
    patch_size: Option<f64>,
    /// Split concave and warped faces into triangles (ear clipping) and drop degenerate
    /// ones, with a count, instead of refusing the file.
    #[arg(long, global = true)]
    triangulate: bool,
    /// Reflectance of faces with no material (PLY, STL; OBJ and glTF faces that name
    /// none): R or R,G,B, each in [0, 1). Default 0.5.
    #[arg(long, global = true, value_name = "R[,G,B]")]
    reflectance: Option<String>,
    /// A material side file (JSON): materials, emitters among them, and rules giving
    /// them to faces by number or by a box (see the README).
    #[arg(long, global = true, value_name = "FILE.json")]
    materials: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Every patch of a scene: id, polygon, centre, normal, corners, area (JSON).
    Patches {
        /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
        scene: PathBuf,
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Form-factor rows by hemisphere ray casting (JSON).
    Formfactors {
        /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
        scene: PathBuf,
        /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
        #[arg(long, default_value = "180x720")]
        resolution: String,
        /// Patches whose rows to compute: "all" or a list like 3,17,40-59.
        #[arg(long, default_value = "all")]
        patches: String,
        #[command(flatten)]
        rows: RowFlags,
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Surface-to-surface view factors: F_IJ by patch, polygon or group, area to area, under an enclosure rule (JSON, CSV, Matrix Market, View3D text or binary).
    Viewfactors {
        /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
        scene: PathBuf,
        /// What a row is: patch, polygon, or group (every polygon's "group" in the JSON
        /// format; an OBJ file's objects and groups; a View3D file's surfaces, combined
        /// as its cmb fields say). Default: group for a .vs3 file, else polygon.
        #[arg(long, value_enum)]
        by: Option<ByKind>,
        /// N: N x N hemispheres spread over each patch and averaged (area to area; 1 is
        /// point to area, from the patch centre). Default 2.
        #[arg(long, default_value_t = rad_pipeline::viewfactors::DEFAULT_ORIGINS)]
        origins: u32,
        /// Hemisphere cells, N_THETAxN_PHI.
        #[arg(long, default_value = "180x720")]
        resolution: String,
        /// raw: as computed; reciprocal: A_I F_IJ = A_J F_JI, each row keeping its sum;
        /// closed: reciprocal and every row summing to 1 (a closed scene only: rows that
        /// leak are named). Default: closed for a .vs3 file that says encl=1, else raw.
        #[arg(long, value_enum)]
        enclosure: Option<EnclosureKind>,
        /// Hottel's total exchange factors (script-F) from the surfaces' emissivities
        /// (1 - reflectance), after the enclosure rule; on for a .vs3 file that says emit=1.
        #[arg(long)]
        script_f: bool,
        /// json (surfaces and sparse rows), csv (a dense table, names in the first row
        /// and column), mtx (Matrix Market, for scipy.io.mmread), view3d (View3D's
        /// text output: areas, rows, emissivities) or bin (coherad's compact binary
        /// triplets: see the README; with --by patch --enclosure raw, written as rows are
        /// made, never held). Default: from --out's extension (.csv, .mtx, .bin), else
        /// json.
        #[arg(long, value_enum)]
        format: Option<FormatKind>,
        /// How hemispheres are made: scan, hierarchy, facets or grid (the same factors, to the
        /// bit). Default: the fastest for the scene.
        #[arg(long)]
        caster: Option<CasterKind>,
        /// Write here instead of standard output (atomically: all or nothing).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Radiosity of every patch: form factors (exact or estimated), made reciprocal, solved (JSON).
    Solve {
        /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
        scene: PathBuf,
        /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
        #[arg(long, default_value = "180x720")]
        resolution: String,
        #[command(flatten)]
        rows: RowFlags,
        /// gauss-seidel (gathering), progressive (shooting by unshot power) or jacobi
        /// (sweeps from the last sweep's radiosities: under MPI each rank holds only its rows).
        #[arg(long, value_enum, default_value_t = SolverKind::GaussSeidel)]
        solver: SolverKind,
        /// Stop when max |E + rho F B - B| / max B is at most this (stored: default 1e-9);
        /// matrix-free and out-of-core: when the largest unshot (or ungathered) radiosity
        /// over the largest radiosity is (default 1e-4)
        #[arg(long)]
        tolerance: Option<f64>,
        /// Stop after this many sweeps (Gauss-Seidel, progressive) or shots (matrix-free,
        /// out-of-core)
        /// even if not converged (the exit code is then 3). Default: 10,000,000.
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
        max_iterations: Option<u64>,
        /// Solve the rows as computed, without making them reciprocal first (energy is then
        /// conserved only to their reciprocity error).
        #[arg(long)]
        raw: bool,
        /// How to hold the form factors: stored (every row made once, kept compact, made
        /// reciprocal), out-of-core (every row made once and written compact to an unnamed
        /// file in --temp-dir, then shot from there as matrix-free shoots), matrix-free
        /// (progressive refinement making each shooter's row when it shoots, keeping what
        /// the memory limit allows; exact rows only), or auto: stored if an estimate from
        /// 64 sample rows fits --memory-limit, else out-of-core if the temporary folder has
        /// room, else matrix-free
        #[arg(long, value_enum, default_value_t = StorageKind::Auto)]
        storage: StorageKind,
        /// Bytes the form factors may take (K, M, G suffixes: powers of 1024); the scene,
        /// the caster and per-patch arrays come on top
        #[arg(long, default_value = "1.5G")]
        memory_limit: String,
        /// Where out-of-core solving writes its rows (an unnamed file: nothing is left
        /// behind, however the run ends). Default: TMPDIR, else /tmp
        #[arg(long)]
        temp_dir: Option<PathBuf>,
        /// The solution file (atomically: all or nothing).
        #[arg(long)]
        out: PathBuf,
    },
    /// An image of a solution from the scene's camera or one given by flags: 32-bit float EXR, optional PNG preview.
    Render(RenderArgs),
    /// A scene, and a solution baked into vertex colours, for viewers: glTF 2.0 (.glb, .gltf) or PLY.
    Export(ExportArgs),
}

/// `coherad export`'s flags.
#[derive(clap::Args)]
struct ExportArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    scene: PathBuf,
    /// A solution file written by `coherad solve` for this scene: its radiosity is baked
    /// into vertex colours (without one, the geometry and materials alone).
    #[arg(long)]
    solution: Option<PathBuf>,
    /// The file to write: .glb (binary glTF), .gltf (glTF, buffer embedded) or .ply.
    #[arg(long)]
    out: PathBuf,
    /// Exposure in stops: the colours are B x 2^EV, clipped to [0, 1]. Default: the 95th
    /// percentile of the patches' luminance maps to 0.8.
    #[arg(long, allow_negative_numbers = true, value_name = "EV")]
    exposure: Option<f64>,
}

/// `coherad render`'s flags.
#[derive(clap::Args)]
struct RenderArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    scene: PathBuf,
    /// A solution file written by `coherad solve` for this scene.
    #[arg(long)]
    solution: PathBuf,
    /// The EXR image (linear RGB radiosity, or radiance with --radiance).
    #[arg(long)]
    out: PathBuf,
    /// Camera position X,Y,Z: with --look-at, the camera of a scene that has none
    /// (an OBJ file), or to override the scene's; alone, it moves the scene's camera.
    #[arg(long)]
    eye: Option<String>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long)]
    look_at: Option<String>,
    /// The camera's up direction X,Y,Z (default: the scene camera's, else 0,1,0).
    #[arg(long)]
    up: Option<String>,
    /// Vertical field of view, degrees (default: the scene camera's, else 50).
    #[arg(long)]
    fov: Option<f32>,
    /// Write radiance B / pi (what a path tracer or a viewer shows) instead of radiosity B.
    #[arg(long)]
    radiance: bool,
    /// Also a tone-mapped sRGB PNG preview here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Image width, pixels.
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Image height, pixels.
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
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum SolverKind {
    GaussSeidel,
    Progressive,
    /// Jacobi sweeps over stored rows; under MPI each rank holds only its own rows.
    Jacobi,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum StorageKind {
    Auto,
    Stored,
    OutOfCore,
    MatrixFree,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ByKind {
    Patch,
    Polygon,
    Group,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum EnclosureKind {
    Raw,
    Reciprocal,
    Closed,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum FormatKind {
    Json,
    Csv,
    Mtx,
    View3d,
    Bin,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ShadingKind {
    Flat,
    Smooth,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Method {
    Auto,
    Exact,
    Estimated,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum EstimatorMode {
    Faithful,
    Improved,
}

/// The flags that name a way to make rows.
#[derive(clap::Args)]
struct RowFlags {
    /// exact: every hemisphere cast; estimated: 3x3 windows of a polygon (a mesh: windows of about nine neighbouring triangles of one plane), centres cast, the rest estimated (improved by default); auto: estimated where it pays (a scene of 20,000 patches or more whose windows estimate half of them or more: a mesh of flat walls), else exact. Default: auto for solve, exact for formfactors.
    #[arg(long, value_enum)]
    method: Option<Method>,
    /// With --method estimated (or auto, where it estimates): the report's method (faithful) or visibility estimation (improved).
    #[arg(long, value_enum, default_value_t = EstimatorMode::Improved)]
    estimator: EstimatorMode,
    /// How exact hemispheres are made (with --method estimated: the window centres,
    /// improved mode's real rays and exact fallbacks): scan (each polygon tested on the
    /// cells it can cover), hierarchy (the scan over a bounding volume hierarchy,
    /// skipping hidden subtrees), facets (the scan over a mesh's flat pieces, each
    /// cell's triangle found in its piece's grid) or grid (each cell's ray through the
    /// voxel grid, the report's way). All give the same rows, to the bit. Default: the
    /// fastest for the scene (scan below 1024 polygons; from there facets where the flat
    /// pieces hold 128 polygons or more on average, else hierarchy).
    #[arg(long)]
    caster: Option<CasterKind>,
}

impl RowFlags {
    /// The method the flags name, `default` where they name none (auto: what
    /// [`RowMethod::auto_for`] picks, said on standard error, with `--caster` and
    /// `--estimator` applied to it), and whether auto picked it.
    fn method(&self, scene: &SceneFile, default: Method) -> Result<(RowMethod, bool), String> {
        let caster = self
            .caster
            .unwrap_or_else(|| CasterKind::fastest_for(&scene.scene));
        let mode = match self.estimator {
            EstimatorMode::Faithful => Mode::Faithful,
            EstimatorMode::Improved => Mode::Improved,
        };
        let asked = self.method.unwrap_or(default);
        let method = match asked {
            Method::Auto => {
                let (picked, share) =
                    RowMethod::auto_for(&scene.scene).map_err(|e| e.to_string())?;
                let n = scene.scene.patches().len();
                if picked.is_exact() {
                    Method::Exact
                } else {
                    say!(
                        "method auto: estimated rows ({n} patches, {:.0} % of them in windows that estimate them; --method exact casts every hemisphere)",
                        100.0 * share
                    );
                    Method::Estimated
                }
            }
            m => m,
        };
        let method = match method {
            Method::Estimated => RowMethod::Estimated {
                mode,
                centres: caster,
            },
            _ => RowMethod::Exact { caster },
        };
        Ok((method, asked == Method::Auto))
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    QUIET.store(cli.quiet, Ordering::Relaxed);
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("error: --threads must be at least 1");
            return ExitCode::from(EXIT_USAGE);
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("error: cannot start {n} threads: {e}");
            return ExitCode::from(EXIT_ERROR);
        }
    }
    let ranks = Ranks::init();
    if ranks.rank() > 0 {
        // Rank 0 speaks for the run; the others' errors reach it in the gather.
        QUIET.store(true, Ordering::Relaxed);
        SILENT.store(true, Ordering::Relaxed);
    }
    // A panic is an error like any other here, so that under MPI it is gathered too
    // (a rank that unwound without gathering would leave rank 0 waiting).
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(&cli, &ranks)))
        .unwrap_or_else(|p| {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(format!(
                "internal error (a panic: {what}); please report it"
            ))
        });
    // Every rank gathers once: one that ended before it sends its error (or nothing).
    let result = if ranks.gathered() {
        result
    } else {
        ranks.gather(result.map(|()| Vec::new())).map(|_| ())
    };
    if ranks.rank() > 0 {
        return ExitCode::SUCCESS;
    }
    match result {
        Ok(()) if NOT_CONVERGED.load(Ordering::Relaxed) => ExitCode::from(EXIT_NOT_CONVERGED),
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_ERROR)
        }
    }
}

/// Writes through `fill` to `out` (atomically) or to standard output.
fn emit(
    out: Option<&Path>,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), String> {
    match out {
        Some(path) => write_atomic(path, |w| fill(w)).map_err(|e| e.to_string()),
        None => {
            let stdout = std::io::stdout();
            let mut lock = std::io::BufWriter::new(stdout.lock());
            fill(&mut lock)
                .and_then(|_| lock.flush())
                .map_err(|e| format!("cannot write to standard output: {e}"))
        }
    }
}

/// Loads a scene file as the global flags say; warns of what `--triangulate` dropped or
/// split and of what was read with a change.
fn load_scene_file(cli: &Cli, path: &Path) -> Result<SceneFile, String> {
    let reflectance = cli
        .reflectance
        .as_deref()
        .map(parse_reflectance)
        .transpose()?;
    let options = LoadOptions {
        patch_size: cli.patch_size,
        triangulate: cli.triangulate,
        reflectance,
        materials: cli.materials.clone(),
    };
    let scene = SceneFile::load_with(path, &options).map_err(|e| e.to_string())?;
    let t = &scene.triangulation;
    if t.split > 0 {
        say!(
            "note: {}: split {} concave or warped faces into {} triangles",
            path.display(),
            t.split,
            t.triangles
        );
    }
    if t.dropped > 0 {
        warn!(
            "warning: {}: dropped {} degenerate faces or pieces (first: {})",
            path.display(),
            t.dropped,
            t.first_dropped.as_deref().unwrap_or("?")
        );
    }
    for note in &scene.notes {
        say!("note: {}: {note}", path.display());
    }
    Ok(scene)
}

/// `--reflectance`: R or R,G,B.
fn parse_reflectance(text: &str) -> Result<Rgb, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|c| c.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--reflectance {text:?}: expected R or R,G,B (numbers)"))?;
    let rgb = match values[..] {
        [r] => [r; 3],
        [r, g, b] => [r, g, b],
        _ => return Err(format!("--reflectance {text:?}: expected 1 or 3 numbers")),
    };
    if !rgb.iter().all(|c| (0.0..1.0).contains(c)) {
        return Err(format!(
            "--reflectance {text:?}: each value must be in [0, 1)"
        ));
    }
    Ok(Rgb(rgb))
}

fn run(cli: &Cli, ranks: &Ranks) -> Result<(), String> {
    let load = |path: &Path| load_scene_file(cli, path);
    let shared = matches!(
        cli.command,
        Command::Formfactors { .. } | Command::Viewfactors { .. } | Command::Solve { .. }
    );
    if ranks.size() > 1 && !shared {
        return Err(format!(
            "under MPI ({} ranks) only `coherad formfactors`, `viewfactors` and `solve` are shared: run this command as one process",
            ranks.size()
        ));
    }
    match &cli.command {
        Command::Patches { scene, out } => {
            let scene = load(scene)?;
            emit(out.as_deref(), |w| write_patches_json(w, &scene.scene))
        }
        Command::Formfactors {
            scene,
            resolution,
            patches,
            rows,
            out,
        } => {
            let scene = load(scene)?;
            let (method, _) = rows.method(&scene, Method::Exact)?;
            formfactors(&scene, resolution, patches, method, out.as_deref(), ranks)
        }
        Command::Viewfactors {
            scene,
            by,
            origins,
            resolution,
            enclosure,
            script_f,
            format,
            caster,
            out,
        } => {
            let scene = load(scene)?;
            let v3 = scene.view3d.as_ref();
            let by = by.unwrap_or(if v3.is_some() {
                ByKind::Group
            } else {
                ByKind::Polygon
            });
            let encl = v3.is_some_and(|c| c.encl);
            let enclosure = enclosure.unwrap_or(if encl {
                EnclosureKind::Closed
            } else {
                EnclosureKind::Raw
            });
            let mut opts = viewfactor_options(&scene, by, *origins, enclosure, *caster);
            opts.script_f = *script_f || v3.is_some_and(|c| c.emit);
            if let Some(c) = v3.filter(|c| !c.ignored.is_empty()) {
                say!(
                    "note: View3D options of its own integration, not used here: {}",
                    c.ignored.join(" ")
                );
            }
            let format = matrix_format(*format, out.as_deref());
            viewfactors(&scene, resolution, &opts, format, out.as_deref(), ranks)
        }
        Command::Solve {
            scene,
            resolution,
            rows,
            solver,
            tolerance,
            max_iterations,
            raw,
            storage,
            memory_limit,
            temp_dir,
            out,
        } => {
            let scene = load(scene)?;
            let (method, auto) = rows.method(&scene, Method::Auto)?;
            let how = How {
                solver: *solver,
                tolerance: *tolerance,
                max_iterations: *max_iterations,
                raw: *raw,
                storage: *storage,
                memory_limit: parse_bytes(memory_limit)?,
                temp_dir: temp_dir.clone(),
                auto,
            };
            solve(&scene, resolution, method, &how, out, ranks)
        }
        Command::Render(args) => render(&load(&args.scene)?, args),
        Command::Export(args) => export_scene(&load(&args.scene)?, args),
    }
}

/// `coherad export`: glTF or PLY, with the solution baked in if given.
fn export_scene(scene: &SceneFile, args: &ExportArgs) -> Result<(), String> {
    rad_pipeline::export::ExportFormat::of_path(&args.out).map_err(|e| e.to_string())?;
    let b = match &args.solution {
        Some(path) => Some(read_solution(path, scene).map_err(|e| e.to_string())?),
        None => None,
    };
    let summary = rad_pipeline::export::export(scene, b.as_deref(), args.exposure, &args.out)
        .map_err(|e| e.to_string())?;
    let scale = summary
        .scale
        .map(|s| format!(", colours B x {s:.4} (EV {:+.2})", s.log2()))
        .unwrap_or_default();
    say!(
        "wrote {}: {} meshes, {} vertices, {} triangles, {} bytes{scale}",
        args.out.display(),
        summary.meshes,
        summary.vertices,
        summary.triangles,
        summary.bytes
    );
    Ok(())
}

/// The hemisphere of a `--resolution`.
fn hemisphere(resolution: &str) -> Result<Hemisphere, String> {
    let (nt, np) = parse_resolution(resolution).map_err(|e| e.to_string())?;
    Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(|e| e.to_string())
}

/// A bar for `n_rows` rows of `hemi`, shown when the job is long (over about 50 M rays).
fn row_bar(hemi: &Hemisphere, method: RowMethod, n_rows: usize) -> ProgressBar {
    let rays = n_rows as u64 * hemi.n_cells() as u64;
    let bar = if rays > 50_000_000 && !QUIET.load(Ordering::Relaxed) {
        ProgressBar::new(n_rows as u64)
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
    bar.set_message(format!(
        "form factors {}x{}, {method}",
        hemi.n_theta(),
        hemi.n_phi()
    ));
    bar
}

/// What a run of estimated rows did, on standard error.
fn report_estimates(method: RowMethod, s: &EstimateStats) {
    if method.is_exact() {
        return;
    }
    say!(
        "{} rows cast exactly (window centres), {} estimated, {} cast exactly after needing real rays for over {:.0} % of their cells ({} real rays)",
        s.exact,
        s.estimated,
        s.fallback_exact,
        100.0 * rad_pipeline::default_estimator(Mode::Improved).max_real_ray_share,
        s.real_rays
    );
}

fn formfactors(
    scene: &SceneFile,
    resolution: &str,
    patches: &str,
    method: RowMethod,
    out: Option<&Path>,
    ranks: &Ranks,
) -> Result<(), String> {
    let hemi = hemisphere(resolution)?;
    let scene_ = &scene.scene;
    let ids = parse_patch_list(patches, scene_.patches().len()).map_err(|e| e.to_string())?;
    let bar = row_bar(&hemi, method, ids.len());
    let what = format!("formfactors {}x{} {method}", hemi.n_theta(), hemi.n_phi());
    let make = |patches: &[u32], progress: &(dyn Fn(usize) + Sync)| {
        rad_pipeline::rows(scene_, &hemi, method, patches, progress).map_err(|e| e.to_string())
    };
    let Some(made) = shared_rows(scene, method, &ids, ranks, &what, &bar, &make)? else {
        return Ok(()); // (a rank but the first: its rows went to rank 0)
    };
    report_estimates(made.method, &made.stats);
    let leaked: Vec<u32> = made
        .rows
        .iter()
        .filter(|r| r.escaped > 0.0)
        .map(|r| r.patch)
        .collect();
    if !leaked.is_empty() {
        warn!(
            "warning: {} row(s) lose form factor to rays that leave the scene (first: patch {}); the scene is not closed",
            leaked.len(),
            leaked[0]
        );
    }
    let backs: Vec<&rad_pipeline::Row> = made.rows.iter().filter(|r| r.back > 0.0).collect();
    if let Some(first) = backs.iter().max_by(|a, b| a.back.total_cmp(&b.back)) {
        let polygon = scene_.patches()[first.patch as usize].polygon as usize;
        warn!(
            "warning: {} row(s) see polygons from behind (their \"back\" form factor is > 0; most: patch {} of polygon {polygon} ({:?}), {:.3e} of its hemisphere)",
            backs.len(),
            first.patch,
            scene_.polygons()[polygon].name(),
            first.back
        );
    }
    let res = (hemi.n_theta() as u32, hemi.n_phi() as u32);
    emit(out, |w| {
        write_rows_header(w, res, method.rows_name(), scene_.patches().len())?;
        for (k, (r, src)) in made.rows.iter().zip(&made.sources).enumerate() {
            write_row_json(w, r, *src, k == 0)?;
        }
        write_rows_footer(w)
    })
}

/// How a share's rows are made: `make(patches, progress)`.
type MakeRows<'a> =
    dyn Fn(&[u32], &(dyn Fn(usize) + Sync)) -> Result<rad_pipeline::Rows, String> + Sync + 'a;

/// The rows of `ids` (`make` makes any of them), made by this process alone or shared
/// among MPI ranks ([`rad_pipeline::share`]: each rank its share, balanced by the work
/// units of `method`, the rows gathered on rank 0 in the list's order, the same to the
/// bit); `None` on the ranks but the first. `bar` shows this process's rows. Each
/// rank's part begins with a fingerprint of the run (the scene and `what`: the
/// command's resolution, method, options, patch list), so that ranks started on
/// different runs are an error, not a mixed output.
fn shared_rows(
    scene: &SceneFile,
    method: RowMethod,
    ids: &[u32],
    ranks: &Ranks,
    what: &str,
    bar: &ProgressBar,
    make: &MakeRows<'_>,
) -> Result<Option<rad_pipeline::Rows>, String> {
    let progress = |n: usize| bar.set_position(n as u64);
    let mut make = |ids: &[u32]| {
        bar.set_length(ids.len() as u64);
        make(ids, &progress).map_err(rad_pipeline::Error::Peers)
    };
    let run = share::SharedRun {
        scene: &scene.scene,
        scene_hash: scene.hash,
        method,
        what: what.as_bytes(),
    };
    let shared =
        share::shared_rows(run, ids, ranks, false, &mut make).map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    if ranks.size() > 1 && shared.rows.is_some() {
        say_balance(&shared.shares);
    }
    Ok(shared.rows)
}

/// The work units of each rank's share, and the largest over the mean.
fn say_balance(shares: &[share::Share]) {
    let units: Vec<String> = shares.iter().map(|s| format!("{:.0}", s.units)).collect();
    let mean = shares.iter().map(|s| s.units).sum::<f64>() / shares.len() as f64;
    let worst = shares.iter().map(|s| s.units).fold(0.0, f64::max);
    say!(
        "mpi: {} ranks, work units {} (the largest {:.3} of the mean)",
        shares.len(),
        units.join(" / "),
        worst / mean
    );
}

/// The view-factor options of `coherad viewfactors`' flags.
fn viewfactor_options(
    scene: &SceneFile,
    by: ByKind,
    origins: u32,
    enclosure: EnclosureKind,
    caster: Option<CasterKind>,
) -> ViewFactorOptions {
    let mut opts = ViewFactorOptions::for_scene(&scene.scene);
    opts.by = match by {
        ByKind::Patch => Grouping::Patch,
        ByKind::Polygon => Grouping::Polygon,
        ByKind::Group => Grouping::Group,
    };
    opts.origins = origins;
    opts.enclosure = match enclosure {
        EnclosureKind::Raw => Enclosure::Raw,
        EnclosureKind::Reciprocal => Enclosure::Reciprocal,
        EnclosureKind::Closed => Enclosure::Closed,
    };
    if let Some(c) = caster {
        opts.caster = c;
    }
    opts
}

/// The matrix format of `--format`, else of `--out`'s extension (.csv, .mtx, any
/// case), else JSON.
fn matrix_format(format: Option<FormatKind>, out: Option<&Path>) -> MatrixFormat {
    match format {
        Some(FormatKind::Json) => MatrixFormat::Json,
        Some(FormatKind::Csv) => MatrixFormat::Csv,
        Some(FormatKind::Mtx) => MatrixFormat::Mtx,
        Some(FormatKind::View3d) => MatrixFormat::View3d,
        Some(FormatKind::Bin) => MatrixFormat::Bin,
        None => {
            let ext = out.and_then(|p| p.extension()).and_then(|e| e.to_str());
            match ext.map(str::to_ascii_lowercase).as_deref() {
                Some("csv") => MatrixFormat::Csv,
                Some("mtx") => MatrixFormat::Mtx,
                Some("bin") => MatrixFormat::Bin,
                _ => MatrixFormat::Json,
            }
        }
    }
}

fn viewfactors(
    scene: &SceneFile,
    resolution: &str,
    opts: &ViewFactorOptions,
    format: MatrixFormat,
    out: Option<&Path>,
    ranks: &Ranks,
) -> Result<(), String> {
    let hemi = hemisphere(resolution)?;
    let n_surfaces = count_surfaces(&scene.scene, opts.by).map_err(|e| e.to_string())?;
    check_format(format, n_surfaces).map_err(|e| e.to_string())?;
    let max = rad_pipeline::viewfactors::MAX_ORIGINS;
    if !(1..=max).contains(&opts.origins) {
        return Err(format!(
            "--origins {} is invalid: give 1 to {max} (N x N hemispheres a patch)",
            opts.origins
        ));
    }
    if opts.script_f && n_surfaces > rad_pipeline::viewfactors::MAX_SCRIPT_F {
        return Err(format!(
            "--script-f solves a dense system of the surfaces: {n_surfaces} is over the limit of {} (use --by group, or fewer surfaces)",
            rad_pipeline::viewfactors::MAX_SCRIPT_F
        ));
    }
    if format == MatrixFormat::Bin && out.is_none() {
        return Err("--format bin writes a binary file: give --out FILE.bin".into());
    }
    let n_patches = scene.scene.patches().len();
    let per_patch = u64::from(opts.origins).pow(2);
    let rays = n_patches as u64 * per_patch * hemi.n_cells() as u64;
    let bar = if rays > 50_000_000 && !QUIET.load(Ordering::Relaxed) {
        ProgressBar::new(n_patches as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{msg} [{bar:40}] {pos}/{len} patches, {elapsed} elapsed, eta {eta}",
        )
        .expect("a valid template")
        .progress_chars("=> "),
    );
    bar.set_message(format!(
        "view factors {}x{}, {per_patch} hemispheres a patch",
        hemi.n_theta(),
        hemi.n_phi()
    ));
    let run = ViewFactorRun {
        scene: scene.path.display().to_string(),
        scene_hash: scene.hash_text(),
        resolution: (hemi.n_theta() as u32, hemi.n_phi() as u32),
    };
    let progress = |n: usize| bar.set_position(n as u64);
    if ranks.size() > 1 {
        // Shared among ranks: each its patches' rows, gathered on rank 0 (whole: the
        // streaming path below is one process's).
        let scene_ = &scene.scene;
        let ids = row_patches(scene_);
        // (Every patch costs origins² hemispheres alike: exact rows' units.)
        let method = RowMethod::Exact {
            caster: opts.caster,
        };
        let what = format!("viewfactors {}x{} {opts:?}", hemi.n_theta(), hemi.n_phi());
        let make = |patches: &[u32], progress: &(dyn Fn(usize) + Sync)| {
            let rows =
                area_rows(scene_, &hemi, opts, patches, progress).map_err(|e| e.to_string())?;
            let sources = vec![None; rows.len()];
            let stats = EstimateStats::default();
            Ok(rad_pipeline::Rows {
                method,
                rows,
                sources,
                stats,
            })
        };
        let Some(made) = shared_rows(scene, method, &ids, ranks, &what, &bar, &make)? else {
            return Ok(());
        };
        let vf = view_factors_of_rows(scene_, opts, made.rows).map_err(|e| e.to_string())?;
        return report_and_write_view_factors(&vf, &run, format, out);
    }
    if let (MatrixFormat::Bin, Grouping::Patch, Enclosure::Raw, false, Some(path)) =
        (format, opts.by, opts.enclosure, opts.script_f, out)
    {
        // Patch to patch, raw: written as the rows are made, never held.
        let mut done = None;
        write_atomic(path, |w| {
            let s = stream_patch_matrix(&scene.scene, &hemi, opts, &run, w, &progress)
                .map_err(|e| std::io::Error::other(e.to_string()))?;
            done = Some(s);
            Ok(())
        })
        .map_err(|e| e.to_string())?;
        bar.finish_and_clear();
        let done = done.expect("written");
        say!(
            "{} rows, {} entries written as made; {} rows lose form factor to rays leaving the scene, {} see polygons from behind",
            done.n_patches, done.entries, done.escaping_rows, done.back_rows
        );
        return Ok(());
    }
    let vf = view_factors(&scene.scene, &hemi, opts, &progress).map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    report_and_write_view_factors(&vf, &run, format, out)
}

/// Notes what view factors lose (rays leaving the scene, backs), reports the enclosure
/// rule's changes, and writes them.
fn report_and_write_view_factors(
    vf: &rad_pipeline::viewfactors::ViewFactors,
    run: &ViewFactorRun,
    format: MatrixFormat,
    out: Option<&Path>,
) -> Result<(), String> {
    let leaking = (0..vf.names.len()).filter(|&i| vf.escaped[i] > 0.0).count();
    if leaking > 0 {
        say!(
            "note: {leaking} of {} surfaces lose form factor to rays that leave the scene (the scene is not closed)",
            vf.names.len()
        );
    }
    let backs: Vec<&str> = (0..vf.names.len())
        .filter(|&i| vf.back[i] > 0.0)
        .map(|i| vf.names[i].as_str())
        .collect();
    if !backs.is_empty() {
        warn!(
            "warning: {} surfaces see polygons from behind (first: {:?}); those rays count as \"back\", in no factor",
            backs.len(),
            backs[0]
        );
    }
    let r = &vf.report;
    say!(
        "enclosure {}: rows' |1 - sum| max {:.3e} (median {:.3e}), reciprocity error max {:.3e} (median {:.3e}); as computed: {:.3e} ({:.3e}) and {:.3e} ({:.3e}); largest change {:.3e}",
        vf.enclosure.name(),
        r.fixed.row_sum.max,
        r.fixed.row_sum.median,
        r.fixed.reciprocity.max,
        r.fixed.reciprocity.median,
        r.raw.row_sum.max,
        r.raw.row_sum.median,
        r.raw.reciprocity.max,
        r.raw.reciprocity.median,
        r.max_change
    );
    emit(out, |w| write_view_factors(w, vf, run, format))
}

/// `coherad render`: the solution's image from the scene's camera or the flags'.
fn render(scene: &SceneFile, args: &RenderArgs) -> Result<(), String> {
    let RenderArgs {
        scene: _,
        solution,
        out,
        eye,
        look_at,
        up,
        fov,
        radiance,
        png,
        width,
        height,
        samples,
        shading,
        exposure,
    } = args;
    if let Some(x) = exposure {
        if png.is_none() {
            return Err("--exposure sets the PNG preview's exposure: give --png too".into());
        }
        if !(x.is_finite() && *x > 0.0) {
            return Err(format!("--exposure must be finite and > 0, not {x}"));
        }
    }
    let flags = CameraFlags {
        eye: eye.as_deref(),
        look_at: look_at.as_deref(),
        up: up.as_deref(),
        fov: *fov,
    };
    let camera = camera(&scene, &flags)?;
    let view = View::new(&camera, *width, *height).map_err(|e| e.to_string())?;
    let mut b = read_solution(solution, &scene).map_err(|e| e.to_string())?;
    if *radiance {
        b = radiance_of(&b);
    }
    let config = RenderConfig {
        samples: *samples,
        shading: match shading {
            ShadingKind::Flat => Shading::Flat,
            ShadingKind::Smooth => Shading::Smooth,
        },
    };
    render_to_files(
        &scene.scene,
        &b,
        &view,
        &config,
        out,
        png.as_deref(),
        *exposure,
    )
    .map_err(|e| e.to_string())
}

/// `coherad render`'s camera flags.
struct CameraFlags<'a> {
    eye: Option<&'a str>,
    look_at: Option<&'a str>,
    up: Option<&'a str>,
    fov: Option<f32>,
}

/// A vector from "X,Y,Z".
fn parse_vec3(flag: &str, text: &str) -> Result<[f32; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let values: Option<Vec<f32>> = parts
        .iter()
        .map(|p| p.parse::<f32>().ok().filter(|v| v.is_finite()))
        .collect();
    match values {
        Some(v) if v.len() == 3 => Ok([v[0], v[1], v[2]]),
        _ => Err(format!("{flag} {text:?}: give three finite numbers X,Y,Z")),
    }
}

/// The camera of a render: the scene's, with whatever the flags override; a scene
/// without one needs --eye and --look-at.
fn camera(scene: &SceneFile, f: &CameraFlags) -> Result<Camera, String> {
    let own = scene.scene.camera().copied();
    let given = |flag, t: Option<&str>| t.map(|t| parse_vec3(flag, t)).transpose();
    let eye = given("--eye", f.eye)?;
    let look_at = given("--look-at", f.look_at)?;
    let up = given("--up", f.up)?;
    let v = |a: [f32; 3]| rad_pipeline::Vec3::from_array(a);
    let (position, target) = match (own, eye, look_at) {
        (_, Some(e), Some(l)) => (v(e), v(l)),
        (Some(c), e, l) => (e.map_or(c.position, v), l.map_or(c.look_at, v)),
        (None, _, _) => {
            return Err(format!(
            "{} has no camera: give --eye X,Y,Z and --look-at X,Y,Z (and --up, --fov if need be)",
            scene.path.display()
        ))
        }
    };
    if let Some(x) = f.fov {
        if !(x.is_finite() && x > 0.0 && x < 180.0) {
            return Err(format!("--fov {x}: give degrees in (0, 180)"));
        }
    }
    Ok(Camera {
        position,
        look_at: target,
        up: up
            .map(v)
            .or(own.map(|c| c.up))
            .unwrap_or(rad_pipeline::Vec3::Y),
        fov_y: f
            .fov
            .map(f32::to_radians)
            .or(own.map(|c| c.fov_y))
            .unwrap_or(50f32.to_radians()),
    })
}

/// How `coherad solve` solves, from its flags.
struct How {
    solver: SolverKind,
    tolerance: Option<f64>,
    max_iterations: Option<u64>,
    raw: bool,
    storage: StorageKind,
    memory_limit: usize,
    temp_dir: Option<PathBuf>,
    /// The method is `--method auto`'s pick (settled against the storage).
    auto: bool,
}

/// Bytes from "123", "900M", "1.5G" (suffixes K, M, G, T: powers of 1024).
fn parse_bytes(text: &str) -> Result<usize, String> {
    let t = text.trim();
    let (num, unit) = match t.char_indices().find(|(_, c)| c.is_ascii_alphabetic()) {
        Some((k, _)) => (&t[..k], t[k..].to_ascii_uppercase()),
        None => (t, String::new()),
    };
    let scale: f64 = match unit.trim_end_matches("IB").trim_end_matches('B') {
        "" => 1.0,
        "K" => 1024.0,
        "M" => 1024.0 * 1024.0,
        "G" => 1024.0 * 1024.0 * 1024.0,
        "T" => 1024.0f64.powi(4),
        _ => {
            return Err(format!(
                "--memory-limit {text:?}: unknown unit (use K, M, G or T)"
            ))
        }
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * scale < usize::MAX as f64 => {
            Ok((v * scale) as usize)
        }
        _ => Err(format!(
            "--memory-limit {text:?}: not a positive size (say 900M or 1.5G)"
        )),
    }
}

/// Warns of a scene in which nothing emits (every radiosity would be 0).
fn warn_if_nothing_emits(scene: &SceneFile) {
    let sc = &scene.scene;
    if (0..sc.patches().len()).all(|p| sc.patch_material(p as u32).emission.0 == [0.0; 3]) {
        warn!(
            "warning: no polygon emits light (every material's emission is 0): every radiosity will be 0; give a material an \"emission\" (or use --materials)"
        );
    }
}

/// What an out-of-core or matrix-free solve held and did.
fn report_storage(solved: &rad_pipeline::solve::Solved, opts: &SolveOptions) {
    if solved.matrix.storage == Storage::OutOfCore.name() {
        say!(
            "out-of-core: rows written to a temporary file in {} ({:.0} MiB, removed); {} shots, {} rows read back, {} kept ({:.0} MiB)",
            opts.temp_dir().display(),
            solved.matrix.disk_bytes as f64 / (1u64 << 20) as f64,
            solved.solution.report.iterations,
            solved.matrix.rows_made,
            solved.matrix.cached_rows,
            solved.matrix.bytes as f64 / (1u64 << 20) as f64
        );
    }
    if solved.matrix.storage == Storage::MatrixFree.name() {
        say!(
            "matrix-free: {} shots, {} rows made, {} kept ({:.0} MiB)",
            solved.solution.report.iterations,
            solved.matrix.rows_made,
            solved.matrix.cached_rows,
            solved.matrix.bytes as f64 / (1u64 << 20) as f64
        );
    }
}

/// The method a solve makes rows with: auto's pick settled against the storage
/// ([`settle_auto`], said when it changes), any other as asked.
fn settled(
    scene: &SceneFile,
    hemi: &Hemisphere,
    method: RowMethod,
    how: &How,
    opts: &SolveOptions,
    ranks: &Ranks,
) -> Result<RowMethod, String> {
    if !how.auto {
        return Ok(method);
    }
    let (settled, changed) =
        settle_auto(&scene.scene, hemi, method, opts, ranks.size()).map_err(|e| e.to_string())?;
    if changed {
        say!("method auto: exact rows after all (matrix-free solving, asked for or the only storage that fits, casts each shooter's row)");
    }
    Ok(settled)
}

fn solve(
    scene: &SceneFile,
    resolution: &str,
    method: RowMethod,
    how: &How,
    out: &Path,
    ranks: &Ranks,
) -> Result<(), String> {
    if let Some(t) = how.tolerance.filter(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(format!("--tolerance must be finite and > 0, not {t}"));
    }
    if how.raw && how.solver == SolverKind::Progressive {
        return Err(
            "--raw with --solver progressive cannot converge: shooting takes \
             F_ji from F_ij by reciprocity, which raw rows hold only to their \
             discretisation error; use --solver gauss-seidel, or drop --raw"
                .into(),
        );
    }
    let hemi = hemisphere(resolution)?;
    warn_if_nothing_emits(scene);
    let storage = match how.storage {
        StorageKind::Auto => None,
        StorageKind::Stored => Some(Storage::Stored),
        StorageKind::MatrixFree => Some(Storage::MatrixFree),
        StorageKind::OutOfCore => Some(Storage::OutOfCore),
    };
    let mut opts = SolveOptions {
        solver: match how.solver {
            SolverKind::GaussSeidel => Solver::GaussSeidel,
            SolverKind::Progressive => Solver::Progressive,
            SolverKind::Jacobi => Solver::Jacobi,
        },
        reciprocal: !how.raw,
        storage,
        memory_limit: how.memory_limit,
        temp_dir: how.temp_dir.clone(),
        ..SolveOptions::default()
    };
    if let Some(t) = how.tolerance {
        opts.config.tolerance = t;
        opts.matrix_free.tolerance = t;
    }
    if let Some(n) = how.max_iterations {
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        opts.config.max_iterations = n;
        opts.matrix_free.max_iterations = n;
    }
    let method = settled(scene, &hemi, method, how, &opts, ranks)?;
    let n = scene.scene.patches().len();
    let bar = row_bar(&hemi, method, n);
    let solved = solve_scene_shared(
        scene,
        &hemi,
        method,
        &opts,
        &|p| match p {
            Progress::Rows(k) => {
                bar.set_position(k as u64);
                if k == n {
                    bar.set_message("rows done; solving");
                }
            }
            Progress::Sweeps { sweeps, residual } => {
                bar.set_message(format!("jacobi: {sweeps} sweeps, residual {residual:.2e}"));
            }
            Progress::Shots { shots, unshot } => {
                bar.set_position((n as u64).min(shots as u64));
                bar.set_message(format!(
                    "shooting: {shots} shots, {:.2e} of the power unshot or ungathered",
                    unshot
                ));
            }
        },
        ranks,
    )
    .map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    // (Rank 0 speaks for the run and writes its file.)
    let Some((file, solved, stats)) = solved else {
        return Ok(());
    };
    report_estimates(method, &stats);
    report_storage(&solved, &opts);
    if let Some(rec) = solved.reciprocity.filter(|r| !r.converged) {
        warn!(
            "warning: the reciprocal scaling stopped after {} products with rows off their sums by up to {:.1e}; energy is conserved only to that",
            rec.iterations, rec.max_row_sum_error
        );
    }
    let r = &solved.solution.report;
    say!(
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
    let text = serde_json::to_string_pretty(&file).map_err(|e| e.to_string())?;
    emit(Some(out), |w| w.write_all(text.as_bytes()))?;
    if !r.converged {
        warn!(
            "warning: the solve did not converge (residual {:.1e} after {} iterations); {} is written, the exit code is {EXIT_NOT_CONVERGED}",
            r.residual,
            r.iterations,
            out.display()
        );
        NOT_CONVERGED.store(true, Ordering::Relaxed);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn every_command_and_flag_has_help_text() {
        let cmd = Cli::command();
        cmd.clone().debug_assert();
        let mut missing = Vec::new();
        let check = |owner: &str, c: &clap::Command, missing: &mut Vec<String>| {
            for a in c.get_arguments() {
                let id = a.get_id().as_str();
                if id != "help" && id != "version" && a.get_help().is_none() {
                    missing.push(format!("{owner} {id}"));
                }
            }
        };
        check("coherad", &cmd, &mut missing);
        for sub in cmd.get_subcommands() {
            if sub.get_about().is_none() {
                missing.push(format!("the command {}", sub.get_name()));
            }
            check(sub.get_name(), sub, &mut missing);
        }
        assert!(missing.is_empty(), "no help text: {missing:?}");
    }

    #[test]
    fn the_version_names_the_git_revision() {
        assert!(VERSION.starts_with(env!("CARGO_PKG_VERSION")));
        assert!(VERSION.contains("(git "), "{VERSION}");
    }

    #[test]
    fn reflectances_parse_or_are_refused_by_value() {
        assert_eq!(parse_reflectance("0.25").unwrap().0, [0.25; 3]);
        assert_eq!(
            parse_reflectance("0.1, 0.2,0.3").unwrap().0,
            [0.1, 0.2, 0.3]
        );
        for bad in ["1", "-0.1", "0.1,0.2", "x", "nan"] {
            assert!(parse_reflectance(bad).is_err(), "{bad}");
        }
    }
}
