//! `A_1 F_12` between two planar polygons that see each other whole, by the double
//! contour integral (Stokes' theorem turns the double area integral of
//! `cos θ_1 cos θ_2 / π r²` into one over the two outlines):
//!
//! `A_1 F_12 = 1/(2π) Σ_i Σ_j (e_i · e_j) ∫_{e_i} ∫_{e_j} ln r dt ds`,
//!
//! each polygon's outline counter-clockwise seen from its front, `e_i`, `e_j` unit edge
//! directions. The inner integral along a segment is in closed form; the outer one is
//! adaptive Gauss-Kronrod (7-15 points), whose interval estimates add up to the error
//! estimate. Edges on one line (two polygons that share an edge) are integrated in
//! closed form, where the logarithm's singularity lies along the whole edge. The
//! polygons are first moved and scaled to a unit box about the first (the logarithm's
//! constant integrates to zero over a closed outline, so the factor does not depend on
//! the units), which keeps the sums well conditioned at any scale.

use glam::DVec3;
use std::f64::consts::PI;

/// `A_1 F_12` and its error estimate (absolute, in the same units: area).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaFactor {
    pub value: f64,
    pub error: f64,
}

/// Gauss-Kronrod 7-15 on [-1, 1]: the Kronrod nodes (the Gauss ones are the odd
/// indices), their weights, and the Gauss weights.
const XK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// Deepest bisection of an outer interval, and the most pieces an edge pair's outer
/// integral is cut into (past them, the error estimate says what is left).
const MAX_DEPTH: u32 = 30;
const MAX_PIECES: usize = 4096;

/// A piece's error estimate within this share of the integral of `|f|` over it is
/// rounding, not a want of points.
const ROUNDING: f64 = 1e-14;

