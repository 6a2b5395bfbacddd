//! The solves as a user runs them: `coherad solve` on bench scenes as a user runs it (the scene and
//! a resolution, nothing else but where a storage is named), each in a child process,
//! its wall time and peak resident memory (the child's rusage from wait4: what
//! `/usr/bin/time -v` reports as its maximum resident set size), and what its solution
//! file says (method, storage, shots or sweeps, energy balance).

use anyhow::{bail, Context, Result};
use rad_repro::Provenance;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One solve: a bench scene, a resolution, and flags beyond them (none: the defaults).
pub struct Case {
    scene: &'static str,
    resolution: &'static str,
    flags: &'static [&'static str],
}

/// The report's solves, quick (CI): its scenes at a coarse resolution.
pub const REPORT_QUICK: &[Case] = &[
    Case {
        scene: "cornell.json",
        resolution: "24x96",
        flags: &[],
    },
    Case {
        scene: "loft.json",
        resolution: "24x96",
        flags: &[],
    },
];

/// The report's solves: the Cornell box and the loft at the report's resolution.
pub const REPORT_FULL: &[Case] = &[
    Case {
        scene: "cornell.json",
        resolution: "180x720",
        flags: &[],
    },
    Case {
        scene: "loft.json",
        resolution: "180x720",
        flags: &[],
    },
];

/// The bench's solves, quick (under a minute): the other storages on the loft at a
/// coarse resolution, and a mesh whose default method is estimated.
pub const BENCH_QUICK: &[Case] = &[
    Case {
        scene: "loft.json",
        resolution: "24x96",
        flags: &["--storage", "out-of-core"],
    },
    Case {
        scene: "loft.json",
        resolution: "24x96",
        flags: &["--storage", "matrix-free"],
    },
    Case {
        scene: "loft_triangles.json",
        resolution: "8x32",
        flags: &[],
    },
];

/// The bench's large solves: the tessellated lofts at the report's resolution, up to
/// 115,200 one-patch triangles (about 15 minutes of the two-core machine's time).
pub const BENCH_FULL: &[Case] = &[
    Case {
        scene: "loft_triangles.json",
        resolution: "180x720",
        flags: &[],
    },
    Case {
        scene: "loft_fine.json",
        resolution: "180x720",
        flags: &[],
    },
];

/// What one solve did.
#[derive(Serialize)]
pub struct Solved {
    pub command: String,
    pub scene: String,
    pub resolution: String,
    pub patches: u64,
    pub method: String,
    pub storage: String,
    pub solver: String,
    /// Sweeps, or shots for shooting.
    pub iterations: u64,
    pub converged: bool,
    pub relative_imbalance: f64,
    pub wall_seconds: f64,
    /// The child's peak resident set, MiB (rusage `ru_maxrss`).
    pub peak_rss_mib: f64,
    pub form_factors_seconds: f64,
    pub solve_seconds: f64,
    /// Bytes of rows written to the temporary file (out-of-core), else 0.
    pub disk_bytes: u64,
}

/// Runs `cases` with the release `coherad` (built first if needed), their solution
/// files in `work`, saying each on standard error.
pub fn run(cases: &[Case], root: &Path, work: &Path) -> Result<Vec<Solved>> {
    let binary = coherad(root)?;
    std::fs::create_dir_all(work).with_context(|| format!("cannot create {}", work.display()))?;
    let mut out = Vec::with_capacity(cases.len());
    for (k, case) in cases.iter().enumerate() {
        let scene = root.join("bench-scenes").join(case.scene);
        let solution = work.join(format!("solve-{k}.json"));
        let log = work.join(format!("solve-{k}.log"));
        let mut args: Vec<String> = vec![
            "solve".into(),
            scene.display().to_string(),
            "--resolution".into(),
            case.resolution.into(),
        ];
        args.extend(case.flags.iter().map(|f| f.to_string()));
        let shown = format!(
            "coherad solve bench-scenes/{} --resolution {}{}",
            case.scene,
            case.resolution,
            case.flags.iter().fold(String::new(), |s, f| s + " " + f)
        );
        eprintln!("  solve {}/{}: {shown}", k + 1, cases.len());
        args.extend(["--out".into(), solution.display().to_string()]);
        let (wall, peak_kib) = measured(&binary, &args, &log)
            .with_context(|| format!("{shown} (its messages: {})", log.display()))?;
        let text = std::fs::read_to_string(&solution)
            .with_context(|| format!("reading {}", solution.display()))?;
        let file: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("reading {}", solution.display()))?;
        let _ = std::fs::remove_file(&solution);
        let solved = Solved {
            command: shown,
            scene: case.scene.into(),
            resolution: case.resolution.into(),
            patches: file["n_patches"].as_u64().unwrap_or(0),
            method: file["method"].as_str().unwrap_or("?").into(),
            storage: file["matrix"]["storage"].as_str().unwrap_or("?").into(),
            solver: file["solver"]["solver"].as_str().unwrap_or("?").into(),
            iterations: file["solver"]["iterations"].as_u64().unwrap_or(0),
            converged: file["solver"]["converged"].as_bool().unwrap_or(false),
            relative_imbalance: file["solver"]["energy"]["relative_imbalance"]
                .as_f64()
                .unwrap_or(f64::NAN),
            wall_seconds: wall,
            peak_rss_mib: peak_kib as f64 / 1024.0,
            form_factors_seconds: file["timings"]["form_factors_seconds"]
                .as_f64()
                .unwrap_or(0.0),
            solve_seconds: file["timings"]["solve_seconds"].as_f64().unwrap_or(0.0),
            disk_bytes: file["matrix"]["disk_bytes"].as_u64().unwrap_or(0),
        };
        // (NaN, an imbalance the file did not give, is not balanced.)
        let balanced = solved.relative_imbalance <= 1e-6;
        if !solved.converged || !balanced {
            bail!(
                "{}: converged {}, energy imbalance {:e}",
                solved.command,
                solved.converged,
                solved.relative_imbalance
            );
        }
        eprintln!(
            "    {} patches, {}, {}: {:.1} s, {:.0} MiB peak",
            solved.patches, solved.method, solved.storage, wall, solved.peak_rss_mib
        );
        out.push(solved);
    }
    Ok(out)
}

