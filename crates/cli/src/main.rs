//! `coherad`: patches, form factors, view factors, radiosity solutions, images and
//! exports of any scene file, from the command line.
//!
//! A thin map over `rad-pipeline`: [`flags`] holds every flag (clap) and what it names
//! in the pipeline's terms; one module a command ([`patches`], [`formfactors`],
//! [`viewfactors`], [`solve`], [`render`], [`export`]), each a `run` that returns an
//! [`exit::Outcome`] or a typed [`exit::Error`] ([`exit`]: the exit codes);
//! [`context`] loads scenes and writes outputs; [`report`] holds notes, warnings and
//! progress bars; `ranks` is the processes sharing a run (`ranks_mpi.rs` with the `mpi`
//! feature, else `ranks_one.rs`). What the binary and the Python package both decide (the
//! method and auto's pick, a solve's and view factors' settings) is the pipeline's
//! (`rad_pipeline::{pick_method, SolveRequest, ...}`).
//! Exit codes: 0 done, 1 an error, 2 a usage error (clap's), 3 a solve that did not
//! converge (its file written all the same).

mod context;
mod exit;
mod export;
mod flags;
mod formfactors;
mod moving;
mod patches;
mod render;
mod report;
mod solve;
mod viewfactors;

// The processes sharing a run: MPI's ranks with the `mpi` feature, else one.
#[cfg(feature = "mpi")]
#[path = "ranks_mpi.rs"]
mod ranks;
#[cfg(not(feature = "mpi"))]
#[path = "ranks_one.rs"]
mod ranks;

use clap::Parser;
use context::Ctx;
use exit::{Error, Outcome, EXIT_ERROR, EXIT_NOT_CONVERGED, EXIT_USAGE};
use flags::{Cli, Command};
use rad_pipeline::share::Peers;
use ranks::Ranks;
use report::Report;
use std::process::ExitCode;

fn main() -> ExitCode {
    ExitCode::from(run(&Cli::parse()))
}

/// Runs the command the flags name; its exit code.
fn run(cli: &Cli) -> u8 {
    if let Some(n) = cli.threads {
        if n == 0 {
            eprintln!("error: --threads must be at least 1");
            return EXIT_USAGE;
        }
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("error: cannot start {n} threads: {e}");
            return EXIT_ERROR;
        }
    }
    let ranks = Ranks::init();
    // Rank 0 speaks for the run; the others' errors reach it in the gather.
    let report = Report::new(cli.quiet, ranks.rank() > 0);
    let ctx = Ctx {
        cli,
        ranks: &ranks,
        report: &report,
    };
    // A panic is an error like any other here, so that under MPI it is gathered too
    // (a rank that unwound without gathering would leave rank 0 waiting).
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| command(&ctx)))
        .unwrap_or_else(|p| {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(Error::Panic(what))
        });
    // Every rank gathers once: one that ended before it sends its error (or nothing).
    let result = if ranks.gathered() {
        result
    } else {
        let part = result
            .as_ref()
            .map(|_| Vec::new())
            .map_err(|e| e.to_string());
        ranks.gather(part).map_err(Error::Peers).and(result)
    };
    if ranks.rank() > 0 {
        return 0;
    }
    match result {
        Ok(Outcome::Done) => 0,
        Ok(Outcome::NotConverged) => EXIT_NOT_CONVERGED,
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_ERROR
        }
    }
}

/// The command, once the processes and the report are set up.
fn command(ctx: &Ctx) -> Result<Outcome, Error> {
    let shared = matches!(
        ctx.cli.command,
        Command::Formfactors(_) | Command::Viewfactors(_) | Command::Solve(_)
    );
    if ctx.ranks.size() > 1 && !shared {
        return Err(Error::Flags(format!(
            "under MPI ({} ranks) only `coherad formfactors`, `viewfactors` and `solve` are shared: run this command as one process",
            ctx.ranks.size()
        )));
    }
    match &ctx.cli.command {
        Command::Patches(args) => patches::run(ctx, args),
        Command::Formfactors(args) => formfactors::run(ctx, args),
        Command::Viewfactors(args) => viewfactors::run(ctx, args),
        Command::Solve(args) => solve::run(ctx, args),
        Command::Render(args) => render::run(ctx, args),
        Command::Export(args) => export::run(ctx, args),
    }
}
