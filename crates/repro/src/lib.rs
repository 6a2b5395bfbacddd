//! The report's experiments, run on our scenes, and their tables (JSON and Markdown)
//! for `cargo xtask reproduce` and `cargo xtask bench`, on top of the pipeline
//! (`rad-pipeline`), whose rows, solves and writers they use. It computes; it never prints.
//!
//! - `reproduce`: the report's run and REPORT.md, from the modules below it:
//!   - `accuracy`: the exact hemisphere against Lambert in the empty cube, and face to face;
//!   - `loft`: checks on our loft (counts, closure, reciprocity, exact hemisphere speed);
//!   - `reciprocity`: reciprocity over the pairs of a set of rows;
//!   - `estimation`: the estimation-error experiment;
//!   - `speedup`: Table 1, Table 2, figures 7-9 and the cube's and Cornell box's solves.
//! - `bench`: `cargo xtask bench`'s sections and BENCH.md, from the modules below it:
//!   - `scaling`: exact hemispheres of every caster as scenes grow;
//!   - `viewfactors`: view factors against closed forms and at scale;
//!   - `ranks`: rows and solves shared among simulated processes, checked to the bit;
//!   - `meshes`: estimation across polygons on the mesh scenes.
//! - `closed_form`: closed-form view factors (squares, discs, obstructed plates).
//! - `stats`: summary statistics of samples.

pub mod accuracy;
pub mod bench;
pub mod closed_form;
pub mod estimation;
pub mod loft;
pub mod meshes;
pub mod motion;
pub mod ranks;
pub mod reciprocity;
pub mod reproduce;
pub mod scaling;
pub mod speedup;
pub mod stats;
pub mod viewfactors;

pub use rad_pipeline::Error;

/// A pool of one thread, for timings.
pub(crate) fn one_thread() -> Result<rayon::ThreadPool, Error> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| Error::Parse {
            what: "thread pool",
            input: "1".into(),
            reason: e.to_string(),
        })
}

/// Where a figure comes from: filled in by the harness (the library reads no
/// environment) and written into every JSON result.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Provenance {
    pub git_revision: String,
    pub cpu_model: String,
    pub nproc: usize,
    pub threads: usize,
    pub profile: String,
    pub command: String,
    /// The day of the run (UTC), YYYY-MM-DD.
    pub date: String,
}

impl Provenance {
    /// The line a report opens with: the command, revision, machine, build and wall time
    /// (and a warning on a quick run's figures).
    pub fn written_by(&self, wall_seconds: f64, quick: bool) -> String {
        format!(
            "Written by `{}` at git revision `{}` on {} ({} cores, {} threads, {} build), in {:.1} s.{}",
            self.command,
            self.git_revision,
            self.cpu_model,
            self.nproc,
            self.threads,
            self.profile,
            wall_seconds,
            if quick {
                " **Quick run: small settings, for CI; not the reported figures.**"
            } else {
                ""
            }
        )
    }
}
