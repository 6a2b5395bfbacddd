//! Records the git revision the binary is built from, for `coherad --version`
//! (`COHERAD_GIT_REVISION`: `git rev-parse --short=12 HEAD`; `unknown` outside a git
//! checkout). The commit, not the work tree: uncommitted changes are not marked.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let revision = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(rev) if !rev.is_empty() => rev,
        _ => "unknown".to_string(),
    };
    println!("cargo:rustc-env=COHERAD_GIT_REVISION={revision}");
    // Rebuilt when HEAD moves (a commit, a checkout).
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        for f in ["HEAD"] {
            println!("cargo:rerun-if-changed={dir}/{f}");
        }
        if let Some(head) = git(&["symbolic-ref", "-q", "HEAD"]) {
            println!("cargo:rerun-if-changed={dir}/{head}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
