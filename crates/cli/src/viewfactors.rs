//! `coherad viewfactors`: surface-to-surface view factors under an enclosure rule, in
//! one of five formats; shared among MPI ranks under `mpirun`, or (patch to patch, raw,
//! binary) written as the rows are made, never held.

use crate::context::{emit, hemisphere, Ctx};
use crate::exit::{Error, Outcome};
use crate::flags::{matrix_format, ViewfactorsArgs};
use crate::moving::{checked_motion, motion_folder, recast_note, remove_stale, steps_bar};
use crate::report::{say, warning, Report};
use indicatif::ProgressBar;
use rad_pipeline::matrix_file::StepsWriter;
use rad_pipeline::output::write_atomic;
use rad_pipeline::share::Peers;
use rad_pipeline::viewfactors::{
    area_rows, check_format, row_patches, stream_patch_matrix, view_factors, view_factors_of_rows,
    view_factors_over_motion, write_view_factors, MatrixFormat, StepViewFactors, ViewFactorConfig,
    ViewFactorRun, ViewFactors,
};
use rad_pipeline::{EstimateStats, Hemisphere, Motion, RowMethod, SceneFile, ViewFactorRequest};
use std::path::Path;

pub fn run(ctx: &Ctx, args: &ViewfactorsArgs) -> Result<Outcome, Error> {
    let (scene, desc) = ctx.load_keeping(&args.scene, args.motion.is_some())?;
    let request = ViewFactorRequest {
        by: args.by.map(|b| b.grouping()),
        method: Some(args.method.method()),
        tolerance: args.tolerance,
        origins: Some(args.origins),
        enclosure: args.enclosure.map(|e| e.enclosure()),
        script_f: args.script_f.then_some(true),
        caster: args.caster,
    };
    if let Some(c) = scene.view3d.as_ref().filter(|c| !c.ignored.is_empty()) {
        say!(
            ctx.report,
            "note: View3D options of its own integration, not used here: {}",
            c.ignored.join(" ")
        );
    }
    let format = matrix_format(args.format, args.out.as_deref());
    let out = args.out.as_deref();
    let hemi = hemisphere(&args.resolution)?;
    let (config, n_surfaces) = request.config(&scene)?;
    check_format(format, n_surfaces)?;
    if format == MatrixFormat::Bin && out.is_none() {
        return Err(Error::Flags(
            "--format bin writes a binary file: give --out FILE.bin".into(),
        ));
    }
    let bar = bar(ctx.report, &scene, &hemi, &config);
    let run = ViewFactorRun {
        scene: scene.path.display().to_string(),
        scene_hash: scene.hash_text(),
        resolution: (hemi.n_theta() as u32, hemi.n_phi() as u32),
    };
    if let (Some(motion), Some(desc)) = (&args.motion, desc) {
        return moving(ctx, (&scene, &desc), motion, &hemi, &config, format, out);
    }
    if ctx.ranks.size() > 1 {
        return shared(ctx, &scene, &hemi, &config, &bar, (&run, format, out));
    }
    if let (true, Some(path)) = (config.streams_to(format), out) {
        return streamed(ctx.report, &scene, &hemi, &config, &bar, &run, path);
    }
    let progress = |n: usize| bar.set_position(n as u64);
    let vf = view_factors(&scene.scene, &hemi, &config, &progress)?;
    bar.finish_and_clear();
    report_and_write(ctx.report, &vf, &run, format, out)
}

/// Over a motion: one file a step into the folder `out`, each written (atomically) as
/// it is made, so that a run stopped midway leaves only whole steps; or, with `--out
/// FILE.bin`, every step in that one file ([`moving_one_file`]).
fn moving(
    ctx: &Ctx,
    (scene, desc): (&SceneFile, &rad_pipeline::SceneDesc),
    motion: &Path,
    hemi: &Hemisphere,
    config: &ViewFactorConfig,
    format: MatrixFormat,
    out: Option<&Path>,
) -> Result<Outcome, Error> {
    if out.is_none() {
        return Err(Error::Flags(
            "--motion writes one file a step: give --out FOLDER (or --out FILE.bin: one binary file with a step index)".into(),
        ));
    }
    if let Some(file) = out.filter(|o| format == MatrixFormat::Bin && is_steps_file(o)) {
        let motion = checked_motion(ctx, motion, desc)?;
        return moving_one_file(ctx, (scene, desc, &motion), hemi, config, file);
    }
    let (dir, motion) = motion_folder(ctx, out, motion, desc)?;
    let ext = match format {
        MatrixFormat::View3d => "txt",
        f => f.name(),
    };
    over_steps(ctx, (scene, desc, &motion), hemi, config, &mut |s, run| {
        let path = dir.join(format!("step_{:04}.{ext}", s.step));
        write_atomic(&path, |w| write_view_factors(w, &s.vf, run, format))?;
        Ok(format!("; {}", path.display()))
    })?;
    remove_stale(ctx.report, dir, motion.steps.len(), &[ext])?;
    Ok(Outcome::Done)
}

