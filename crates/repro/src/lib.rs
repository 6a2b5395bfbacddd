//! The report's experiments, run on our scenes, and their tables (JSON and Markdown)
//! for `cargo xtask reproduce` and `cargo xtask bench`, on top of the pipeline (`rad-pipeline`), whose rows,
//! solves and writers they use. It computes; it never prints.

pub mod accuracy;
pub mod bench;
pub mod closed_form;
pub mod estimation;
pub mod loft;
pub mod meshes;
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
