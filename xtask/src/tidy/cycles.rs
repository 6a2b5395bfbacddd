//! Module cycles within a crate: which files of a crate use which, read from their
//! `use` lines and paths (`crate::`, `super::`, a child module's name), re-exports
//! followed to the module that defines the item; a cycle is a strongly connected
//! component of more than one file.

use super::{code_only, root, rust_files};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A module's path from its crate's root (`[]` for lib.rs or main.rs).
type ModPath = Vec<String>;

/// One module of a crate: its code (comments and strings blanked, test modules cut),
/// its re-exports (name → the path it names) and the paths it uses.
struct Module {
    code: String,
    reexports: BTreeMap<String, ModPath>,
    uses: Vec<ModPath>,
}

/// The module path of a source file under `src`: `a/b.rs` → `[a, b]`, `a/mod.rs` → `[a]`.
fn module_path(src: &Path, file: &Path) -> Option<ModPath> {
    let rel = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop()?.strip_suffix(".rs")?.to_string();
    if parts.first().is_some_and(|p| p == "bin") {
        return None;
    }
    match last.as_str() {
        "lib" | "main" if parts.is_empty() => {}
        "mod" => {}
        _ => parts.push(last),
    }
    Some(parts)
}

/// `text` up to its first `#[cfg(test)]` (test modules come last in a file).
fn without_tests(text: &str) -> &str {
    text.find("#[cfg(test)]").map_or(text, |at| &text[..at])
}

/// The paths a `use` tree names: `a::{b, c::{d as e}, self}` → `a::b`, `a::c::d`
/// (as `e`), `a`; each with the name it binds.
fn expand_use(tree: &str) -> Vec<(ModPath, String)> {
    fn split_top(s: &str) -> Vec<&str> {
        let (mut depth, mut start, mut out) = (0, 0, Vec::new());
        for (k, ch) in s.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    out.push(&s[start..k]);
                    start = k + 1;
                }
                _ => {}
            }
        }
        out.push(&s[start..]);
        out.into_iter()
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .collect()
    }
    fn walk(prefix: &[String], tree: &str, out: &mut Vec<(ModPath, String)>) {
        let tree = tree.trim();
        if let Some(open) = tree.find('{') {
            let head: Vec<String> = tree[..open]
                .split("::")
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(String::from)
                .collect();
            let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
            let mut p = prefix.to_vec();
            p.extend(head);
            for part in split_top(inner) {
                walk(&p, part, out);
            }
            return;
        }
        let (path, alias) = match tree.split_once(" as ") {
            Some((p, a)) => (p.trim(), Some(a.trim().to_string())),
            None => (tree, None),
        };
        let mut p = prefix.to_vec();
        for seg in path.split("::").map(str::trim).filter(|s| !s.is_empty()) {
            if seg != "self" || p.is_empty() {
                p.push(seg.to_string());
            }
        }
        let name = alias.unwrap_or_else(|| p.last().cloned().unwrap_or_default());
        out.push((p, name));
    }
    let mut out = Vec::new();
    walk(&[], tree, &mut out);
    out
}

/// `path` as written in module `at` made absolute from the crate root, if it is the
/// crate's (`crate::`, `super::`, `self::`, or a child module of `at` first).
fn absolute(at: &[String], path: &[String], children: &BTreeSet<String>) -> Option<ModPath> {
    let first = path.first()?;
    let mut base: ModPath = at.to_vec();
    let rest = match first.as_str() {
        "crate" => {
            base.clear();
            &path[1..]
        }
        "self" => &path[1..],
        "super" => {
            let mut k = 0;
            while path.get(k).is_some_and(|s| s == "super") {
                base.pop()?;
                k += 1;
            }
            &path[k..]
        }
        name if children.contains(name) => path,
        _ => return None,
    };
    base.extend(rest.iter().cloned());
    Some(base)
}

/// Identifier paths `a::b::c` in `code` that start at `start` (`crate`, `super`, or a
/// child module's name), not inside a longer path.
fn paths_from(code: &str, start: &str) -> Vec<ModPath> {
    let bytes = code.as_bytes();
    let ident = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
    let mut out = Vec::new();
    let needle = format!("{start}::");
    let mut from = 0;
    while let Some(off) = code[from..].find(&needle) {
        let at = from + off;
        from = at + needle.len();
        if at > 0 && (ident(bytes[at - 1]) || bytes[at - 1] == b':') {
            continue;
        }
        let mut end = at;
        while end < bytes.len() && (ident(bytes[end]) || code[end..].starts_with("::")) {
            end += if bytes[end] == b':' { 2 } else { 1 };
        }
        let path: ModPath = code[at..end]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect();
        out.push(path);
    }
    out
}

