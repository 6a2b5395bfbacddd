//! The part of a convex polygon on the front side of a plane (Sutherland and Hodgman's
//! clip against one plane).

use glam::DVec3;

/// The part of `polygon` (convex, planar) where `normal · x >= offset`, its vertices in
/// the same order; empty where none is (or only an edge or a point: no area).
pub fn clip_to_front(polygon: &[DVec3], normal: DVec3, offset: f64) -> Vec<DVec3> {
    let side = |p: DVec3| normal.dot(p) - offset;
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (k, &p) in polygon.iter().enumerate() {
        let q = polygon[(k + 1) % polygon.len()];
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        // (A vertex on the plane is kept, and no crossing is made at it.)
        if (sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0) {
            let t = sp / (sp - sq);
            out.push(p + (q - p) * t);
        }
    }
    let perimeter: f64 = (0..out.len())
        .map(|k| (out[(k + 1) % out.len()] - out[k]).length())
        .sum();
    if out.len() < 3 || newell_area(&out) <= 1e-12 * perimeter * perimeter {
        out.clear();
    }
    out
}

/// The area of a planar polygon (half the length of Newell's normal).
pub(crate) fn newell_area(polygon: &[DVec3]) -> f64 {
    let mut n = DVec3::ZERO;
    for (k, &p) in polygon.iter().enumerate() {
        n += p.cross(polygon[(k + 1) % polygon.len()]);
    }
    0.5 * n.length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_is_cut_by_a_plane_through_it() {
        let square = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let half = clip_to_front(&square, DVec3::X, 0.5);
        assert_eq!(half.len(), 4);
        assert!(half.iter().all(|p| p.x >= 0.5));
        assert_eq!(clip_to_front(&square, DVec3::X, -1.0).len(), 4);
        assert!(clip_to_front(&square, DVec3::X, 2.0).is_empty());
        // Touching along an edge only: no area.
        assert!(clip_to_front(&square, -DVec3::X, 0.0).is_empty());
    }
}
