//! Properties of hemisphere cells.

use proptest::prelude::*;
use rad_hemisphere::{delta_form_factors, DeltaRule};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn delta_form_factors_sum_to_one(n_theta in 1u32..=1000, n_phi in 1u32..=1000) {
        let ring = delta_form_factors(n_theta, n_phi, DeltaRule::Exact);
        let total: f64 = ring.iter().map(|f| f * n_phi as f64).sum();
        prop_assert!((total - 1.0).abs() < 1e-12, "{n_theta}x{n_phi}: {total}");
        prop_assert!(ring.iter().all(|&f| f > 0.0));
    }
}