/// `A_1 F_12` of polygon `p1` to polygon `p2` (vertices counter-clockwise seen from each
/// one's front), both planar and convex, each wholly in front of the other's plane
/// (clip them first: [`crate::clip_to_front`]) and nothing between them; each edge
/// pair's outer integral to about `tolerance` relative to the first polygon's area.
pub fn area_factor(p1: &[DVec3], p2: &[DVec3], tolerance: f64) -> AreaFactor {
    if p1.len() < 3 || p2.len() < 3 {
        return AreaFactor {
            value: 0.0,
            error: 0.0,
        };
    }
    // Into a unit box about p1: the factor is the same, the area scales back.
    let (lo, hi) = p1
        .iter()
        .chain(p2)
        .fold((p1[0], p1[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let centre = p1.iter().sum::<DVec3>() / p1.len() as f64;
    let scale = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let unit = |p: &DVec3| (*p - centre) / scale;
    let a: Vec<DVec3> = p1.iter().map(unit).collect();
    let b: Vec<DVec3> = p2.iter().map(unit).collect();
    let area = crate::clip::newell_area(&a);
    let budget = tolerance * area / (a.len() * b.len()) as f64;
    let (mut sum, mut error) = (0.0, 0.0);
    for k in 0..a.len() {
        let (s0, s1) = (a[k], a[(k + 1) % a.len()]);
        for m in 0..b.len() {
            let (t0, t1) = (b[m], b[(m + 1) % b.len()]);
            let (v, e) = edge_pair(s0, s1, t0, t1, budget);
            sum += v;
            error += e;
        }
    }
    let k = scale * scale / (2.0 * PI);
    AreaFactor {
        value: sum * k,
        error: error * k,
    }
}

/// `F_12` of [`area_factor`]: `A_1 F_12` over `A_1`, and the error estimate likewise.
pub fn view_factor(p1: &[DVec3], p2: &[DVec3], tolerance: f64) -> AreaFactor {
    let area = crate::clip::newell_area(p1);
    let f = area_factor(p1, p2, tolerance);
    if !(area > 0.0) {
        return AreaFactor {
            value: 0.0,
            error: 0.0,
        };
    }
    AreaFactor {
        value: f.value / area,
        error: f.error / area,
    }
}

/// `(e_i · e_j) ∫∫ ln r` over the segments `s0 → s1` and `t0 → t1`, and its error
/// estimate, the outer integral to within `budget`.
fn edge_pair(s0: DVec3, s1: DVec3, t0: DVec3, t1: DVec3, budget: f64) -> (f64, f64) {
    let (ds, dt) = (s1 - s0, t1 - t0);
    let (l1, l2) = (ds.length(), dt.length());
    if l1 == 0.0 || l2 == 0.0 {
        return (0.0, 0.0);
    }
    let (u, v) = (ds / l1, dt / l2);
    let cos = u.dot(v);
    // Perpendicular edges add nothing.
    if cos.abs() < 1e-15 {
        return (0.0, 0.0);
    }
    // On one line: in closed form.
    let off_line = (t0 - s0) - u * (t0 - s0).dot(u);
    if u.cross(v).length() < 1e-12 && off_line.length() < 1e-12 {
        let w0 = (t0 - s0).dot(u);
        let w1 = (t1 - s0).dot(u);
        return (cos * collinear(l1, w0.min(w1), w0.max(w1)), 0.0);
    }
    let inner = |s: f64| inner_integral(s0 + u * s - t0, v, l2);
    let pieces = std::cell::Cell::new(MAX_PIECES);
    let (value, error) = adaptive(&inner, 0.0, l1, budget / l1.max(1e-300), 0, &pieces);
    (cos * value, cos.abs() * error)
}

/// `∫_0^len ln |p − t v| dt` for a unit `v`, in closed form.
fn inner_integral(p: DVec3, v: DVec3, len: f64) -> f64 {
    let b = p.dot(v);
    // (The distance to the line from its perpendicular part, not from |p|² − b²,
    // which cancels where the point lies near the line.)
    let h2 = (p - v * b).length_squared();
    let h = h2.sqrt();
    // ∫ ½ ln(x² + h²) dx = ½ (x ln(x² + h²) − 2x + 2h atan(x / h)).
    let f = |x: f64| {
        let q = x * x + h2;
        let log = if q > 0.0 { x * q.ln() } else { 0.0 };
        let atan = if h > 0.0 {
            2.0 * h * (x / h).atan()
        } else {
            0.0
        };
        log - 2.0 * x + atan
    };
    0.5 * (f(len - b) - f(-b))
}

/// `∫_0^l1 ∫_w0^w1 ln |s − w| dw ds`, in closed form (`G'' = ln |x|`).
fn collinear(l1: f64, w0: f64, w1: f64) -> f64 {
    let g = |x: f64| {
        if x == 0.0 {
            0.0
        } else {
            0.5 * x * x * x.abs().ln() - 0.75 * x * x
        }
    };
    -(g(l1 - w1) - g(l1 - w0) - g(-w1) + g(-w0))
}

/// `∫_a^b f` by Gauss-Kronrod 7-15, bisected until each piece's estimate is within its
/// share of `rate · (b − a)`, or within rounding of the integral of `|f|` over it; (the
/// integral, the error estimate).
/// `pieces` counts down the pieces an edge pair may still be cut into.
fn adaptive(
    f: &dyn Fn(f64) -> f64,
    a: f64,
    b: f64,
    rate: f64,
    depth: u32,
    pieces: &std::cell::Cell<usize>,
) -> (f64, f64) {
    let (k, g, magnitude) = kronrod(f, a, b);
    let err = (k - g).abs();
    let done = err <= rate * (b - a) || err <= ROUNDING * magnitude;
    if done || depth >= MAX_DEPTH || pieces.get() < 2 {
        return (k, err);
    }
    pieces.set(pieces.get() - 2);
    let mid = 0.5 * (a + b);
    let (k1, e1) = adaptive(f, a, mid, rate, depth + 1, pieces);
    let (k2, e2) = adaptive(f, mid, b, rate, depth + 1, pieces);
    (k1 + k2, e1 + e2)
}

/// The Kronrod and Gauss sums of `f` on [a, b], and the Kronrod sum of `|f|`.
fn kronrod(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64) {
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let fc = f(c);
    let (mut k, mut g, mut m) = (WK[7] * fc, WG[3] * fc, WK[7] * fc.abs());
    for (i, (&x, &w)) in XK[..7].iter().zip(&WK[..7]).enumerate() {
        let (f1, f2) = (f(c - h * x), f(c + h * x));
        k += w * (f1 + f2);
        m += w * (f1.abs() + f2.abs());
        if i % 2 == 1 {
            g += WG[i / 2] * (f1 + f2);
        }
    }
    (k * h, g * h, m * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inner_integral_is_the_quadrature_of_the_log() {
        let (p, v) = (DVec3::new(0.3, -0.2, 0.4), DVec3::new(0.6, 0.8, 0.0));
        let exact = inner_integral(p, v, 1.7);
        let n = 200_000;
        let h = 1.7 / n as f64;
        let mid: f64 = (0..n)
            .map(|k| (p - v * ((k as f64 + 0.5) * h)).length().ln() * h)
            .sum();
        assert!((exact - mid).abs() < 1e-9, "{exact} {mid}");
    }

    #[test]
    fn collinear_edges_match_the_quadrature() {
        // [0, 1] against [0.5, 2]: the log singularity along the overlap.
        let exact = collinear(1.0, 0.5, 2.0);
        let n = 2000;
        let h = 1.0 / n as f64;
        let mut sum = 0.0;
        for k in 0..n {
            let s = (k as f64 + 0.5) * h;
            sum += collinear_inner(s, 0.5, 2.0) * h;
        }
        assert!((exact - sum).abs() < 1e-6, "{exact} {sum}");
    }

    /// `∫_w0^w1 ln |s − w| dw`.
    fn collinear_inner(s: f64, w0: f64, w1: f64) -> f64 {
        let f = |x: f64| if x == 0.0 { 0.0 } else { x * x.abs().ln() - x };
        f(s - w0) - f(s - w1)
    }
}