/// Every `use …;` statement of `code`: (whether it re-exports, its tree, its span).
fn use_statements(code: &str) -> Vec<(bool, String, std::ops::Range<usize>)> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    let mut from = 0;
    while let Some(off) = code[from..].find("use ") {
        let at = from + off;
        from = at + 4;
        if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_') {
            continue;
        }
        let before = code[..at].trim_end();
        let line_start = before.rfind(['\n', ';', '{', '}']).map_or(0, |k| k + 1);
        let lead = before[line_start..].trim();
        let lead = lead.rsplit(']').next().unwrap_or("").trim();
        if !(lead.is_empty() || lead.starts_with("pub")) {
            continue;
        }
        let Some(end) = code[at..].find(';') else {
            break;
        };
        let tree = code[at + 4..at + end].to_string();
        out.push((lead.starts_with("pub"), tree, at..at + end));
        from = at + end;
    }
    out
}

/// The modules of the crate whose sources are in `src`.
fn read_crate(src: &Path) -> BTreeMap<ModPath, Module> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    // Modules declared with `#[path = "file.rs"] mod name;` (in the crate's root) take
    // their declared name; two files of one name (chosen by cfg) are read as one.
    let mut renamed: BTreeMap<String, String> = BTreeMap::new();
    for root_file in ["lib.rs", "main.rs"] {
        let text = std::fs::read_to_string(src.join(root_file)).unwrap_or_default();
        let mut lines = text.lines().map(str::trim).peekable();
        while let Some(line) = lines.next() {
            let Some(file) = line
                .strip_prefix("#[path = \"")
                .and_then(|l| l.strip_suffix("\"]"))
            else {
                continue;
            };
            while lines.peek().is_some_and(|l| l.starts_with("#[")) {
                lines.next();
            }
            if let Some(name) = lines
                .next()
                .and_then(|l| l.strip_prefix("mod "))
                .and_then(|l| l.strip_suffix(';'))
            {
                renamed.insert(file.trim_end_matches(".rs").to_string(), name.to_string());
            }
        }
    }
    let mut texts: BTreeMap<ModPath, String> = BTreeMap::new();
    for f in files {
        let Some(mut path) = module_path(src, &f) else {
            continue;
        };
        if let [one] = path.as_slice() {
            if let Some(name) = renamed.get(one) {
                path = vec![name.clone()];
            }
        }
        if path.last().is_some_and(|l| l == "tests") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let code: String = code_only(without_tests(&text)).into_iter().collect();
        texts.entry(path).or_default().push_str(&code);
    }
    let paths: Vec<ModPath> = texts.keys().cloned().collect();
    let mut modules = BTreeMap::new();
    for (at, code) in texts {
        let children: BTreeSet<String> = paths
            .iter()
            .filter(|p| p.len() == at.len() + 1 && p.starts_with(&at))
            .map(|p| p.last().unwrap().clone())
            .collect();
        let mut reexports = BTreeMap::new();
        let mut uses = Vec::new();
        let statements = use_statements(&code);
        // Paths in the code itself, `use` lines blanked (they are read as trees).
        let mut body = code.clone().into_bytes();
        for (_, _, span) in &statements {
            body[span.clone()].fill(b' ');
        }
        let body = String::from_utf8(body).expect("blanked ASCII");
        for (public, tree, _) in statements {
            for (path, name) in expand_use(&tree) {
                let Some(abs) = absolute(&at, &path, &children) else {
                    continue;
                };
                if public {
                    reexports.insert(name, abs);
                } else {
                    uses.push(abs);
                }
            }
        }
        let starts = ["crate", "super"]
            .into_iter()
            .map(String::from)
            .chain(children.iter().cloned());
        for start in starts {
            for path in paths_from(&body, &start) {
                if let Some(abs) = absolute(&at, &path, &children) {
                    uses.push(abs);
                }
            }
        }
        modules.insert(
            at,
            Module {
                code,
                reexports,
                uses,
            },
        );
    }
    modules
}

