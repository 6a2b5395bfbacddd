//! `coherad export`: a scene, and a solution baked into vertex colours, as glTF or PLY.

use crate::context::Ctx;
use crate::exit::{Error, Outcome};
use crate::flags::ExportArgs;
use crate::report::say;
use rad_pipeline::export::{export, ExportFormat};
use rad_pipeline::solve::read_solution;

pub fn run(ctx: &Ctx, args: &ExportArgs) -> Result<Outcome, Error> {
    let scene = ctx.load(&args.scene)?;
    ExportFormat::of_path(&args.out)?;
    let b = match &args.solution {
        Some(path) => Some(read_solution(path, &scene)?),
        None => None,
    };
    let summary = export(&scene, b.as_deref(), args.exposure, &args.out)?;
    let scale = summary
        .scale
        .map(|s| format!(", colours B x {s:.4} (EV {:+.2})", s.log2()))
        .unwrap_or_default();
    say!(
        ctx.report,
        "wrote {}: {} meshes, {} vertices, {} triangles, {} bytes{scale}",
        args.out.display(),
        summary.meshes,
        summary.vertices,
        summary.triangles,
        summary.bytes
    );
    Ok(Outcome::Done)
}