/// The release `coherad` beside this harness (`target/release`), built first (cargo
/// does nothing when it is up to date).
fn coherad(root: &Path) -> Result<PathBuf> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = std::process::Command::new(cargo)
        .args(["build", "--release", "--quiet", "-p", "coherad"])
        .current_dir(root)
        .status()
        .context("cannot run cargo to build coherad")?;
    if !status.success() {
        bail!("cargo build --release -p coherad failed");
    }
    let exe = std::env::current_exe().context("where is this harness?")?;
    let binary = exe
        .parent()
        .context("the harness has no folder")?
        .join("coherad");
    if !binary.is_file() {
        bail!("no coherad binary at {}", binary.display());
    }
    Ok(binary)
}

/// Runs `binary args`, its standard error into `log`: the wall seconds and the peak
/// resident set (KiB) of the child, from wait4's rusage; an error if it fails.
fn measured(binary: &Path, args: &[String], log: &Path) -> Result<(f64, i64)> {
    let err = std::fs::File::create(log).with_context(|| format!("creating {}", log.display()))?;
    let t = Instant::now();
    let child = std::process::Command::new(binary)
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(err)
        .spawn()
        .with_context(|| format!("cannot run {}", binary.display()))?;
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: rusage is plain old data, zeroes a valid value; wait4 writes status and
    // usage for the child `pid`, which is ours and not yet waited for (the `Child` is
    // never waited on after this; interrupted, wait4 is asked again). Linux gives
    // ru_maxrss in KiB.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = loop {
        let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
        if r != -1 || std::io::Error::last_os_error().kind() != std::io::ErrorKind::Interrupted {
            break r;
        }
    };
    let wall = t.elapsed().as_secs_f64();
    drop(child);
    if r != pid {
        bail!("wait4 failed: {}", std::io::Error::last_os_error());
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        let tail = std::fs::read_to_string(log).unwrap_or_default();
        let tail: Vec<&str> = tail.lines().rev().take(5).collect();
        bail!(
            "failed (wait status {status}): {}",
            tail.into_iter().rev().collect::<Vec<_>>().join(" | ")
        );
    }
    let _ = std::fs::remove_file(log);
    Ok((wall, usage.ru_maxrss))
}

/// A solve file (solves.json, solves_large.json): the provenance and every solve.
pub fn json(provenance: &Provenance, solves: &[Solved]) -> String {
    #[derive(Serialize)]
    struct File<'a> {
        provenance: &'a Provenance,
        solves: &'a [Solved],
    }
    let mut s =
        serde_json::to_string_pretty(&File { provenance, solves }).expect("plain data serialises");
    s.push('\n');
    s
}

/// The report's section: one line a solve (their JSON in `file`).
pub fn markdown(solves: &[Solved], file: &str) -> String {
    let mut s = format!(
        "\n## Solves as a user runs them\n\n`coherad solve SCENE --resolution R` (storage named where given), each a child process of the harness: wall time and peak resident memory (wait4's rusage, as `/usr/bin/time -v` reports it), and what the solution file says (results/{file}).\n\n| command | patches | method | storage | solver, iterations | energy imbalance | wall | peak resident |\n|---|---|---|---|---|---|---|---|\n",
    );
    for v in solves {
        s += &format!(
            "| `{}` | {} | {} | {} | {}, {} | {:.1e} | {:.1} s | {:.0} MiB |\n",
            v.command,
            v.patches,
            v.method,
            v.storage,
            v.solver,
            v.iterations,
            v.relative_imbalance,
            v.wall_seconds,
            v.peak_rss_mib
        );
    }
    s
}
