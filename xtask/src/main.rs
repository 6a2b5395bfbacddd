//! The harness: `cargo xtask reproduce [--quick] [--out DIR] [--threads N]` runs the
//! experiments and writes results/; `cargo xtask solves [--quick]` runs its solve
//! section alone (`coherad solve` on bench scenes, timed, peak memory measured);
//! `cargo xtask scenes` rewrites bench-scenes/ from the builders.

mod plot;
mod reproduce;
mod solves;
#[cfg(test)]
mod tidy;

use anyhow::{bail, Context, Result};
use std::path::PathBuf;

fn usage() -> &'static str {
    "usage: cargo xtask reproduce [--quick] [--out DIR] [--threads N]\n       cargo xtask solves [--quick] [--out DIR]\n       cargo xtask scenes [--out DIR]"
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(cmd) = args.first() else {
        bail!("{}", usage())
    };
    let mut quick = false;
    let mut out: Option<PathBuf> = None;
    let mut threads: Option<usize> = None;
    let mut rest = args[1..].iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--quick" => quick = true,
            "--out" => out = Some(rest.next().context("--out needs a directory")?.into()),
            "--threads" => {
                let n: usize = rest
                    .next()
                    .context("--threads needs a count")?
                    .parse()
                    .context("--threads needs a count")?;
                if n == 0 {
                    bail!("--threads must be at least 1");
                }
                threads = Some(n);
            }
            "-h" | "--help" => {
                println!("{}", usage());
                return Ok(());
            }
            other => bail!("unknown argument {other:?}\n{}", usage()),
        }
    }
    if let Some(n) = threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the thread pool")?;
    }
    let root = workspace_root();
    match cmd.as_str() {
        "reproduce" => {
            let default = if quick {
                root.join("target").join("repro-quick")
            } else {
                root.join("results")
            };
            reproduce::reproduce(quick, &out.unwrap_or(default), &root, &args)
        }
        "solves" => {
            let default = root.join("target").join("solves");
            reproduce::solves_alone(quick, &out.unwrap_or(default), &root, &args)
        }
        "scenes" => reproduce::write_scenes(&out.unwrap_or(root.join("bench-scenes"))),
        other => bail!("unknown command {other:?}\n{}", usage()),
    }
}

/// The workspace root: xtask's manifest directory's parent.
fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}
