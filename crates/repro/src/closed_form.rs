//! Closed-form view factors: unit squares (the cube's face-to-face check), coaxial
//! discs, and parallel plates with an obstruction between them (exact by superposition
//! of point-to-rectangle factors, integrated by Gauss-Legendre).

use rad_geometry::Scene;
use std::f64::consts::PI;

/// Parallel, directly opposed rectangles `x × y` at distance 1 (lengths in units of the
/// distance): Hottel's formula. For the unit cube, `x = y = 1`: 0.199825.
pub fn parallel_rectangles(x: f64, y: f64) -> f64 {
    let (x2, y2) = (x * x, y * y);
    let a = ((1.0 + x2) * (1.0 + y2) / (1.0 + x2 + y2)).sqrt().ln();
    let b = x * (1.0 + y2).sqrt() * (x / (1.0 + y2).sqrt()).atan();
    let c = y * (1.0 + x2).sqrt() * (y / (1.0 + x2).sqrt()).atan();
    2.0 / (PI * x * y) * (a + b + c - x * x.atan() - y * y.atan())
}

/// Perpendicular rectangles sharing an edge of length 1: the emitter is `1 × w`, the
/// receiver `1 × h` (lengths in units of the common edge). For the unit cube: 0.200044.
pub fn perpendicular_rectangles(w: f64, h: f64) -> f64 {
    let (w2, h2) = (w * w, h * h);
    let s = (w2 + h2).sqrt();
    let log = ((1.0 + w2) * (1.0 + h2) / (1.0 + w2 + h2)).ln()
        + w2 * (w2 * (1.0 + w2 + h2) / ((1.0 + w2) * (w2 + h2))).ln()
        + h2 * (h2 * (1.0 + h2 + w2) / ((1.0 + h2) * (h2 + w2))).ln();
    (w * (1.0 / w).atan() + h * (1.0 / h).atan() - s * (1.0 / s).atan() + 0.25 * log) / (PI * w)
}

/// Coaxial parallel discs of radii `r1` (the emitter) and `r2` at distance `h` (Howell
/// C-41). Equal radii r = h: (3 − √5) / 2 = 0.38196601.
pub fn coaxial_discs(r1: f64, r2: f64, h: f64) -> f64 {
    let (a, b) = (r1 / h, r2 / h);
    let x = 1.0 + (1.0 + b * b) / (a * a);
    0.5 * (x - (x * x - 4.0 * (b / a).powi(2)).sqrt())
}

/// From a point to a parallel rectangle at height `h` whose corner lies right above it,
/// the rectangle `a × b` (Howell B-3).
fn point_to_corner_rectangle(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// From the point (px, py, 0), facing +z, to the rectangle [x0, x1] × [y0, y1] at
/// height `h` facing it: superposition of four corner rectangles (signed).
pub fn point_to_parallel_rectangle(p: (f64, f64), x: (f64, f64), y: (f64, f64), h: f64) -> f64 {
    let signed =
        |u: f64, v: f64| u.signum() * v.signum() * point_to_corner_rectangle(u.abs(), v.abs(), h);
    let (u0, u1, v0, v1) = (x.0 - p.0, x.1 - p.0, y.0 - p.1, y.1 - p.1);
    signed(u1, v1) - signed(u0, v1) - signed(u1, v0) + signed(u0, v0)
}

/// Gauss-Legendre nodes and weights on [0, 1], `n` points (Newton on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let w = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * (x + 1.0), 0.5 * w)
        })
        .collect()
}

/// Unit squares [0, 1]² at z = 0 (facing up) and z = 1 (facing down), with an opaque
/// unit square at z = 1/2 shifted by `shift` ∈ [0, 1] along x (covering [shift, 1 +
/// shift] × [0, 1]) between them: from a point (px, py) below, the obstruction's
/// shadow on the upper plane covers x ≥ 2·shift − px and every y of the square, so
/// what the point sees of the upper square is the rectangle [0, 2·shift − px] × [0, 1]
/// (clipped to the square). F = ∫ F_point over the lower square, by Gauss-Legendre in
/// x on each side of the shadow's kink and in y. shift = 1/2: 0.09991245, half the
/// unobstructed plates' (the map x → 1 − x on both plates swaps the pairs of points it
/// blocks and those it does not); 1: no obstruction in the way, 0.19982490.
pub fn obstructed_parallel_squares(shift: f64) -> f64 {
    let nodes = gauss_legendre(40);
    let f_point = |px: f64, py: f64| {
        let x1 = (2.0 * shift - px).clamp(0.0, 1.0);
        if x1 <= 0.0 {
            0.0
        } else {
            point_to_parallel_rectangle((px, py), (0.0, x1), (0.0, 1.0), 1.0)
        }
    };
    // The visible width 2·shift − px clamps to 1 below px = 2·shift − 1 and to 0 above
    // 2·shift: split there so that each piece is smooth.
    let mut cuts = vec![0.0, 1.0];
    for c in [2.0 * shift - 1.0, 2.0 * shift] {
        if c > 0.0 && c < 1.0 {
            cuts.push(c);
        }
    }
    cuts.sort_by(f64::total_cmp);
    let mut total = 0.0;
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        for &(sx, wx) in &nodes {
            let px = a + (b - a) * sx;
            for &(sy, wy) in &nodes {
                total += (b - a) * wx * wy * f_point(px, sy);
            }
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_cube_values() {
        assert!((parallel_rectangles(1.0, 1.0) - 0.199825).abs() < 5e-7);
        assert!((perpendicular_rectangles(1.0, 1.0) - 0.200044).abs() < 5e-7);
        // The six faces of a cube: one opposite, four adjacent, none to itself.
        let total = parallel_rectangles(1.0, 1.0) + 4.0 * perpendicular_rectangles(1.0, 1.0);
        assert!((total - 1.0).abs() < 1e-6, "{total}");
    }

    #[test]
    fn discs_and_superposition() {
        assert!((coaxial_discs(1.0, 1.0, 1.0) - 0.381_966_01).abs() < 1e-8);
        // Point to a rectangle centred above it, by superposition, against the
        // integral of the parallel squares: the unobstructed plates.
        assert!((obstructed_parallel_squares(1.0) - parallel_rectangles(1.0, 1.0)).abs() < 1e-9);
        assert!((obstructed_parallel_squares(1.0) - 0.199_824_90).abs() < 1e-8);
        // Fully in the way: nothing seen.
        assert_eq!(obstructed_parallel_squares(0.0), 0.0);
        let half = obstructed_parallel_squares(0.5);
        assert!(
            (half - 0.5 * parallel_rectangles(1.0, 1.0)).abs() < 1e-9,
            "{half}"
        );
        // Reciprocity of the disc formula: A1 F12 = A2 F21.
        let (f12, f21) = (coaxial_discs(1.0, 2.0, 1.5), coaxial_discs(2.0, 1.0, 1.5));
        assert!((f12 - 4.0 * f21).abs() < 1e-12);
    }
}

/// The factor from face `i` to face `j` of a unit cube's scene (its polygons the six
/// faces): 0 to itself, C-11 to the opposite face, C-14 to the four beside it.
pub fn unit_cube_face_factor(scene: &Scene, i: usize, j: usize) -> f64 {
    let normal = |k: usize| scene.polygons()[k].normal();
    match normal(i).dot(normal(j)) {
        d if d > 0.5 => 0.0,
        d if d < -0.5 => parallel_rectangles(1.0, 1.0),
        _ => perpendicular_rectangles(1.0, 1.0),
    }
}
