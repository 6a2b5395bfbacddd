//! House rules checked as a test: `//!` headers, no glob re-exports, no
//! `should_panic` or `ignore`, and the one-way arrows between crates (STYLE.md).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir)
        .expect("readable directory")
        .flatten()
    {
        let path = entry.path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n != "target") {
                rust_files(&path, out);
            }
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

fn sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    rust_files(&root().join("crates"), &mut files);
    rust_files(&root().join("xtask"), &mut files);
    files.sort();
    files
}

#[test]
fn every_file_opens_with_a_doc_line() {
    for f in sources() {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(
            text.starts_with("//!"),
            "{} does not open with a //! line",
            f.display()
        );
    }
}

#[test]
fn no_glob_reexports_should_panic_or_ignore() {
    // Assembled so that this file does not match itself.
    let glob = ["pub use ", "*;"];
    let banned = [["#[should", "_panic"].concat(), ["#[ign", "ore"].concat()];
    for f in sources() {
        let text = std::fs::read_to_string(&f).unwrap();
        for line in text.lines() {
            let l = line.trim();
            assert!(
                !(l.starts_with(glob[0]) && l.ends_with(glob[1])),
                "{}: glob re-export {l:?}",
                f.display()
            );
            for b in &banned {
                assert!(!l.starts_with(b.as_str()), "{}: {l:?}", f.display());
            }
        }
    }
}

/// The arrows of ../shared/STYLE.md: a crate may depend on these workspace crates
/// (normal dependencies). The binary sees the libraries only through the pipeline;
/// the harness writes scene files through rad-geometry and results through the
/// pipeline's writers (ARCHITECTURE.md).
fn allowed() -> BTreeMap<&'static str, &'static [&'static str]> {
    BTreeMap::from([
        ("rad-core", &[][..]),
        ("rad-geometry", &["rad-core"][..]),
        ("rad-accel", &["rad-core", "rad-geometry"][..]),
        ("rad-hemisphere", &["rad-core", "rad-geometry"][..]),
        ("rad-render", &["rad-core", "rad-geometry"][..]),
        (
            "rad-estimator",
            &["rad-core", "rad-geometry", "rad-hemisphere"][..],
        ),
        ("rad-solver", &["rad-core"][..]),
        ("rad-testkit", &["rad-core", "rad-geometry"][..]),
        (
            "rad-pipeline",
            &[
                "rad-core",
                "rad-geometry",
                "rad-accel",
                "rad-hemisphere",
                "rad-render",
                "rad-estimator",
                "rad-solver",
            ][..],
        ),
        (
            "rad-repro",
            &[
                "rad-core",
                "rad-geometry",
                "rad-accel",
                "rad-hemisphere",
                "rad-render",
                "rad-estimator",
                "rad-solver",
                "rad-pipeline",
            ][..],
        ),
        ("coherad", &["rad-pipeline"][..]),
        ("xtask", &["rad-geometry", "rad-pipeline", "rad-repro"][..]),
    ])
}

/// Workspace dependencies named in one `[section]` of a manifest.
fn section_deps(manifest: &str, section: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut inside = false;
    for line in manifest.lines() {
        let l = line.trim();
        if l.starts_with('[') {
            inside = l == section;
            continue;
        }
        if inside {
            if let Some((name, rest)) = l.split_once('=') {
                if rest.contains("path") {
                    out.push(name.trim().to_string());
                }
            }
        }
    }
    out
}

#[test]
fn crate_dependencies_follow_the_arrows() {
    let allowed = allowed();
    let mut manifests: Vec<PathBuf> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .flatten()
        .map(|e| e.path().join("Cargo.toml"))
        .collect();
    manifests.push(root().join("xtask/Cargo.toml"));
    for m in manifests {
        let text = std::fs::read_to_string(&m).unwrap();
        let name = text
            .lines()
            .find_map(|l| {
                l.trim()
                    .strip_prefix("name = ")
                    .map(|n| n.trim_matches('"').to_string())
            })
            .expect("a package name");
        let ok = allowed
            .get(name.as_str())
            .unwrap_or_else(|| panic!("{name} is not in the crate table"));
        for dep in section_deps(&text, "[dependencies]") {
            assert!(
                ok.contains(&dep.as_str()),
                "{name} depends on {dep}, against the arrows"
            );
        }
        for dep in section_deps(&text, "[dev-dependencies]") {
            assert!(
                name == "rad-repro" || (dep != "rad-repro" && dep != "xtask"),
                "{name} has a dev-dependency on {dep}"
            );
        }
    }
}