/// Whether `--out` names one file for every step of a motion: `.bin`, not a folder (an
/// existing one, or a path ending in a separator).
fn is_steps_file(out: &Path) -> bool {
    let text = out.as_os_str().to_string_lossy();
    out.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("bin"))
        && !text.ends_with(std::path::is_separator)
        && !out.is_dir()
}

/// Over a motion, into one binary file with a step index
/// ([`rad_pipeline::matrix_file::StepsWriter`]), written whole once every step is made
/// (a run stopped midway leaves the file as it was).
fn moving_one_file(
    ctx: &Ctx,
    job: (&SceneFile, &rad_pipeline::SceneDesc, &Motion),
    hemi: &Hemisphere,
    config: &ViewFactorConfig,
    file: &Path,
) -> Result<Outcome, Error> {
    let mut failed: Option<rad_pipeline::Error> = None;
    let written = write_atomic(file, |w| {
        let mut steps = StepsWriter::begin(w)?;
        let made = over_steps(ctx, job, hemi, config, &mut |s, run| {
            steps
                .step(|w| write_view_factors(w, &s.vf, run, MatrixFormat::Bin))
                .map_err(|source| rad_pipeline::Error::Io {
                    action: "write",
                    path: file.to_path_buf(),
                    source,
                })?;
            Ok(String::new())
        });
        if let Err(e) = made {
            failed = Some(e);
            return Err(std::io::Error::other("a step failed"));
        }
        steps.finish().map(|_| ())
    });
    if let Some(e) = failed {
        return Err(e.into());
    }
    written?;
    say!(
        ctx.report,
        "wrote {} steps to {}",
        job.2.steps.len(),
        file.display()
    );
    Ok(Outcome::Done)
}

/// Every step of the motion, handed to `write` with its metadata as it is made (what
/// `write` returns ends the step's line on standard error), under a bar over the steps.
fn over_steps(
    ctx: &Ctx,
    (scene, desc, motion): (&SceneFile, &rad_pipeline::SceneDesc, &Motion),
    hemi: &Hemisphere,
    config: &ViewFactorConfig,
    write: &mut dyn FnMut(&StepViewFactors, &ViewFactorRun) -> Result<String, rad_pipeline::Error>,
) -> Result<(), rad_pipeline::Error> {
    let n_patches = scene.scene.patches().len();
    let bar = steps_bar(ctx.report, motion, n_patches, hemi, "view factors");
    let progress = |k: usize, n: usize| bar.set_position((k * n_patches + n) as u64);
    let report = ctx.report;
    // Each step's time runs from the end of the one before (loading the scene and
    // writing files excluded), so that users can weigh a step against a whole run.
    let mut since = std::time::Instant::now();
    view_factors_over_motion(
        desc,
        &scene.scene,
        motion,
        hemi,
        config,
        &progress,
        &mut |s| {
            let took = since.elapsed();
            let run = ViewFactorRun {
                scene: format!("{} at step {} ({})", scene.path.display(), s.step, s.name),
                scene_hash: s.scene_hash.clone(),
                resolution: (hemi.n_theta() as u32, hemi.n_phi() as u32),
            };
            let wrote = write(&s, &run)?;
            let cost = recast_note(s.moved_polygons, &s.recast);
            bar.suspend(|| {
                say!(
                    report,
                    "step {} ({}): {cost} in {:.1} ms{wrote}",
                    s.step,
                    s.name,
                    took.as_secs_f64() * 1e3,
                )
            });
            since = std::time::Instant::now();
            Ok(())
        },
    )?;
    bar.finish_and_clear();
    Ok(())
}

