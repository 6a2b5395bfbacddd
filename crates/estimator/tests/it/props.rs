//! Properties of the reprojection and of estimated hemispheres.

use proptest::prelude::*;
use rad_estimator::{reproject_exact, reproject_first_order, Motion};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// For far points the first-order formulas agree with the exact reprojection
    /// within their second-order error: |Δθ|, |Δφ| ≤ 2 (|d| / (R sinθ))².
    #[test]
    fn first_order_agrees_with_exact_for_far_points(
        theta in 0.2f64..1.5,
        phi in 0.0f64..std::f64::consts::TAU,
        r in 1.0f64..20.0,
        du in -1.0f64..1.0,
        dv in -1.0f64..1.0,
        scale in 0.0f64..0.02,
    ) {
        let m = Motion::new([du * scale * r, dv * scale * r, 0.0]);
        let e = reproject_exact(theta, phi, r, &m);
        let f = reproject_first_order(theta, phi, r, &m);
        let x = m.len / (r * theta.sin());
        let bound = 2.0 * x * x + 1e-12;
        let dphi = (e.phi - f.phi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        prop_assert!((e.theta - f.theta).abs() <= bound, "dtheta {} > {bound}", e.theta - f.theta);
        prop_assert!(dphi.abs() <= bound, "dphi {dphi} > {bound}");
        prop_assert!((e.r - f.r).abs() <= 2.0 * r * x * x + 1e-9);
    }
}
