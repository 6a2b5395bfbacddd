//! Where a point seen from C1 lands when seen from C2 = C1 + d (docs/design.md, "Motion and
//! reprojection"), in f64: the reference for the splat's f32 arithmetic (`faithful::splat`) and for
//! the tests.

use std::f64::consts::{PI, TAU};

/// The motion from C1 to C2 in the shared local frame (t, b, n) of their polygon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// d = C2 − C1 in local coordinates (d_w = 0 on a planar polygon).
    pub d: [f64; 3],
    /// |d|.
    pub len: f64,
}

impl Motion {
    pub fn new(d: [f64; 3]) -> Motion {
        Motion {
            d,
            len: (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(),
        }
    }
}

/// A point's direction and distance seen from C2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojected {
    pub theta: f64,
    pub phi: f64,
    pub r: f64,
}

/// Exact reprojection through Cartesian coordinates: `q' = Rω − d`,
/// `R' = |q'|`, `θ' = acos(q'_w / R')`, `φ' = atan2(q'_v, q'_u)` in [0, 2π).
pub fn reproject_exact(theta: f64, phi: f64, r: f64, m: &Motion) -> Reprojected {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    let q = [r * st * cp - m.d[0], r * st * sp - m.d[1], r * ct - m.d[2]];
    let r2 = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
    let theta = (q[2] / r2).clamp(-1.0, 1.0).acos();
    let phi = q[1].atan2(q[0]);
    Reprojected {
        theta,
        phi: if phi < 0.0 { phi + TAU } else { phi },
        r: r2,
    }
}

/// First-order formulas (1): with Δ = −d,
/// `θ' = θ + (Δ·e_θ)/R`, `φ' = φ + (Δ·e_φ)/(R sinθ)`, `R' = R + Δ·e_R`;
/// a θ' below 0 has crossed the pole (θ' → −θ', φ' → φ' + π).
pub fn reproject_first_order(theta: f64, phi: f64, r: f64, m: &Motion) -> Reprojected {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    let dl = [-m.d[0], -m.d[1], -m.d[2]];
    let e_r = [st * cp, st * sp, ct];
    let e_t = [ct * cp, ct * sp, -st];
    let e_p = [-sp, cp, 0.0];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut t2 = theta + dot(dl, e_t) / r;
    let mut p2 = phi + dot(dl, e_p) / (r * st);
    if t2 < 0.0 {
        t2 = -t2;
        p2 += PI;
    }
    Reprojected {
        theta: t2,
        phi: p2.rem_euclid(TAU),
        r: r + dot(dl, e_r),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_reprojection_moves_a_point_by_minus_d() {
        let m = Motion::new([0.1, -0.05, 0.0]);
        let (theta, phi, r) = (0.7, 2.0, 3.0);
        let p = reproject_exact(theta, phi, r, &m);
        let q =
            |t: f64, f: f64, r: f64| [r * t.sin() * f.cos(), r * t.sin() * f.sin(), r * t.cos()];
        let (a, b) = (q(theta, phi, r), q(p.theta, p.phi, p.r));
        for k in 0..3 {
            assert!((a[k] - m.d[k] - b[k]).abs() < 1e-12);
        }
    }

    #[test]
    fn first_order_crosses_the_pole() {
        // A point just off the pole, pushed across it.
        let m = Motion::new([0.2, 0.0, 0.0]);
        let p = reproject_first_order(0.01, 0.0, 5.0, &m);
        assert!(p.theta > 0.0);
        assert!((p.phi - PI).abs() < 0.1, "{p:?}");
    }
}
