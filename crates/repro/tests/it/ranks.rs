//! The simulated larger run: every shared run is one process's to the bit, and the
//! loft's shares balance within 10 %.

#[test]
fn simulated_ranks_match_one_process_and_balance_the_loft() {
    let ranks = rad_repro::ranks::run(true, &|_, _, _| {}).unwrap();
    assert!(ranks.runs.len() >= 15, "{} runs", ranks.runs.len());
    for r in &ranks.runs {
        assert!(r.identical, "{} at {}", r.what, r.processes);
        assert_eq!(r.units.len(), r.processes);
        if r.scene == "loft" && r.processes <= 4 {
            assert!(
                r.balance <= 1.1,
                "{} at {}: {}",
                r.what,
                r.processes,
                r.balance
            );
        }
    }
    assert!(ranks.runs.iter().any(|r| r.what.contains("jacobi")));
}
