//! What every command starts from: the flags, the processes sharing the run and the
//! report; the scene as the global flags load it; output to a file (atomically) or to
//! standard output; rows made by this process or shared among MPI ranks.

use crate::exit::Error;
use crate::flags::Cli;
use crate::ranks::Ranks;
use crate::report::{say, warning, Report};
use indicatif::ProgressBar;
use rad_pipeline::output::write_atomic;
use rad_pipeline::share::{self, Peers};
use rad_pipeline::{
    parse_reflectance, parse_resolution, Hemisphere, HemisphereConfig, LoadConfig, RowMethod, Rows,
    SceneFile,
};
use std::io::Write;
use std::path::Path;

/// One run of one command.
pub struct Ctx<'a> {
    pub cli: &'a Cli,
    pub ranks: &'a Ranks,
    pub report: &'a Report,
}

/// How a share's rows are made: `make(patches, progress)`.
pub type MakeRows<'a> =
    dyn Fn(&[u32], &(dyn Fn(usize) + Sync)) -> Result<Rows, rad_pipeline::Error> + Sync + 'a;

impl Ctx<'_> {
    /// Loads a scene file as the global flags say; says what loading
    /// did ([`SceneFile::load_notes`]): notes, and warnings even when quiet.
    pub fn load(&self, path: &Path) -> Result<SceneFile, Error> {
        self.load_keeping(path, false).map(|(s, _)| s)
    }

    /// [`Ctx::load`], and the scene's description where `keep` says so.
    pub fn load_keeping(
        &self,
        path: &Path,
        keep: bool,
    ) -> Result<(SceneFile, Option<rad_pipeline::SceneDesc>), Error> {
        let cli = self.cli;
        let reflectance = cli
            .reflectance
            .as_deref()
            .map(parse_reflectance)
            .transpose()?;
        let config = LoadConfig {
            patch_size: cli.patch_size,
            triangulate: cli.triangulate,
            reflectance,
            materials: cli.materials.clone(),
            repair: cli.repair,
            weld: cli.weld,
        };
        let (scene, desc) = SceneFile::load_keeping(path, &config, keep)?;
        for note in scene.load_notes() {
            if note.warning {
                warning!(self.report, "warning: {}: {}", path.display(), note.text);
            } else {
                say!(self.report, "note: {}: {}", path.display(), note.text);
            }
        }
        Ok((scene, desc))
    }

    /// The rows of `ids` (`make` makes any of them), made by this process alone or
    /// shared among MPI ranks ([`rad_pipeline::share`]: each rank its share, balanced
    /// by the work units of `method`, the rows gathered on rank 0 in the list's order,
    /// the same to the bit); `None` on the ranks but the first. `bar` shows this
    /// process's rows. Each rank's part begins with a fingerprint of the run (the
    /// scene and `what`: the command's resolution, method, settings, patch list), so
    /// that ranks started on different runs are an error, not a mixed output.
    pub fn shared_rows(
        &self,
        scene: &SceneFile,
        method: RowMethod,
        ids: &[u32],
        what: &str,
        bar: &ProgressBar,
        make: &MakeRows<'_>,
    ) -> Result<Option<Rows>, Error> {
        let progress = |n: usize| bar.set_position(n as u64);
        let mut make = |ids: &[u32]| {
            bar.set_length(ids.len() as u64);
            make(ids, &progress)
        };
        let run = share::SharedRun {
            scene: &scene.scene,
            scene_hash: scene.hash,
            method,
            what: what.as_bytes(),
        };
        let shared = share::shared_rows(run, ids, self.ranks, false, &mut make)?;
        bar.finish_and_clear();
        if self.ranks.size() > 1 && shared.rows.is_some() {
            self.report.balance(&shared.shares);
        }
        Ok(shared.rows)
    }
}

/// The hemisphere of a `--resolution`.
pub fn hemisphere(resolution: &str) -> Result<Hemisphere, Error> {
    let (nt, np) = parse_resolution(resolution)?;
    Ok(Hemisphere::new(HemisphereConfig::exact(nt, np)).map_err(rad_pipeline::Error::from)?)
}

/// Writes through `fill` to `out` (atomically) or to standard output.
pub fn emit(
    out: Option<&Path>,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), Error> {
    match out {
        Some(path) => Ok(write_atomic(path, |w| fill(w))?),
        None => {
            let stdout = std::io::stdout();
            let mut lock = std::io::BufWriter::new(stdout.lock());
            fill(&mut lock)
                .and_then(|_| lock.flush())
                .map_err(Error::Stdout)
        }
    }
}
