//! `coherad formfactors`: form-factor rows of chosen patches (JSON), shared among MPI
//! ranks when run under `mpirun`.

use crate::context::{emit, hemisphere, Ctx};
use crate::exit::{Error, Outcome};
use crate::flags::{FormfactorsArgs, Method};
use crate::report::warning;
use rad_pipeline::output::{write_row_json, write_rows_footer, write_rows_header};
use rad_pipeline::{parse_patch_list, pick_method};

pub fn run(ctx: &Ctx, args: &FormfactorsArgs) -> Result<Outcome, Error> {
    let scene = ctx.load(&args.scene)?;
    let picked = pick_method(&scene, args.rows.choice(Method::Exact), args.rows.caster)?;
    ctx.report.picked(&picked, scene.scene.patches().len());
    let method = picked.method;
    let hemi = hemisphere(&args.resolution)?;
    let scene_ = &scene.scene;
    let ids = parse_patch_list(&args.patches, scene_.patches().len())?;
    let bar = ctx.report.row_bar(&hemi, method, ids.len());
    let what = format!("formfactors {}x{} {method}", hemi.n_theta(), hemi.n_phi());
    let make = |patches: &[u32], progress: &(dyn Fn(usize) + Sync)| {
        rad_pipeline::rows(scene_, &hemi, method, patches, progress)
    };
    let Some(made) = ctx.shared_rows(&scene, method, &ids, &what, &bar, &make)? else {
        return Ok(Outcome::Done); // (a rank but the first: its rows went to rank 0)
    };
    ctx.report.estimates(made.method, &made.stats);
    let leaked: Vec<u32> = made
        .rows
        .iter()
        .filter(|r| r.escaped > 0.0)
        .map(|r| r.patch)
        .collect();
    if !leaked.is_empty() {
        warning!(
            ctx.report,
            "warning: {} row(s) lose form factor to rays that leave the scene (first: patch {}); the scene is not closed",
            leaked.len(),
            leaked[0]
        );
    }
    let backs: Vec<&rad_pipeline::Row> = made.rows.iter().filter(|r| r.back > 0.0).collect();
    if let Some(first) = backs.iter().max_by(|a, b| a.back.total_cmp(&b.back)) {
        let polygon = scene_.patches()[first.patch as usize].polygon as usize;
        warning!(
            ctx.report,
            "warning: {} row(s) see polygons from behind (their \"back\" form factor is > 0; most: patch {} of polygon {polygon} ({:?}), {:.3e} of its hemisphere); a mesh whose faces are wound inconsistently is oriented by --repair",
            backs.len(),
            first.patch,
            scene_.polygons()[polygon].name(),
            first.back
        );
    }
    let res = (hemi.n_theta() as u32, hemi.n_phi() as u32);
    emit(args.out.as_deref(), |w| {
        write_rows_header(w, res, method.rows_name(), scene_.patches().len())?;
        for (k, (r, src)) in made.rows.iter().zip(&made.sources).enumerate() {
            write_row_json(w, r, *src, k == 0)?;
        }
        write_rows_footer(w)
    })?;
    Ok(Outcome::Done)
}
