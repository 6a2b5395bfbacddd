//! Closed-form form factors between unit squares, for the cube's face-to-face check.

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
}
