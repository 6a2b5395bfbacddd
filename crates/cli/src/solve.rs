//! `coherad solve`: every row made (exact or estimated), held as the memory limit
//! allows, solved; the solution file written, its energy balance said.

use crate::context::{emit, hemisphere, Ctx};
use crate::exit::{Error, Outcome, EXIT_NOT_CONVERGED};
use crate::flags::{Method, SolveArgs};
use crate::moving::{motion_folder, recast_note, remove_stale, steps_bar};
use crate::report::{say, warning, Report};
use indicatif::ProgressBar;
use rad_pipeline::output::write_atomic;
use rad_pipeline::share::Peers;
use rad_pipeline::solve::{
    check_motion_solve, solve_over_motion, solve_scene_shared, SceneSolveConfig, Solved,
};
use rad_pipeline::{
    parse_size, pick_method, settle_method, CasterKind, Progress, SceneFile, SolveRequest, Storage,
};
use std::path::Path;
use std::time::Instant;

pub fn run(ctx: &Ctx, args: &SolveArgs) -> Result<Outcome, Error> {
    if let Some(motion) = &args.motion {
        return moving(ctx, args, motion);
    }
    let scene = ctx.load(&args.scene)?;
    let picked = pick_method(&scene, args.rows.choice(Method::Auto), args.rows.caster)?;
    ctx.report.picked(&picked, scene.scene.patches().len());
    let config = request(args)?.config()?;
    let hemi = hemisphere(&args.resolution)?;
    warn_if_nothing_emits(ctx.report, &scene);
    let (method, changed) = settle_method(&scene, &hemi, &picked, &config, ctx.ranks.size())?;
    if changed {
        say!(
            ctx.report,
            "method auto: exact rows after all (matrix-free solving, asked for or the only storage that fits, casts each shooter's row)"
        );
    }
    let n = scene.scene.patches().len();
    let bar = ctx.report.row_bar(&hemi, method, n);
    let progress = |p| show(&bar, n, p);
    let solved = solve_scene_shared(&scene, &hemi, method, &config, &progress, ctx.ranks)?;
    bar.finish_and_clear();
    // (Rank 0 speaks for the run and writes its file.)
    let Some((file, solved, stats)) = solved else {
        return Ok(Outcome::Done);
    };
    ctx.report.estimates(method, &stats);
    report_storage(ctx.report, &solved, &config);
    if let Some(rec) = solved.reciprocity.filter(|r| !r.converged) {
        warning!(
            ctx.report,
            "warning: the reciprocal scaling stopped after {} products with rows off their sums by up to {:.1e}; energy is conserved only to that",
            rec.iterations,
            rec.max_row_sum_error
        );
    }
    let r = &solved.solution.report;
    say!(
        ctx.report,
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
    let text = serde_json::to_string_pretty(&file).map_err(|e| rad_pipeline::Error::Encode {
        what: "the solution file",
        reason: e.to_string(),
    })?;
    emit(Some(&args.out), |w| w.write_all(text.as_bytes()))?;
    if r.converged {
        return Ok(Outcome::Done);
    }
    warning!(
        ctx.report,
        "warning: the solve did not converge (residual {:.1e} after {} iterations); {} is written, the exit code is {EXIT_NOT_CONVERGED}",
        r.residual,
        r.iterations,
        args.out.display()
    );
    Ok(Outcome::NotConverged)
}

/// The solve the flags ask for.
fn request(args: &SolveArgs) -> Result<SolveRequest, Error> {
    Ok(SolveRequest {
        solver: args.solver.solver(),
        tolerance: args.tolerance,
        max_iterations: args.max_iterations,
        reciprocal: !args.raw,
        storage: args.storage.storage(),
        memory_limit: Some(parse_size(&args.memory_limit)?),
        temp_dir: args.temp_dir.clone(),
    })
}

/// Over a motion: one solution file a step into the folder `--out`, each written
/// (atomically) as it is made, so that a run stopped midway leaves only whole steps.
fn moving(ctx: &Ctx, args: &SolveArgs, motion: &Path) -> Result<Outcome, Error> {
    if args.rows.method == Some(Method::Estimated) {
        return Err(Error::Flags(
            "--motion makes exact rows (each step's from the step before's hemispheres): drop --method estimated".into(),
        ));
    }
    let (scene, desc) = ctx.load_keeping(&args.scene, true)?;
    let desc = desc.expect("kept as asked");
    let config = request(args)?.config()?;
    let hemi = hemisphere(&args.resolution)?;
    let caster = args
        .rows
        .caster
        .unwrap_or_else(|| CasterKind::fastest_for(&scene.scene));
    // (Refused before the folder is made.)
    check_motion_solve(&scene.scene, &hemi, caster, &config)?;
    let (dir, motion) = motion_folder(ctx, Some(&args.out), motion, &desc)?;
    warn_if_nothing_emits(ctx.report, &scene);
    let n = scene.scene.patches().len();
    let bar = steps_bar(ctx.report, &motion, n, &hemi, "exact rows and solves");
    let progress = |k: usize, p: Progress| {
        if let Progress::Rows(done) = p {
            bar.set_position((k * n + done) as u64);
        }
    };
    let report = ctx.report;
    let mut outcome = Outcome::Done;
    // (Each step's time runs from the end of the one before: file writing excluded.)
    let mut since = Instant::now();
    solve_over_motion(
        (&scene, &desc),
        &motion,
        &hemi,
        caster,
        &config,
        &progress,
        &mut |s| {
            let took = since.elapsed();
            let path = dir.join(format!("step_{:04}.json", s.step));
            let text =
                serde_json::to_string_pretty(&s.file).map_err(|e| rad_pipeline::Error::Encode {
                    what: "a solution file",
                    reason: e.to_string(),
                })?;
            write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
            let r = &s.solved.solution.report;
            let cost = recast_note(s.moved_polygons, &s.recast);
            bar.suspend(|| {
                say!(
                    report,
                    "step {} ({}): {cost}; {} sweeps{}, residual {:.1e}, energy imbalance {:.1e}; in {:.1} ms; {}",
                    s.step,
                    s.name,
                    r.iterations,
                    if s.warm { " from the step before" } else { "" },
                    r.residual,
                    s.solved.balance.relative_imbalance,
                    took.as_secs_f64() * 1e3,
                    path.display()
                );
                if !r.converged {
                    warning!(
                        report,
                        "warning: step {} did not converge (residual {:.1e} after {} iterations); {} is written, the exit code will be {EXIT_NOT_CONVERGED}",
                        s.step,
                        r.residual,
                        r.iterations,
                        path.display()
                    );
                }
            });
            if !r.converged {
                outcome = Outcome::NotConverged;
            }
            since = Instant::now();
            Ok(())
        },
    )?;
    bar.finish_and_clear();
    remove_stale(ctx.report, dir, motion.steps.len(), &["json"])?;
    Ok(outcome)
}

/// A solve's progress on its bar: rows made, then sweeps or shots.
fn show(bar: &ProgressBar, n: usize, p: Progress) {
    match p {
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
    }
}

/// Warns of a scene in which nothing emits (every radiosity would be 0).
fn warn_if_nothing_emits(report: &Report, scene: &SceneFile) {
    let sc = &scene.scene;
    if (0..sc.patches().len()).all(|p| sc.patch_material(p as u32).emission.0 == [0.0; 3]) {
        warning!(
            report,
            "warning: no polygon emits light (every material's emission is 0): every radiosity will be 0; give a material an \"emission\" (or use --materials)"
        );
    }
}

/// What an out-of-core or matrix-free solve held and did.
fn report_storage(report: &Report, solved: &Solved, config: &SceneSolveConfig) {
    let mib = |bytes: f64| bytes / (1u64 << 20) as f64;
    let m = &solved.matrix;
    if m.storage == Storage::OutOfCore.name() {
        say!(
            report,
            "out-of-core: rows written to a temporary file in {} ({:.0} MiB, removed); {} shots, {} rows read back, {} kept ({:.0} MiB)",
            config.temp_dir().display(),
            mib(m.disk_bytes as f64),
            solved.solution.report.iterations,
            m.rows_made,
            m.cached_rows,
            mib(m.bytes as f64)
        );
    }
    if m.storage == Storage::MatrixFree.name() {
        say!(
            report,
            "matrix-free: {} shots, {} rows made, {} kept ({:.0} MiB)",
            solved.solution.report.iterations,
            m.rows_made,
            m.cached_rows,
            mib(m.bytes as f64)
        );
    }
}
