//! The command line: every flag (clap), and what the flags name in the pipeline's
//! terms. Help texts are the reference's (docs/cli.md lists each flag).

use clap::{Parser, Subcommand};
use rad_pipeline::viewfactors::{Grouping, MatrixFormat, ViewFactorMethod};
use rad_pipeline::{CasterKind, Enclosure, MethodChoice, Mode, Shading, Solver, Storage};
use std::path::{Path, PathBuf};

/// What `--version` prints: the crate's version and the git revision it was built from.
pub const VERSION: &str = concat!(
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
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    pub threads: Option<usize>,
    /// Show only warnings and errors: no notes, summaries or progress bars.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Target patch size, in scene units, for mesh files (OBJ, PLY, STL, glTF: required)
    /// and JSON polygons that give no grid.
    #[arg(long, global = true)]
    pub patch_size: Option<f64>,
    /// Split concave and warped faces into triangles (ear clipping) and drop degenerate
    /// ones, with a count, instead of refusing the file.
    #[arg(long, global = true)]
    pub triangulate: bool,
    /// Mend a mesh as it comes: weld vertices closer than --weld, drop duplicate faces
    /// and faces folded onto a coplanar neighbour, orient each connected piece
    /// consistently (closed pieces outward, or inward if they enclose the scene); with
    /// a report of what changed.
    #[arg(long, global = true)]
    pub repair: bool,
    /// The welding distance of --repair, in scene units (default: 1e-6 of the scene's
    /// bounding-box diagonal; 0 welds only identical positions).
    #[arg(long, global = true, value_name = "DIST", requires = "repair", value_parser = weld_distance)]
    pub weld: Option<f64>,
    /// Reflectance of faces with no material (PLY, STL; OBJ and glTF faces that name
    /// none): R or R,G,B, each in [0, 1). Default 0.5.
    #[arg(long, global = true, value_name = "R[,G,B]")]
    pub reflectance: Option<String>,
    /// A material side file (JSON): materials, emitters among them, and rules giving
    /// them to faces by number or by a box (see docs/formats.md).
    #[arg(long, global = true, value_name = "FILE.json")]
    pub materials: Option<PathBuf>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Every patch of a scene: id, polygon, centre, normal, corners, area (JSON).
    Patches(PatchesArgs),
    /// Form-factor rows by hemisphere ray casting (JSON).
    Formfactors(FormfactorsArgs),
    /// Surface-to-surface view factors: F_IJ by patch, polygon or group, area to area, under an enclosure rule (JSON, CSV, Matrix Market, View3D text or binary).
    Viewfactors(ViewfactorsArgs),
    /// Radiosity of every patch: form factors (exact or estimated), made reciprocal, solved (JSON).
    Solve(SolveArgs),
    /// An image of a solution from the scene's camera or one given by flags: 32-bit float EXR, optional PNG preview.
    Render(RenderArgs),
    /// A scene, and a solution baked into vertex colours, for viewers: glTF 2.0 (.glb, .gltf) or PLY.
    Export(ExportArgs),
}

/// `coherad patches`'s flags.
#[derive(clap::Args)]
pub struct PatchesArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// Write here instead of standard output (atomically: all or nothing).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `coherad formfactors`'s flags.
#[derive(clap::Args)]
pub struct FormfactorsArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
    #[arg(long, default_value = "180x720")]
    pub resolution: String,
    /// Patches whose rows to compute: "all" or a list like 3,17,40-59.
    #[arg(long, default_value = "all")]
    pub patches: String,
    #[command(flatten)]
    pub rows: RowFlags,
    /// Write here instead of standard output (atomically: all or nothing).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `coherad viewfactors`'s flags.
