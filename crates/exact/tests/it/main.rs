//! Exact view factors against closed forms, closure in convex enclosures (where nothing
//! can come between two faces), reciprocity and scale.

use glam::DVec3;
use proptest::prelude::*;
use rad_exact::{clip_to_front, view_factor};
use std::f64::consts::PI;

const TOL: f64 = 1e-10;

fn quad(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> Vec<DVec3> {
    [a, b, c, d].map(DVec3::from_array).to_vec()
}

/// The six inward faces of the box [0, x] × [0, y] × [0, z], each counter-clockwise
/// seen from inside.
fn box_faces(x: f64, y: f64, z: f64) -> Vec<Vec<DVec3>> {
    vec![
        quad([0., 0., 0.], [0., y, 0.], [x, y, 0.], [x, 0., 0.]), // z = 0, facing +z
        quad([0., 0., z], [x, 0., z], [x, y, z], [0., y, z]),     // z = z, facing -z
        quad([0., 0., 0.], [x, 0., 0.], [x, 0., z], [0., 0., z]), // y = 0, facing +y
        quad([0., y, 0.], [0., y, z], [x, y, z], [x, y, 0.]),     // y = y, facing -y
        quad([0., 0., 0.], [0., 0., z], [0., y, z], [0., y, 0.]), // x = 0, facing +x
        quad([x, 0., 0.], [x, y, 0.], [x, y, z], [x, 0., z]),     // x = x, facing -x
    ]
}

fn area(p: &[DVec3]) -> f64 {
    let mut n = DVec3::ZERO;
    for k in 0..p.len() {
        n += p[k].cross(p[(k + 1) % p.len()]);
    }
    0.5 * n.length()
}

/// Howell C-11: parallel, directly opposed rectangles a × b, c apart.
fn parallel(a: f64, b: f64, c: f64) -> f64 {
    let (x, y) = (a / c, b / c);
    let (x1, y1) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    2.0 / (PI * x * y)
        * (((x1 * x1 * y1 * y1) / (1.0 + x * x + y * y)).sqrt().ln()
            + x * y1 * (x / y1).atan()
            + y * x1 * (y / x1).atan()
            - x * x.atan()
            - y * y.atan())
}

/// Howell C-14: rectangles at right angles sharing an edge of length l, widths w (the
/// emitter) and h.
fn perpendicular(w: f64, h: f64, l: f64) -> f64 {
    let (hh, ww) = (h / l, w / l);
    let a = (1.0 + ww * ww) * (1.0 + hh * hh) / (1.0 + ww * ww + hh * hh);
    let b = ww * ww * (1.0 + ww * ww + hh * hh) / ((1.0 + ww * ww) * (ww * ww + hh * hh));
    let c = hh * hh * (1.0 + hh * hh + ww * ww) / ((1.0 + hh * hh) * (hh * hh + ww * ww));
    1.0 / (PI * ww)
        * (ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan()
            - (hh * hh + ww * ww).sqrt() * (1.0 / (hh * hh + ww * ww).sqrt()).atan()
            + 0.25 * (a * b.powf(ww * ww) * c.powf(hh * hh)).ln())
}

#[test]
fn parallel_unit_squares_one_apart() {
    let f = box_faces(1.0, 1.0, 1.0);
    let v = view_factor(&f[0], &f[1], TOL);
    let want = parallel(1.0, 1.0, 1.0);
    assert!((v.value - want).abs() < 1e-12, "{} {want}", v.value);
    assert!((want - 0.19982489569838746).abs() < 1e-15);
    assert!(v.error < 1e-9, "{v:?}");
}

#[test]
fn perpendicular_squares_sharing_an_edge() {
    let f = box_faces(1.0, 1.0, 1.0);
    let want = perpendicular(1.0, 1.0, 1.0);
    assert!((want - 0.20004377607540316).abs() < 1e-14, "{want}");
    for other in 2..6 {
        let v = view_factor(&f[0], &f[other], TOL);
        assert!(
            (v.value - want).abs() < 1e-10,
            "face {other}: {} {want}",
            v.value
        );
    }
}

#[test]
fn rectangles_of_other_shapes_match_howell() {
    let f = box_faces(2.0, 0.5, 3.0);
    // z = 0 to z = 3: 2 × 0.5 rectangles 3 apart.
    let v = view_factor(&f[0], &f[1], TOL).value;
    assert!((v - parallel(2.0, 0.5, 3.0)).abs() < 1e-11, "{v}");
    // z = 0 (2 wide in x, 0.5 in y) to y = 0 (2 by 3): they share the edge along x.
    let v = view_factor(&f[0], &f[2], TOL).value;
    assert!((v - perpendicular(0.5, 3.0, 2.0)).abs() < 1e-10, "{v}");
}

#[test]
fn the_factor_does_not_depend_on_the_units() {
    for scale in [1e-6, 1e-3, 1.0, 1e3, 1e6] {
        let f = box_faces(scale, 2.0 * scale, 0.7 * scale);
        let opposite = view_factor(&f[0], &f[1], TOL).value;
        let adjacent = view_factor(&f[0], &f[4], TOL).value;
        let f1 = box_faces(1.0, 2.0, 0.7);
        assert!((opposite - view_factor(&f1[0], &f1[1], TOL).value).abs() < 1e-12);
        assert!((adjacent - view_factor(&f1[0], &f1[4], TOL).value).abs() < 1e-12);
    }
}

#[test]
fn a_polygon_behind_the_plane_is_clipped_away() {
    let f = box_faces(1.0, 1.0, 1.0);
    // Half of the ceiling's square moved below the floor's plane: its front part alone.
    let tilted = quad([0., 0., -1.], [1., 0., 1.], [1., 1., 1.], [0., 1., -1.]);
    let kept = clip_to_front(&tilted, DVec3::Z, 0.0);
    assert!(kept.iter().all(|p| p.z >= -1e-15));
    assert!((area(&kept) - 0.5 * area(&tilted)).abs() < 1e-12);
    assert!(view_factor(&f[0], &kept, TOL).value > 0.0);
}

/// A convex prism: a convex polygon (counter-clockwise) as its base, height h; its
/// faces inward.
fn prism(base: &[[f64; 2]], h: f64) -> Vec<Vec<DVec3>> {
    let low: Vec<DVec3> = base.iter().map(|p| DVec3::new(p[0], p[1], 0.0)).collect();
    let high: Vec<DVec3> = base.iter().map(|p| DVec3::new(p[0], p[1], h)).collect();
    let n = base.len();
    // Inward: the floor faces +z (clockwise seen from below is counter-clockwise from
    // above... seen from inside, i.e. from above): the base as given faces +z.
    let mut faces = vec![low.clone(), high.iter().rev().copied().collect()];
    for k in 0..n {
        let (a, b) = (k, (k + 1) % n);
        faces.push(vec![low[a], high[a], high[b], low[b]]);
    }
    faces
}

/// A convex polygon: `n` points on an ellipse, at increasing angles.
fn ellipse_polygon(n: usize, rx: f64, ry: f64, turn: f64) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let t = turn + 2.0 * PI * k as f64 / n as f64;
            [rx * t.cos(), ry * t.sin()]
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Inside a convex enclosure nothing comes between two faces: every face's factors
    /// sum to 1, and A_i F_ij = A_j F_ji.
    #[test]
    fn convex_enclosures_close_and_are_reciprocal(
        n in 3usize..9, rx in 0.2f64..3.0, ry in 0.2f64..3.0, h in 0.05f64..4.0, turn in 0.0f64..1.0
    ) {
        let faces = prism(&ellipse_polygon(n, rx, ry, turn), h);
        let a: Vec<f64> = faces.iter().map(|f| area(f)).collect();
        for i in 0..faces.len() {
            let mut sum = 0.0;
            for j in 0..faces.len() {
                if i == j { continue; }
                let fij = view_factor(&faces[i], &faces[j], TOL).value;
                let fji = view_factor(&faces[j], &faces[i], TOL).value;
                prop_assert!(fij >= -1e-13, "F_{i}{j} = {fij}");
                prop_assert!((a[i] * fij - a[j] * fji).abs() <= 1e-10 * a[i].max(a[j]),
                    "A F {i}{j}: {} against {}", a[i] * fij, a[j] * fji);
                sum += fij;
            }
            prop_assert!((sum - 1.0).abs() < 1e-9, "face {i}: {sum}");
        }
    }
}
