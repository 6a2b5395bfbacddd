//! `coherad patches`: every patch of a scene (JSON).

use crate::context::{emit, Ctx};
use crate::exit::{Error, Outcome};
use crate::flags::PatchesArgs;
use rad_pipeline::output::write_patches_json;

pub fn run(ctx: &Ctx, args: &PatchesArgs) -> Result<Outcome, Error> {
    let scene = ctx.load(&args.scene)?;
    emit(args.out.as_deref(), |w| write_patches_json(w, &scene.scene))?;
    Ok(Outcome::Done)
}