#[derive(clap::Args)]
pub struct ViewfactorsArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// What a row is: patch, polygon, or group (every polygon's "group" in the JSON
    /// format; an OBJ file's objects and groups; a View3D file's surfaces, combined
    /// as its cmb fields say). Default: group for a .vs3 file, else polygon.
    #[arg(long, value_enum)]
    pub by: Option<ByKind>,
    /// How each pair's factor is made: auto (in closed form, by the double contour
    /// integral, where no polygon can come between two polygons; from hemispheres
    /// elsewhere, by patch, and past 2,000 polygons), exact (closed form for every pair:
    /// an error where a polygon may come between two) or hemisphere (every pair from
    /// --origins² hemispheres a patch).
    #[arg(long, value_enum, default_value_t = ViewFactorMethodKind::Auto)]
    pub method: ViewFactorMethodKind,
    /// The closed-form factors' quadrature tolerance, relative (default 1e-10).
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// N: N x N hemispheres spread over each patch and averaged (area to area; 1 is
    /// point to area, from the patch centre). Default 2.
    #[arg(long, default_value_t = rad_pipeline::viewfactors::DEFAULT_ORIGINS)]
    pub origins: u32,
    /// Hemisphere cells, N_THETAxN_PHI.
    #[arg(long, default_value = "180x720")]
    pub resolution: String,
    /// raw: as computed; reciprocal: A_I F_IJ = A_J F_JI, each row keeping its sum;
    /// closed: reciprocal and every row summing to 1 (a closed scene only: rows that
    /// leak are named). Default: closed for a .vs3 file that says encl=1, else raw.
    #[arg(long, value_enum)]
    pub enclosure: Option<EnclosureKind>,
    /// Hottel's total exchange factors (script-F) from the surfaces' emissivities
    /// (1 - reflectance), after the enclosure rule; on for a .vs3 file that says emit=1.
    #[arg(long)]
    pub script_f: bool,
    /// json (surfaces and sparse rows), csv (a dense table, names in the first row
    /// and column), mtx (Matrix Market, for scipy.io.mmread), view3d (View3D's
    /// text output: areas, rows, emissivities) or bin (coherad's compact binary
    /// triplets: see docs/formats.md; with --by patch --enclosure raw, written as rows are
    /// made, never held). Default: from --out's extension (.csv, .mtx, .bin), else
    /// json.
    #[arg(long, value_enum)]
    pub format: Option<FormatKind>,
    /// How hemispheres are made: scan, hierarchy, facets or grid (the same factors, to the
    /// bit). Default: the fastest for the scene.
    #[arg(long)]
    pub caster: Option<CasterKind>,
    /// Write here instead of standard output (atomically: all or nothing). With
    /// --motion, a folder (made if missing) that gets one file a step; or, in the bin
    /// format, a FILE.bin that gets every step, with a step index.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A motion file (JSON, or a glTF file whose node animations move its meshes; see docs/formats.md): named groups moved rigidly through
    /// steps. Writes one matrix a step into the folder --out, step_0000.json and on (the
    /// format's extension), each when made, or every step into one --out FILE.bin; a step
    /// casts again only the cells that what moved can change, and gives the factors a
    /// whole run of that step gives, to the bit.
    #[arg(long)]
    pub motion: Option<PathBuf>,
}

/// `coherad solve`'s flags.
#[derive(clap::Args)]
pub struct SolveArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// Hemisphere cells, N_THETAxN_PHI (the report: 180x720).
    #[arg(long, default_value = "180x720")]
    pub resolution: String,
    #[command(flatten)]
    pub rows: RowFlags,
    /// gauss-seidel (gathering), progressive (shooting by unshot power) or jacobi
    /// (sweeps from the last sweep's radiosities: under MPI each rank holds only its rows).
    #[arg(long, value_enum, default_value_t = SolverKind::GaussSeidel)]
    pub solver: SolverKind,
    /// Stop when max |E + rho F B - B| / max B is at most this (stored: default 1e-9);
    /// matrix-free and out-of-core: when the largest unshot (or ungathered) radiosity
    /// over the largest radiosity is (default 1e-4)
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Stop after this many sweeps (Gauss-Seidel, progressive) or shots (matrix-free,
    /// out-of-core)
    /// even if not converged (the exit code is then 3). Default: 10,000,000.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub max_iterations: Option<u64>,
    /// Solve the rows as computed, without making them reciprocal first (energy is then
    /// conserved only to their reciprocity error).
    #[arg(long)]
    pub raw: bool,
    /// How to hold the form factors: stored (every row made once, kept compact, made
    /// reciprocal), out-of-core (every row made once and written compact to an unnamed
    /// file in --temp-dir, then shot from there as matrix-free shoots), matrix-free
    /// (progressive refinement making each shooter's row when it shoots, keeping what
    /// the memory limit allows; exact rows only), or auto: stored if an estimate from
    /// 64 sample rows fits --memory-limit, else out-of-core if the temporary folder has
    /// room, else matrix-free
    #[arg(long, value_enum, default_value_t = StorageKind::Auto)]
    pub storage: StorageKind,
    /// Bytes the form factors may take (K, M, G suffixes: powers of 1024); the scene,
    /// the caster and per-patch arrays come on top
    #[arg(long, default_value = "1.5G")]
    pub memory_limit: String,
    /// Where out-of-core solving writes its rows (an unnamed file: nothing is left
    /// behind, however the run ends). Default: TMPDIR, else /tmp
    #[arg(long)]
    pub temp_dir: Option<PathBuf>,
    /// The solution file (atomically: all or nothing). With --motion, a folder (made
    /// if missing) that gets one solution file a step.
    #[arg(long)]
    pub out: PathBuf,
    /// A motion file (JSON, or a glTF file whose node animations move its meshes; see docs/formats.md): named groups moved rigidly through
    /// steps. Writes one solution a step into --out, step_0000.json and on, each when
    /// made; a step's rows are exact and cast again only the cells that what moved can
    /// change (the rows a whole run of that step makes, to the bit), stored, and
    /// Gauss-Seidel starts from the step before's radiosities.
    #[arg(long)]
    pub motion: Option<PathBuf>,
}

