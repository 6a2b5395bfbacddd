//! The harness. `cargo xtask reproduce [--quick]` reproduces the report (the cube's
//! accuracy, estimation's error, Tables 1 and 2, figures 7 to 9, the report's solves)
//! into results/; `cargo xtask bench [--quick] [--only SECTIONS]` runs the extended
//! measurements (scaling, viewfactors, ranks, meshes, motion, solves) into results/; both
//! rewrite the README's figures table when they write results/. `cargo xtask scenes`
//! rewrites bench-scenes/ from the builders (`--sculptures`: the scan-like galleries,
//! too large to commit, to target/scenes).
//!
//! - `figures`: the README's table of current figures, from results/.
//! - `plot`: the scaling plot (results/scaling.png).
//! - `provenance`: the revision, machine, threads, command and date of a run.
//! - `reproduce`: `reproduce` and `bench`, writing what `rad_repro` returns.
//! - `scenes`: `scenes`, bench-scenes/ from `rad_geometry::scenes`.
//! - `solves`: `coherad solve` run as a user runs it, timed, its peak memory measured.
//! - `tidy` (tests): the house rules: `//!` headers, no glob re-exports, no `should_panic`
//!   or `ignore`, the crate arrows, functions of at most 120 lines; `tidy/cycles.rs`: no
//!   module cycles within a crate.

mod figures;
mod plot;
mod provenance;
mod reproduce;
mod scenes;
mod solves;
#[cfg(test)]
mod tidy;

use anyhow::{bail, Context, Result};
use rad_pipeline::output::write_atomic;
use std::path::{Path, PathBuf};

fn usage() -> &'static str {
    "usage: cargo xtask reproduce [--quick] [--out DIR] [--threads N]\n       cargo xtask bench [--quick] [--only scaling,viewfactors,ranks,meshes,motion,solves] [--out DIR] [--threads N]\n       cargo xtask scenes [--out DIR] [--sculptures]"
}

/// The command line, read by hand (a harness needs no more).
struct Args {
    quick: bool,
    out: Option<PathBuf>,
    threads: Option<usize>,
    only: Vec<String>,
    sculptures: bool,
}

fn parse(rest: &[String]) -> Result<Option<Args>> {
    let mut a = Args {
        quick: false,
        out: None,
        threads: None,
        only: Vec::new(),
        sculptures: false,
    };
    let mut rest = rest.iter();
    while let Some(flag) = rest.next() {
        match flag.as_str() {
            "--quick" => a.quick = true,
            "--sculptures" => a.sculptures = true,
            "--out" => a.out = Some(rest.next().context("--out needs a directory")?.into()),
            "--only" => {
                let list = rest.next().context("--only needs a list of sections")?;
                a.only = list.split(',').map(|s| s.trim().to_string()).collect();
                let known = [
                    "scaling",
                    "viewfactors",
                    "ranks",
                    "meshes",
                    "motion",
                    "solves",
                ];
                if let Some(bad) = a.only.iter().find(|s| !known.contains(&s.as_str())) {
                    bail!(
                        "--only: no section {bad:?} (sections: {})",
                        known.join(", ")
                    );
                }
            }
            "--threads" => {
                let n: usize = rest
                    .next()
                    .context("--threads needs a count")?
                    .parse()
                    .context("--threads needs a count")?;
                if n == 0 {
                    bail!("--threads must be at least 1");
                }
                a.threads = Some(n);
            }
            "-h" | "--help" => return Ok(None),
            other => bail!("unknown argument {other:?}\n{}", usage()),
        }
    }
    Ok(Some(a))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(cmd) = args.first() else {
        bail!("{}", usage())
    };
    let Some(a) = parse(&args[1..])? else {
        println!("{}", usage());
        return Ok(());
    };
    if let Some(n) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the thread pool")?;
    }
    let root = workspace_root();
    let quick_out = |name: &str| root.join("target").join(name);
    let results = root.join("results");
    match cmd.as_str() {
        "reproduce" => {
            let default = if a.quick {
                quick_out("repro-quick")
            } else {
                results
            };
            reproduce::reproduce(a.quick, &a.out.unwrap_or(default), &root, &args)
        }
        "bench" => {
            let default = if a.quick {
                quick_out("bench-quick")
            } else {
                results
            };
            let out = a.out.unwrap_or(default);
            reproduce::bench(a.quick, &a.only, &out, &root, &args)
        }
        "scenes" if a.sculptures => {
            scenes::write_sculptures(&a.out.unwrap_or(root.join("target").join("scenes")))
        }
        "scenes" => scenes::write_scenes(&a.out.unwrap_or(root.join("bench-scenes"))),
        other => bail!("unknown command {other:?}\n{}", usage()),
    }
}

/// Writes `bytes` to `path` atomically, and says so.
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes))
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("  wrote {}", path.display());
    Ok(())
}

/// Writes `text` to `dir/name` atomically, and says so.
fn write_text(dir: &Path, name: &str, text: &str) -> Result<()> {
    write_file(&dir.join(name), text.as_bytes())
}

/// The workspace root: xtask's manifest directory's parent.
fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}
