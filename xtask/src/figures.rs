//! The README's table of current figures: read from the JSON files in results/ (each
//! with the revision, CPU and date of the run that wrote it) and written between the
//! README's two markers, after `cargo xtask reproduce` or `bench` has written results/.

use anyhow::{bail, Context, Result};
use rad_pipeline::output::write_atomic;
use serde_json::Value;
use std::path::Path;

const BEGIN: &str = "<!-- figures:begin";
const END: &str = "<!-- figures:end -->";

/// Rewrites the table in README.md from `out`'s files, if `out` is the workspace's
/// results/ (a quick run or another folder leaves the README alone).
pub fn update_readme(root: &Path, out: &Path) -> Result<()> {
    let results = root.join("results");
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if !same(out, &results) {
        return Ok(());
    }
    let path = root.join("README.md");
    let text = std::fs::read_to_string(&path).context("reading README.md")?;
    let new = with_table(&text, &table(&results))?;
    write_atomic(&path, |w| w.write_all(new.as_bytes())).context("writing README.md")?;
    eprintln!("  wrote the figures table of {}", path.display());
    Ok(())
}

/// `readme` with `table` between the markers (the begin marker's line kept).
fn with_table(readme: &str, table: &str) -> Result<String> {
    let Some(begin) = readme.find(BEGIN) else {
        bail!("README.md has no {BEGIN} ... --> line");
    };
    let after_begin = begin + readme[begin..].find('\n').context("a marker line")? + 1;
    let Some(end) = readme[after_begin..].find(END).map(|k| after_begin + k) else {
        bail!("README.md has no {END} line after {BEGIN}");
    };
    Ok(format!(
        "{}{}{}",
        &readme[..after_begin],
        table,
        &readme[end..]
    ))
}

/// One figure: what, its value, the command that measures it, and the file.
struct Row {
    what: String,
    value: String,
    file: &'static str,
}

fn read(results: &Path, name: &str) -> Option<Value> {
    let text = std::fs::read_to_string(results.join(name)).ok()?;
    serde_json::from_str(&text).ok()
}

/// "revision · CPU · date" of a file's provenance.
fn source(v: &Value) -> String {
    let p = &v["provenance"];
    let s = |k: &str| p[k].as_str().unwrap_or("?").to_string();
    format!(
        "`{}` · {} · {}",
        s("git_revision"),
        s("cpu_model"),
        s("date")
    )
}

/// The Markdown table of every figure whose file is in `results`.
fn table(results: &Path) -> String {
    let mut rows: Vec<(Row, String)> = Vec::new();
    let mut add = |file: &'static str, make: &dyn Fn(&Value) -> Vec<(String, String)>| {
        if let Some(v) = read(results, file) {
            let src = source(&v);
            for (what, value) in make(&v) {
                rows.push((Row { what, value, file }, src.clone()));
            }
        }
    };
    add("cube_accuracy.json", &cube_rows);
    add("loft_checks.json", &loft_check_rows);
    add("loft_speedup.json", &table1_rows);
    add("solves.json", &|v| {
        solve_rows(v, &["cornell.json", "loft.json"])
    });
    add("scaling.json", &scaling_rows);
    add("viewfactors.json", &viewfactor_rows);
    add("ranks.json", &rank_rows);
    add("solves_large.json", &|v| solve_rows(v, &["loft_fine.json"]));
    let mut s = String::from(
        "| figure | value | file (command) | revision · CPU · date |\n|---|---|---|---|\n",
    );
    for (r, src) in rows {
        let command = match r.file {
            "scaling.json" | "viewfactors.json" | "ranks.json" | "solves_large.json" => {
                "cargo xtask bench"
            }
            _ => "cargo xtask reproduce",
        };
        s += &format!(
            "| {} | {} | [{}](results/{}) (`{command}`) | {src} |\n",
            r.what, r.value, r.file, r.file
        );
    }
    s
}