/// `coherad export`'s flags.
#[derive(clap::Args)]
pub struct ExportArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// A solution file written by `coherad solve` for this scene: its radiosity is baked
    /// into vertex colours (without one, the geometry and materials alone).
    #[arg(long)]
    pub solution: Option<PathBuf>,
    /// The file to write: .glb (binary glTF), .gltf (glTF, buffer embedded) or .ply.
    #[arg(long)]
    pub out: PathBuf,
    /// Exposure in stops: the colours are B x 2^EV, clipped to [0, 1]. Default: the 95th
    /// percentile of the patches' luminance maps to 0.8.
    #[arg(long, allow_negative_numbers = true, value_name = "EV")]
    pub exposure: Option<f64>,
    /// A motion file (JSON, or a glTF file whose node animations move its meshes; see docs/formats.md): one binary glTF a step of the scene
    /// moved as `solve --motion` moved it. --solution is then the folder `solve
    /// --motion` wrote, --out a folder that gets step_0000.glb and on, all at the first
    /// step's exposure.
    #[arg(long)]
    pub motion: Option<PathBuf>,
}

/// `coherad render`'s flags.
#[derive(clap::Args)]
pub struct RenderArgs {
    /// The scene file: .json, .obj (with its MTL), .vs3, .ply, .stl, .gltf or .glb.
    pub scene: PathBuf,
    /// A solution file written by `coherad solve` for this scene.
    #[arg(long)]
    pub solution: PathBuf,
    /// The EXR image (linear RGB radiosity, or radiance with --radiance).
    #[arg(long)]
    pub out: PathBuf,
    /// Camera position X,Y,Z: with --look-at, the camera of a scene that has none
    /// (an OBJ file), or to override the scene's; alone, it moves the scene's camera.
    #[arg(long)]
    pub eye: Option<String>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long)]
    pub look_at: Option<String>,
    /// The camera's up direction X,Y,Z (default: the scene camera's, else 0,1,0).
    #[arg(long)]
    pub up: Option<String>,
    /// Vertical field of view, degrees (default: the scene camera's, else 50).
    #[arg(long)]
    pub fov: Option<f32>,
    /// Write radiance B / pi (what a path tracer or a viewer shows) instead of radiosity B.
    #[arg(long)]
    pub radiance: bool,
    /// Also a tone-mapped sRGB PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Image width, pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// SAMPLES x SAMPLES rays a pixel.
    #[arg(long, default_value_t = 2)]
    pub samples: u32,
    /// flat: each patch's own value; smooth: interpolated from patch corners.
    #[arg(long, value_enum, default_value_t = ShadingKind::Smooth)]
    pub shading: ShadingKind,
    /// PNG exposure (multiplier before tone mapping); default: the 95th percentile of lit pixels maps to 0.8.
    #[arg(long)]
    pub exposure: Option<f32>,
    /// A motion file (JSON, or a glTF file whose node animations move its meshes; see docs/formats.md): one image a step of the scene moved
    /// as `solve --motion` moved it. --solution is then the folder `solve --motion`
    /// wrote, --out (and --png) folders that get step_0000.exr (.png) and on; the
    /// camera stays, and the PNGs share the first step's exposure.
    #[arg(long)]
    pub motion: Option<PathBuf>,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SolverKind {
    GaussSeidel,
    Progressive,
    /// Jacobi sweeps over stored rows; under MPI each rank holds only its own rows.
    Jacobi,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StorageKind {
    Auto,
    Stored,
    OutOfCore,
    MatrixFree,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ByKind {
    Patch,
    Polygon,
    Group,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EnclosureKind {
    Raw,
    Reciprocal,
    Closed,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ViewFactorMethodKind {
    Auto,
    Exact,
    Hemisphere,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatKind {
    Json,
    Csv,
    Mtx,
    View3d,
    Bin,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShadingKind {
    Flat,
    Smooth,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    Auto,
    Exact,
    Estimated,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EstimatorMode {
    Faithful,
    Improved,
}

/// The flags that name a way to make rows.
#[derive(clap::Args)]
pub struct RowFlags {
    /// exact: every hemisphere cast; estimated: 3x3 windows of a polygon (a mesh: windows of about nine neighbouring triangles of one plane), centres cast, the rest estimated (improved by default); auto: estimated where it pays (a scene of 20,000 patches or more whose windows estimate half of them or more: a mesh of flat walls), else exact. Default: auto for solve, exact for formfactors.
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// With --method estimated (or auto, where it estimates): the report's method (faithful) or visibility estimation (improved).
    #[arg(long, value_enum, default_value_t = EstimatorMode::Improved)]
    pub estimator: EstimatorMode,
    /// How exact hemispheres are made (with --method estimated: the window centres,
    /// improved mode's real rays and exact fallbacks): scan (each polygon tested on the
    /// cells it can cover), hierarchy (the scan over a bounding volume hierarchy,
    /// skipping hidden subtrees), facets (the scan over a mesh's flat pieces, each
    /// cell's triangle found in its piece's grid) or grid (each cell's ray through the
    /// voxel grid, the report's way). All give the same rows, to the bit. Default: the
    /// fastest for the scene (scan below 1024 polygons; from there facets where the flat
    /// pieces hold 128 polygons or more on average, else hierarchy).
    #[arg(long)]
    pub caster: Option<CasterKind>,
}

impl RowFlags {
    /// The method the flags name, `default` where `--method` is not given.
    pub fn choice(&self, default: Method) -> MethodChoice {
        let mode = match self.estimator {
            EstimatorMode::Faithful => Mode::Faithful,
            EstimatorMode::Improved => Mode::Improved,
        };
        match self.method.unwrap_or(default) {
            Method::Auto => MethodChoice::Auto(mode),
            Method::Exact => MethodChoice::Exact,
            Method::Estimated => MethodChoice::Estimated(mode),
        }
    }
}

impl SolverKind {
    pub fn solver(self) -> Solver {
        match self {
            SolverKind::GaussSeidel => Solver::GaussSeidel,
            SolverKind::Progressive => Solver::Progressive,
            SolverKind::Jacobi => Solver::Jacobi,
        }
    }
}

impl StorageKind {
    /// The storage asked for; `None`: auto.
    pub fn storage(self) -> Option<Storage> {
        match self {
            StorageKind::Auto => None,
            StorageKind::Stored => Some(Storage::Stored),
            StorageKind::MatrixFree => Some(Storage::MatrixFree),
            StorageKind::OutOfCore => Some(Storage::OutOfCore),
        }
    }
}

impl ByKind {
    pub fn grouping(self) -> Grouping {
        match self {
            ByKind::Patch => Grouping::Patch,
            ByKind::Polygon => Grouping::Polygon,
            ByKind::Group => Grouping::Group,
        }
    }
}

impl ViewFactorMethodKind {
    pub fn method(self) -> ViewFactorMethod {
        match self {
            ViewFactorMethodKind::Auto => ViewFactorMethod::Auto,
            ViewFactorMethodKind::Exact => ViewFactorMethod::Exact,
            ViewFactorMethodKind::Hemisphere => ViewFactorMethod::Hemisphere,
        }
    }
}

impl EnclosureKind {
    pub fn enclosure(self) -> Enclosure {
        match self {
            EnclosureKind::Raw => Enclosure::Raw,
            EnclosureKind::Reciprocal => Enclosure::Reciprocal,
            EnclosureKind::Closed => Enclosure::Closed,
        }
    }
}

impl ShadingKind {
    pub fn shading(self) -> Shading {
        match self {
            ShadingKind::Flat => Shading::Flat,
            ShadingKind::Smooth => Shading::Smooth,
        }
    }
}

/// The matrix format of `--format`, else of `--out`'s extension (.csv, .mtx, .bin, any
/// case), else JSON.
pub fn matrix_format(format: Option<FormatKind>, out: Option<&Path>) -> MatrixFormat {
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
    fn the_format_follows_the_flag_then_the_extension() {
        let out = Some(Path::new("vf.CSV"));
        assert_eq!(matrix_format(None, out), MatrixFormat::Csv);
        assert_eq!(matrix_format(Some(FormatKind::Mtx), out), MatrixFormat::Mtx);
        assert_eq!(matrix_format(None, None), MatrixFormat::Json);
    }
}

/// A `--weld` distance: finite, at least 0.
fn weld_distance(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(d) if d.is_finite() && d >= 0.0 => Ok(d),
        _ => Err(format!(
            "{text:?} is not a distance: give a finite number >= 0"
        )),
    }
}
