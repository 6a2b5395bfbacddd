//! The scene-file parsers under the mutation fuzzer (`rad_testkit::fuzz`), for a time
//! budget a target: executions, inputs that parsed, panics; each panicking input is
//! saved for a regression test (`crates/geometry/tests/fuzz/<target>/`).
//!
//! `cargo run --release -p rad-geometry --example fuzz -- [TARGET...|all] [--seconds 600]
//! [--seed 1] [--save DIR]` (targets: json obj vs3 ply stl gltf glb materials).

use rad_testkit::fuzz::{fuzz, targets};
use std::time::Duration;

fn main() {
    let mut names = Vec::new();
    let mut seconds = 60u64;
    let mut seed = 1u64;
    let mut save = std::path::PathBuf::from("target/fuzz-findings");
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seconds" => {
                seconds = args
                    .next()
                    .and_then(|s| s.parse().ok())
                    .expect("--seconds N")
            }
            "--seed" => seed = args.next().and_then(|s| s.parse().ok()).expect("--seed N"),
            "--save" => save = args.next().expect("--save DIR").into(),
            _ => names.push(a),
        }
    }
    let all = targets();
    let chosen: Vec<_> = all
        .iter()
        .filter(|t| names.is_empty() || names.iter().any(|n| n == "all" || n == t.name))
        .collect();
    if chosen.is_empty() {
        let known: Vec<_> = all.iter().map(|t| t.name).collect();
        eprintln!("no such target; targets: {}", known.join(" "));
        std::process::exit(2);
    }
    // Panics are caught and counted; their messages are reported below, once each.
    std::panic::set_hook(Box::new(|_| {}));
    let mut failed = false;
    println!("target      executions   exec/s   parsed  corpus  panics  seconds");
    for t in chosen {
        let o = fuzz(t, seed, u64::MAX, Duration::from_secs(seconds));
        let secs = o.elapsed.as_secs_f64();
        println!(
            "{:<10} {:>11} {:>8.0} {:>8} {:>7} {:>7} {:>8.1}",
            t.name,
            o.executions,
            o.executions as f64 / secs,
            o.parsed,
            o.corpus,
            o.panics.len(),
            secs
        );
        for (k, (msg, input)) in o.panics.iter().enumerate() {
            failed = true;
            std::fs::create_dir_all(save.join(t.name)).expect("the findings directory");
            let path = save
                .join(t.name)
                .join(format!("finding-{seed}-{k}.{}", t.ext));
            std::fs::write(&path, input).expect("a finding written");
            println!("  panic: {msg}\n    input saved to {}", path.display());
        }
    }
    std::process::exit(i32::from(failed));
}
