//! What the commands that take `--motion` share: the folder of step files, the motion
//! read and checked, each step's scene, a step's line and the bar over the steps.

use crate::context::Ctx;
use crate::exit::Error;
use crate::report::{say, Report};
use indicatif::ProgressBar;
use rad_pipeline::share::Peers;
use rad_pipeline::viewfactors::MOTION_KEEP_BYTES;
use rad_pipeline::{read_motion, Hemisphere, Motion, RecastStats, SceneDesc, SceneFile};
use std::path::{Path, PathBuf};

/// What a step of a motion cast again, for its line on standard error.
pub(crate) fn recast_note(moved_polygons: usize, r: &RecastStats) -> String {
    let unkept = if r.not_kept > 0 {
        format!(
            "; {} patches kept nothing for the next step (over {} MiB of buffers)",
            r.not_kept,
            MOTION_KEEP_BYTES >> 20
        )
    } else {
        String::new()
    };
    format!(
        "{moved_polygons} polygons moved; {} patches cast whole, {} in part, {:.2} % of cells cast{unkept}",
        r.whole,
        r.partly,
        100.0 * r.cast_share()
    )
}

/// The folder `--out` names for a run over a motion, made if missing, and the motion
/// read from `path` and checked against `desc`: refused under MPI, without `--out`, or
/// with `--out` a file (before any folder is made).
pub(crate) fn motion_folder<'p>(
    ctx: &Ctx,
    out: Option<&'p Path>,
    path: &Path,
    desc: &SceneDesc,
) -> Result<(&'p Path, Motion), Error> {
    let Some(dir) = out else {
        return Err(Error::Flags(
            "--motion writes one file a step: give --out FOLDER".into(),
        ));
    };
    if dir.is_file() {
        return Err(Error::Flags(format!(
            "--out {} is a file: with --motion, give a folder (one file a step)",
            dir.display()
        )));
    }
    let motion = checked_motion(ctx, path, desc)?;
    std::fs::create_dir_all(dir).map_err(|source| rad_pipeline::Error::Io {
        action: "create",
        path: dir.to_path_buf(),
        source,
    })?;
    Ok((dir, motion))
}

/// A motion runs in one process: refused under MPI.
fn one_process(ctx: &Ctx) -> Result<(), Error> {
    if ctx.ranks.size() > 1 {
        return Err(Error::Flags(
            "--motion runs in one process: run it without mpirun".into(),
        ));
    }
    Ok(())
}

/// The motion read from `path` and checked against `desc`; refused under MPI.
pub(crate) fn checked_motion(ctx: &Ctx, path: &Path, desc: &SceneDesc) -> Result<Motion, Error> {
    one_process(ctx)?;
    let motion = read_motion(path).map_err(rad_pipeline::Error::from)?;
    motion.check(desc).map_err(rad_pipeline::Error::from)?;
    Ok(motion)
}

/// A bar over the patches of every step of `motion` (`what` over N steps).
pub(crate) fn steps_bar(
    report: &Report,
    motion: &Motion,
    n_patches: usize,
    hemi: &Hemisphere,
    what: &str,
) -> ProgressBar {
    let n_steps = motion.steps.len();
    report.bar(
        n_steps * n_patches,
        (n_steps * n_patches * hemi.n_cells()) as u64 / 10,
        "patches",
        format!("{what} over {n_steps} steps"),
    )
}

/// A scene loaded whole for a motion, and the motion: each step's scene, as `solve
/// --motion` made it (so that its solution file reads back against it).
pub(crate) struct Steps {
    pub scene: SceneFile,
    pub desc: SceneDesc,
    pub motion: Motion,
    unit: f64,
}

impl Steps {
    /// Loads `scene` keeping its description, reads `motion` and checks it against it
    /// (one process only: refused under MPI). Makes no folder.
    pub fn load(ctx: &Ctx, scene: &Path, motion: &Path) -> Result<Steps, Error> {
        one_process(ctx)?;
        let (scene, desc) = ctx.load_keeping(scene, true)?;
        let desc = desc.expect("kept as asked");
        let motion = checked_motion(ctx, motion, &desc)?;
        let unit = motion.unit(&desc);
        Ok(Steps {
            scene,
            desc,
            motion,
            unit,
        })
    }

    /// Step `k`'s scene, named for the step.
    pub fn scene(&self, k: usize) -> Result<SceneFile, Error> {
        Ok(rad_pipeline::step_scene_file(
            (&self.scene, &self.desc),
            &self.motion,
            self.unit,
            k,
        )?)
    }

    /// Step `k`'s file in `dir`: `step_0000.EXT` and on.
    pub fn file(dir: &Path, k: usize, ext: &str) -> PathBuf {
        dir.join(format!("step_{k:04}.{ext}"))
    }
}

/// `--solution` with `--motion`: the folder `solve --motion` wrote (a file, or no such
/// folder, is refused).
pub(crate) fn solution_folder(solution: Option<&Path>) -> Result<Option<&Path>, Error> {
    match solution {
        Some(p) if !p.is_dir() => Err(Error::Flags(format!(
            "--solution {} is {}: with --motion, give the folder `coherad solve --motion` wrote (step_0000.json and on)",
            p.display(),
            if p.exists() { "a file" } else { "no folder" }
        ))),
        other => Ok(other),
    }
}

/// Removes, from `dir`, the step files (`step_NNNN.EXT`, for each of `exts`) numbered
/// `n_steps` and on: an earlier, longer run's, which would pass for this run's; says how
/// many.
pub(crate) fn remove_stale(
    report: &Report,
    dir: &Path,
    n_steps: usize,
    exts: &[&str],
) -> Result<(), Error> {
    let mut removed = 0;
    let entries = std::fs::read_dir(dir).map_err(|source| rad_pipeline::Error::Io {
        action: "read",
        path: dir.to_path_buf(),
        source,
    })?;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else {
            continue;
        };
        let stale = name
            .strip_prefix("step_")
            .and_then(|rest| rest.split_once('.'))
            .is_some_and(|(k, ext)| {
                k.len() >= 4
                    && exts.contains(&ext)
                    && k.parse::<usize>().is_ok_and(|k| k >= n_steps)
            });
        if stale {
            let path = entry.path();
            std::fs::remove_file(&path).map_err(|source| rad_pipeline::Error::Io {
                action: "remove",
                path,
                source,
            })?;
            removed += 1;
        }
    }
    if removed > 0 {
        say!(
            report,
            "removed {removed} step files of an earlier, longer run from {}",
            dir.display()
        );
    }
    Ok(())
}

/// A folder for `--png` with `--motion`: made if missing (a file is refused).
pub(crate) fn made_folder(flag: &str, dir: &Path) -> Result<(), Error> {
    if dir.is_file() {
        return Err(Error::Flags(format!(
            "{flag} {} is a file: with --motion, give a folder (one file a step)",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|source| rad_pipeline::Error::Io {
        action: "create",
        path: dir.to_path_buf(),
        source,
    })?;
    Ok(())
}