/// A bar over the patches, shown on long jobs.
fn bar(report: &Report, scene: &SceneFile, hemi: &Hemisphere, c: &ViewFactorConfig) -> ProgressBar {
    let n_patches = scene.scene.patches().len();
    let per_patch = u64::from(c.origins).pow(2);
    let rays = n_patches as u64 * per_patch * hemi.n_cells() as u64;
    let message = format!(
        "view factors {}x{}, {per_patch} hemispheres a patch",
        hemi.n_theta(),
        hemi.n_phi()
    );
    report.bar(n_patches, rays, "patches", message)
}

/// Shared among ranks: each its patches' rows, gathered on rank 0 (whole: the streaming
/// path is one process's).
fn shared(
    ctx: &Ctx,
    scene: &SceneFile,
    hemi: &Hemisphere,
    config: &ViewFactorConfig,
    bar: &ProgressBar,
    (run, format, out): (&ViewFactorRun, MatrixFormat, Option<&Path>),
) -> Result<Outcome, Error> {
    let scene_ = &scene.scene;
    let ids = row_patches(scene_);
    // (Every patch costs origins² hemispheres alike: exact rows' units.)
    let method = RowMethod::Exact {
        caster: config.caster,
    };
    let what = format!("viewfactors {}x{} {config:?}", hemi.n_theta(), hemi.n_phi());
    let make = |patches: &[u32], progress: &(dyn Fn(usize) + Sync)| {
        let rows = area_rows(scene_, hemi, config, patches, progress)?;
        Ok(rad_pipeline::Rows {
            method,
            sources: vec![None; rows.len()],
            stats: EstimateStats::default(),
            rows,
        })
    };
    let Some(made) = ctx.shared_rows(scene, method, &ids, &what, bar, &make)? else {
        return Ok(Outcome::Done);
    };
    let vf = view_factors_of_rows(scene_, config, made.rows)?;
    report_and_write(ctx.report, &vf, run, format, out)
}

/// Patch to patch, raw, binary: written as the rows are made, never held.
fn streamed(
    report: &Report,
    scene: &SceneFile,
    hemi: &Hemisphere,
    config: &ViewFactorConfig,
    bar: &ProgressBar,
    run: &ViewFactorRun,
    path: &Path,
) -> Result<Outcome, Error> {
    let progress = |n: usize| bar.set_position(n as u64);
    let mut done = None;
    write_atomic(path, |w| {
        let s = stream_patch_matrix(&scene.scene, hemi, config, run, w, &progress)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        done = Some(s);
        Ok(())
    })?;
    bar.finish_and_clear();
    let done = done.expect("written");
    say!(
        report,
        "{} rows, {} entries written as made; {} rows lose form factor to rays leaving the scene, {} see polygons from behind",
        done.n_patches,
        done.entries,
        done.escaping_rows,
        done.back_rows
    );
    Ok(Outcome::Done)
}

/// Notes what view factors lose (rays leaving the scene, backs), reports the enclosure
/// rule's changes, and writes them.
fn report_and_write(
    report: &Report,
    vf: &ViewFactors,
    run: &ViewFactorRun,
    format: MatrixFormat,
    out: Option<&Path>,
) -> Result<Outcome, Error> {
    let leaking = (0..vf.names.len()).filter(|&i| vf.escaped[i] > 0.0).count();
    if leaking > 0 {
        say!(
            report,
            "note: {leaking} of {} surfaces lose form factor to rays that leave the scene (the scene is not closed)",
            vf.names.len()
        );
    }
    let backs: Vec<&str> = (0..vf.names.len())
        .filter(|&i| vf.back[i] > 0.0)
        .map(|i| vf.names[i].as_str())
        .collect();
    if !backs.is_empty() {
        warning!(
            report,
            "warning: {} surfaces see polygons from behind (first: {:?}); those rays count as \"back\", in no factor; a mesh whose faces are wound inconsistently is oriented by --repair",
            backs.len(),
            backs[0]
        );
    }
    if vf.exact_pairs + vf.hemisphere_pairs > 0 {
        say!(
            report,
            "pairs of polygons: {} in closed form, {} from hemispheres ({} polygons cast)",
            vf.exact_pairs,
            vf.hemisphere_pairs,
            vf.hemisphere_polygons
        );
    }
    let r = &vf.report;
    say!(
        report,
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
    emit(out, |w| write_view_factors(w, vf, run, format))?;
    Ok(Outcome::Done)
}