fn cube_rows(v: &Value) -> Vec<(String, String)> {
    let rows = v["accuracy"]["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    rows.iter()
        .find(|r| {
            r["resolution"] == serde_json::json!([180, 720])
                && r["delta"] == "exact"
                && r["patch"].as_str().is_some_and(|p| p.starts_with("floor (3,4)"))
        })
        .and_then(|r| r["rel_error"]["mean"].as_f64())
        .map(|e| {
            vec![(
                "Exact hemisphere against Lambert's formula, empty cube, floor patch, 180×720: mean relative error".into(),
                format!("{:.2} %", 100.0 * e),
            )]
        })
        .unwrap_or_default()
}

fn loft_check_rows(v: &Value) -> Vec<(String, String)> {
    let timing = v["checks"]["timing"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let ms = |name: &str| {
        timing
            .iter()
            .find(|t| t["method"] == name)
            .and_then(|t| t["median_seconds_per_hemisphere"].as_f64())
            .map(|s| 1e3 * s)
    };
    match (ms("polygon scan, 1 thread"), ms("voxel grid, 1 thread")) {
        (Some(scan), Some(grid)) => vec![(
            "One exact hemisphere of the loft (185 polygons), 180×720, one thread: by polygon scan (through the voxel grid)".into(),
            format!("{scan:.2} ms ({grid:.2} ms)"),
        )],
        _ => Vec::new(),
    }
}

fn table1_rows(v: &Value) -> Vec<(String, String)> {
    let l = &v["loft"];
    let all = l["all"].as_array().cloned().unwrap_or_default();
    let run = |m: &str| all.iter().find(|r| r["method"] == m).cloned();
    let mut out = Vec::new();
    if let Some(scan) = run("exact/scan") {
        out.push((
            format!("Table 1, every loft row (14,400 patches, 180×720, {} threads): exact by polygon scan against exact through the voxel grid", l["threads"]),
            format!("{:.1} times faster", scan["speedup_vs_exact"].as_f64().unwrap_or(f64::NAN)),
        ));
    }
    let mode = l["default_mode"].as_str().unwrap_or("improved");
    // (Rows through the scan are those through the grid, to the bit: their L1 is
    // measured once, on the grid's run.)
    let est = run(&format!("estimated/{mode}/scan"));
    let l1 =
        run(&format!("estimated/{mode}/grid")).and_then(|g| g["mean_row_l1_vs_exact"].as_f64());
    if let (Some(est), Some(l1)) = (est, l1) {
        out.push((
            format!("Table 1: estimated ({mode}) rows, centres by polygon scan, against exact by polygon scan: speed-up; mean row L1 from exact"),
            format!(
                "{:.2} times; {l1:.4}",
                est["speedup_vs_scan"].as_f64().unwrap_or(f64::NAN),
            ),
        ));
    }
    let solves = l["solves"].as_array().cloned().unwrap_or_default();
    let diff = solves
        .iter()
        .find(|s| {
            s["method"]
                .as_str()
                .is_some_and(|m| m.starts_with(&format!("estimated/{mode}")))
        })
        .and_then(|s| s["image_difference"]["mean"].as_f64());
    if let Some(d) = diff {
        out.push((
            format!("Figure 9: the loft's image from estimated ({mode}) rows against exact, mean relative difference"),
            format!("{:.2} %", 100.0 * d),
        ));
    }
    out
}

fn solve_rows(v: &Value, scenes: &[&str]) -> Vec<(String, String)> {
    let solves = v["solves"].as_array().cloned().unwrap_or_default();
    solves
        .iter()
        .filter(|s| {
            s["scene"].as_str().is_some_and(|n| scenes.contains(&n))
                && s["command"]
                    .as_str()
                    .is_some_and(|c| !c.contains("--storage"))
        })
        .map(|s| {
            let wall = s["wall_seconds"].as_f64().unwrap_or(f64::NAN);
            (
                format!(
                    "`{}` ({} patches, {} rows, {}): wall time, peak memory, energy imbalance",
                    s["command"].as_str().unwrap_or("?"),
                    s["patches"],
                    s["method"].as_str().unwrap_or("?"),
                    s["storage"].as_str().unwrap_or("?")
                ),
                format!(
                    "{}, {:.0} MiB, {:.0e}",
                    duration(wall),
                    s["peak_rss_mib"].as_f64().unwrap_or(f64::NAN),
                    s["relative_imbalance"].as_f64().unwrap_or(f64::NAN)
                ),
            )
        })
        .collect()
}

fn duration(s: f64) -> String {
    if s < 60.0 {
        format!("{s:.1} s")
    } else {
        format!("{} min {:.0} s", (s / 60.0).floor(), s % 60.0)
    }
}

fn scaling_rows(v: &Value) -> Vec<(String, String)> {
    let scenes = v["scaling"]["scenes"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    scenes
        .iter()
        .filter(|s| s["scene"] == "loft_fine" || s["scene"] == "blob_room")
        .filter_map(|s| {
            let caster = s["default_caster"].as_str()?;
            let ms = s["casters"]
                .as_array()?
                .iter()
                .find(|c| c["caster"] == caster)?["ms_per_hemisphere"]
                .as_f64()?;
            Some((
                format!(
                    "One exact hemisphere of {} ({} polygons), 180×720, one thread, default caster ({caster})",
                    s["scene"].as_str()?,
                    s["polygons"]
                ),
                format!("{ms:.2} ms"),
            ))
        })
        .collect()
}

fn viewfactor_rows(v: &Value) -> Vec<(String, String)> {
    let cases = v["viewfactors"]["cases"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    // (A value without a method is a hemisphere's: files before `auto`.)
    let worst = |method: &str, origins: Option<u64>| {
        cases
            .iter()
            .filter_map(|c| {
                c["values"].as_array()?.iter().find(|x| {
                    x["method"].as_str().unwrap_or("hemisphere") == method
                        && origins.is_none_or(|n| x["origins"] == n)
                })?["error"]
                    .as_f64()
            })
            .fold(f64::NAN, f64::max)
    };
    let mut out = Vec::new();
    let hemisphere = worst("hemisphere", Some(2));
    if !hemisphere.is_nan() {
        out.push((
            format!(
                "View factors against {} closed forms, from 2×2 hemispheres a patch (180×720): largest error",
                cases.len()
            ),
            format!("{hemisphere:.1e}"),
        ));
    }
    let auto = worst("auto", None);
    if !auto.is_nan() {
        out.push((
            "The same by `coherad viewfactors`' default, `--method auto` (in closed form where nothing comes between; the plate between two plates from hemispheres): largest error".to_string(),
            format!("{auto:.1e}"),
        ));
    }
    out
}

fn rank_rows(v: &Value) -> Vec<(String, String)> {
    let runs = v["ranks"]["runs"].as_array().cloned().unwrap_or_default();
    if runs.is_empty() {
        return Vec::new();
    }
    let same = runs.iter().all(|r| r["identical"] == true);
    vec![(
        format!("Rows and solves shared among simulated processes ({} runs): the same bits as one process", runs.len()),
        if same { "yes".into() } else { "NO".into() },
    )]
}

#[test]
fn the_table_goes_between_the_markers() {
    let readme = "# x\n<!-- figures:begin (note) -->\nold\n<!-- figures:end -->\ntail\n";
    let new = with_table(readme, "| a |\n").unwrap();
    assert_eq!(
        new,
        "# x\n<!-- figures:begin (note) -->\n| a |\n<!-- figures:end -->\ntail\n"
    );
    assert!(with_table("# no markers\n", "x").is_err());
}

#[test]
fn the_committed_results_make_a_table() {
    let results = Path::new(env!("CARGO_MANIFEST_DIR")).join("../results");
    let t = table(&results);
    assert!(t.lines().count() > 4, "{t}");
    assert!(!t.contains("NaN"), "{t}");
}
