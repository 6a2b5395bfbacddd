//! House rules checked as a test: `//!` headers, no glob re-exports, no
//! `should_panic` or `ignore`, the one-way arrows between crates (docs/style.md), no
//! function over 120 lines, and (tidy/cycles.rs) no crate whose modules use each other
//! in a circle.

mod cycles;

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

/// The library crates, the pipeline last: the pipeline may depend on the others, the
/// experiments on all of them.
const LIBRARIES: [&str; 9] = [
    "rad-core",
    "rad-exact",
    "rad-geometry",
    "rad-accel",
    "rad-hemisphere",
    "rad-render",
    "rad-estimator",
    "rad-solver",
    "rad-pipeline",
];

/// The arrows of docs/style.md: a crate may depend on these workspace crates
/// (normal dependencies). The binary sees the libraries only through the pipeline;
/// the harness writes scene files through rad-geometry and results through the
/// pipeline's writers (ARCHITECTURE.md).
fn allowed() -> BTreeMap<&'static str, &'static [&'static str]> {
    BTreeMap::from([
        ("rad-core", &[][..]),
        ("rad-exact", &[][..]),
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
        ("rad-pipeline", &LIBRARIES[..8]),
        ("rad-repro", &LIBRARIES[..]),
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

/// The longest a function in `crates/`, `xtask/` or `python/src` may be, in lines
/// (tests included).
const MAX_FUNCTION_LINES: usize = 120;

/// The Rust text of `src` with comments, strings and character literals blanked
/// (lines kept), so that braces can be counted.
fn code_only(src: &str) -> Vec<char> {
    let c: Vec<char> = src.chars().collect();
    let mut out = c.clone();
    let blank = |out: &mut Vec<char>, k: usize| {
        if out[k] != '\n' {
            out[k] = ' ';
        }
    };
    let mut k = 0;
    while k < c.len() {
        match c[k] {
            '/' if c.get(k + 1) == Some(&'/') => {
                while k < c.len() && c[k] != '\n' {
                    blank(&mut out, k);
                    k += 1;
                }
            }
            '/' if c.get(k + 1) == Some(&'*') => {
                while k < c.len() && !(c[k] == '*' && c.get(k + 1) == Some(&'/')) {
                    blank(&mut out, k);
                    k += 1;
                }
                blank(&mut out, k);
                blank(&mut out, (k + 1).min(c.len() - 1));
                k += 2;
            }
            'r' if matches!(c.get(k + 1), Some('"') | Some('#'))
                && (k == 0 || !(c[k - 1].is_alphanumeric() || c[k - 1] == '_')) =>
            {
                let hashes = c[k + 1..].iter().take_while(|&&h| h == '#').count();
                if c.get(k + 1 + hashes) != Some(&'"') {
                    k += 1;
                    continue;
                }
                let close: Vec<char> = std::iter::once('"')
                    .chain(std::iter::repeat_n('#', hashes))
                    .collect();
                k += 2 + hashes;
                while k < c.len() && !c[k..].starts_with(&close) {
                    blank(&mut out, k);
                    k += 1;
                }
                k += close.len();
            }
            '"' => {
                k += 1;
                while k < c.len() && c[k] != '"' {
                    if c[k] == '\\' {
                        blank(&mut out, k);
                        k += 1;
                    }
                    blank(&mut out, k.min(c.len() - 1));
                    k += 1;
                }
                k += 1;
            }
            // A character literal ('x', '\n', '\u{..}'), not a lifetime ('a).
            '\'' if c.get(k + 1) == Some(&'\\') || c.get(k + 2) == Some(&'\'') => {
                k += 1;
                while k < c.len() && c[k] != '\'' {
                    blank(&mut out, k);
                    k += 1;
                }
                k += 1;
            }
            _ => k += 1,
        }
    }
    out
}

/// (first line, lines, name) of every function with a body in `src`.
fn function_lengths(src: &str) -> Vec<(usize, usize, String)> {
    let code = code_only(src);
    let text: String = code.iter().collect();
    let line_of = |at: usize| text[..at].matches('\n').count() + 1;
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(off) = text[from..].find("fn ") {
        let at = from + off;
        from = at + 3;
        if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_') {
            continue;
        }
        let name: String = text[at + 3..]
            .chars()
            .take_while(|ch| ch.is_alphanumeric() || *ch == '_')
            .collect();
        if name.is_empty() {
            continue;
        }
        // The body: the first `{` before any `;` (a declaration has none).
        let Some(open) = text[at..].find(['{', ';']).map(|o| at + o) else {
            continue;
        };
        if bytes[open] == b';' {
            continue;
        }
        let mut depth = 0;
        let mut close = open;
        for (k, &b) in bytes.iter().enumerate().skip(open) {
            depth += i32::from(b == b'{') - i32::from(b == b'}');
            if depth == 0 {
                close = k;
                break;
            }
        }
        let first = line_of(at);
        out.push((first, line_of(close) - first + 1, name));
    }
    out
}

#[test]
fn function_lengths_are_measured_past_strings_and_comments() {
    let src = "fn a() {\n    let s = \"}{{\";\n    // }\n    let c = '}';\n}\nfn b<'x>(v: &'x str) -> &'x str {\n    v\n}\nfn c();\n";
    assert_eq!(
        function_lengths(src),
        vec![(1, 5, "a".to_string()), (6, 3, "b".to_string())]
    );
}

#[test]
fn no_function_is_over_120_lines() {
    let mut files = Vec::new();
    for dir in ["crates", "xtask", "python/src"] {
        rust_files(&root().join(dir), &mut files);
    }
    let mut long = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for (line, n, name) in function_lengths(&text) {
            if n > MAX_FUNCTION_LINES {
                long.push(format!("{}:{line} {name}: {n} lines", f.display()));
            }
        }
    }
    assert!(
        long.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines (split them):\n{}",
        long.join("\n")
    );
}