/// The module that defines what `path` names: its longest prefix that is a module,
/// re-exports followed.
fn resolve(modules: &BTreeMap<ModPath, Module>, path: &[String], depth: usize) -> Option<ModPath> {
    let k = (0..=path.len())
        .rev()
        .find(|&k| modules.contains_key(&path[..k]))?;
    let module = path[..k].to_vec();
    let Some(item) = path.get(k) else {
        return Some(module);
    };
    match modules[&module].reexports.get(item) {
        Some(target) if depth < 16 && target.as_slice() != path => {
            let mut next = target.clone();
            next.extend(path[k + 1..].iter().cloned());
            resolve(modules, &next, depth + 1)
        }
        _ => Some(module),
    }
}

/// The arrows between a crate's modules: each module to those it uses.
fn module_graph(src: &Path) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
    let modules = read_crate(src);
    let mut graph = BTreeMap::new();
    for (at, m) in &modules {
        let to: BTreeSet<ModPath> = m
            .uses
            .iter()
            .filter_map(|p| resolve(&modules, p, 0))
            .filter(|t| t != at)
            .collect();
        debug_assert!(!m.code.is_empty() || to.is_empty());
        graph.insert(at.clone(), to);
    }
    graph
}

/// The strongly connected components of more than one node (Tarjan).
fn cycles(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    struct State<'a> {
        graph: &'a BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<&'a ModPath, usize>,
        low: BTreeMap<&'a ModPath, usize>,
        stack: Vec<&'a ModPath>,
        on_stack: BTreeSet<&'a ModPath>,
        out: Vec<Vec<ModPath>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a ModPath) {
        let k = s.index.len();
        s.index.insert(v, k);
        s.low.insert(v, k);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in s.graph.get(v).into_iter().flatten() {
            let Some((w, _)) = s.graph.get_key_value(w) else {
                continue;
            };
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(lw);
            } else if s.on_stack.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).unwrap();
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.clone());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

fn show(p: &ModPath) -> String {
    if p.is_empty() {
        "(root)".into()
    } else {
        p.join("::")
    }
}

#[test]
fn use_trees_and_paths_are_read() {
    let got = expand_use("crate::a::{self, b::{C, D as E}, F}");
    let names: Vec<String> = got
        .iter()
        .map(|(p, n)| format!("{}={n}", p.join("::")))
        .collect();
    assert_eq!(
        names,
        [
            "crate::a=a",
            "crate::a::b::C=C",
            "crate::a::b::D=E",
            "crate::a::F=F"
        ]
    );
    let code = "fn f() { crate::x::y(); a::crate::z(); super::w::V; }";
    assert_eq!(paths_from(code, "crate"), vec![vec!["crate", "x", "y"]]);
    assert_eq!(paths_from(code, "super"), vec![vec!["super", "w", "V"]]);
}

#[test]
fn a_cycle_through_a_reexport_is_found() {
    let dir = std::env::temp_dir().join(format!("tidy-cycles-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("b")).unwrap();
    let write = |f: &str, t: &str| std::fs::write(src.join(f), t).unwrap();
    write("lib.rs", "//! x\nmod a;\nmod b;\npub use b::c::Thing;\n");
    write("a.rs", "//! x\nuse crate::Thing;\npub fn f() {}\n");
    write("b.rs", "//! x\nmod c;\n");
    write(
        "b/c.rs",
        "//! x\npub struct Thing;\nfn g() { crate::a::f() }\n",
    );
    let found = cycles(&module_graph(&src));
    write("b/c.rs", "//! x\npub struct Thing;\n");
    let none = cycles(&module_graph(&src));
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].iter().map(show).collect::<Vec<_>>(), ["a", "b::c"]);
    assert!(none.is_empty(), "{none:?}");
}

#[test]
fn no_module_cycles_within_a_crate() {
    let mut srcs: Vec<_> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .flatten()
        .map(|e| e.path().join("src"))
        .collect();
    srcs.push(root().join("xtask/src"));
    srcs.push(root().join("python/src"));
    srcs.sort();
    let mut found = Vec::new();
    for src in srcs.iter().filter(|s| s.is_dir()) {
        let modules = read_crate(src);
        for c in cycles(&module_graph(src)) {
            let names: Vec<String> = c.iter().map(show).collect();
            found.push(format!("{}: {}", src.display(), names.join(" <-> ")));
            // Each arrow inside the circle, with the path that makes it.
            for a in &c {
                for u in &modules[a].uses {
                    match resolve(&modules, u, 0) {
                        Some(t) if &t != a && c.contains(&t) => found.push(format!(
                            "    {} uses {} ({})",
                            show(a),
                            show(&t),
                            u.join("::")
                        )),
                        _ => {}
                    }
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "modules that use each other in a circle (move what both need into a module \
         of its own, or the call into the caller):\n{}",
        found.join("\n")
    );
}
