//! The parsers under the mutation fuzzer (`rad_testkit::fuzz`): a short deterministic
//! run of every target (CI), and every finding kept as a regression input.

use rad_testkit::fuzz::{fuzz, targets};
use std::time::Duration;

#[test]
fn every_parser_survives_a_short_fuzzing_run() {
    for target in targets() {
        let outcome = fuzz(&target, 2026_12_02, 400, Duration::from_secs(120));
        assert!(
            outcome.panics.is_empty(),
            "{}: {} panics, first {:?} on {:?}",
            target.name,
            outcome.panics.len(),
            outcome.panics[0].0,
            String::from_utf8_lossy(&outcome.panics[0].1)
        );
        // The seeds parse, and some mutants do too: the run reaches validation.
        assert!(
            outcome.parsed > target.seeds.len() as u64,
            "{}: {outcome:?}",
            target.name
        );
    }
}

#[test]
fn fuzzing_findings_stay_fixed() {
    // crates/geometry/tests/fuzz/<target>/*: inputs that once panicked a parser.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz");
    let mut seen = 0;
    for target in targets() {
        let Ok(entries) = std::fs::read_dir(dir.join(target.name)) else {
            continue;
        };
        for entry in entries {
            let path = entry.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            let result = std::panic::catch_unwind(|| (target.run)(&bytes));
            assert!(result.is_ok(), "{} panics again", path.display());
            seen += 1;
        }
    }
    assert!(seen >= 6, "the findings are in {}", dir.display());
}
