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
    // Rebuilt when HEAD moves (a commit, a checkout): HEAD, the branch's ref (loose,
    // in the common directory of a worktree, or packed). Only files that exist are
    // named: cargo takes a missing one as changed, and would rerun on every build.
    let mut watch = Vec::new();
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        watch.push(format!("{dir}/HEAD"));
    }
    if let Some(common) = git(&["rev-parse", "--git-common-dir"]) {
        watch.push(format!("{common}/packed-refs"));
        if let Some(head) = git(&["symbolic-ref", "-q", "HEAD"]) {
            watch.push(format!("{common}/{head}"));
        }
    }
    for path in watch {
        if std::path::Path::new(&path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
