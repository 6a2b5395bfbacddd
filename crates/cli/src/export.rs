//! `coherad export`: a scene, and a solution baked into vertex colours, as glTF or PLY.

use crate::context::Ctx;
use crate::exit::{Error, Outcome};
use crate::flags::ExportArgs;
use crate::moving::{made_folder, remove_stale, solution_folder, Steps};
use crate::report::say;
use rad_pipeline::export::{export, ExportFormat, ExportSummary};
use rad_pipeline::solve::read_solution;
use std::path::Path;

pub fn run(ctx: &Ctx, args: &ExportArgs) -> Result<Outcome, Error> {
    if let Some(motion) = &args.motion {
        return moving(ctx, args, motion);
    }
    let scene = ctx.load(&args.scene)?;
    ExportFormat::of_path(&args.out)?;
    let b = match &args.solution {
        Some(path) => Some(read_solution(path, &scene)?),
        None => None,
    };
    let summary = export(&scene, b.as_deref(), args.exposure, &args.out)?;
    say!(ctx.report, "{}", wrote(&args.out, &summary));
    Ok(Outcome::Done)
}

/// What an export wrote, for standard error.
fn wrote(path: &Path, summary: &ExportSummary) -> String {
    let scale = summary
        .scale
        .map(|s| format!(", colours B x {s:.4} (EV {:+.2})", s.log2()))
        .unwrap_or_default();
    format!(
        "wrote {}: {} meshes, {} vertices, {} triangles, {} bytes{scale}",
        path.display(),
        summary.meshes,
        summary.vertices,
        summary.triangles,
        summary.bytes
    )
}

/// Over a motion: one binary glTF a step into the folder `--out`, each step's
/// solution (from the folder `--solution`, as `solve --motion` wrote it) baked in at
/// the first step's exposure, so that the steps compare.
fn moving(ctx: &Ctx, args: &ExportArgs, motion: &Path) -> Result<Outcome, Error> {
    let solutions = solution_folder(args.solution.as_deref())?;
    let steps = Steps::load(ctx, &args.scene, motion)?;
    let dir = &args.out;
    made_folder("--out", dir)?;
    let mut exposure = args.exposure;
    for k in 0..steps.motion.steps.len() {
        let scene = steps.scene(k)?;
        let b = match solutions {
            Some(d) => Some(read_solution(&Steps::file(d, k, "json"), &scene)?),
            None => None,
        };
        let path = Steps::file(dir, k, "glb");
        let summary = export(&scene, b.as_deref(), exposure, &path)?;
        if exposure.is_none() {
            exposure = summary.scale.map(f64::log2);
        }
        say!(ctx.report, "step {k}: {}", wrote(&path, &summary));
    }
    remove_stale(ctx.report, dir, steps.motion.steps.len(), &["glb"])?;
    Ok(Outcome::Done)
}
