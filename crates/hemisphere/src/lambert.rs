//! Lambert's closed form for the unoccluded point-to-polygon form factor.

use glam::DVec3;
use std::f64::consts::PI;

/// Form factor from a differential area at `p` with unit normal `n` to the polygon
/// `corners` (any orientation), assuming nothing occludes it and the polygon lies in
/// front of `p`'s plane: `F = (1/2π) Σ_k β_k (n · γ_k)`, β_k the angle edge k subtends
/// at `p` and γ_k the unit normal of the plane through `p` and edge k.
pub fn point_to_polygon_form_factor(p: DVec3, n: DVec3, corners: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for k in 0..corners.len() {
        let a = corners[k] - p;
        let b = corners[(k + 1) % corners.len()] - p;
        let c = a.cross(b);
        let len = c.length();
        if len == 0.0 {
            continue;
        }
        let beta = len.atan2(a.dot(b));
        sum += beta * n.dot(c / len);
    }
    (sum / (2.0 * PI)).abs()
}
