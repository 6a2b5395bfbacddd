//! Whether a polygon can come between two others: every segment from a point of one to
//! a point of the other lies in the convex hull of their vertices (the shaft), so a
//! polygon that a plane separates from that hull blocks none of them. The planes tried
//! are the hull's own faces and the polygon's plane; a polygon that no such plane
//! separates may block (the test is conservative: it never says "clear" wrongly).

use glam::DVec3;

/// The convex hull of two polygons' vertices, as the planes of its faces (outward unit
/// normal, offset), for [`Shaft::may_block`].
#[derive(Clone, Debug)]
pub struct Shaft {
    points: Vec<DVec3>,
    planes: Vec<(DVec3, f64)>,
    lo: DVec3,
    hi: DVec3,
    /// How far inside a plane a point may lie and still count as on it.
    slack: f64,
}

impl Shaft {
    /// The shaft between `p1` and `p2`; points within `slack` (relative to the two
    /// polygons' extent) of a face count as on it, so that a polygon touching the shaft
    /// only at its boundary (a neighbour across a shared edge) is no obstruction.
    pub fn between(p1: &[DVec3], p2: &[DVec3], slack: f64) -> Shaft {
        let points: Vec<DVec3> = p1.iter().chain(p2).copied().collect();
        let (lo, hi) = points.iter().fold((points[0], points[0]), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
        let slack = slack * (hi - lo).max_element();
        let mut planes: Vec<(DVec3, f64)> = Vec::new();
        let n = points.len();
        for i in 0..n {
            for j in i + 1..n {
                for k in j + 1..n {
                    let normal = (points[j] - points[i]).cross(points[k] - points[i]);
                    let len = normal.length();
                    if len <= 1e-12 * (hi - lo).max_element().powi(2) {
                        continue;
                    }
                    let normal = normal / len;
                    let d = normal.dot(points[i]);
                    let (mut above, mut below) = (false, false);
                    for p in &points {
                        let s = normal.dot(*p) - d;
                        above |= s > slack;
                        below |= s < -slack;
                    }
                    // A face: every point on one side (its outward normal away from them).
                    let face = match (above, below) {
                        (false, true) => Some((normal, d)),
                        (true, false) => Some((-normal, -d)),
                        _ => None,
                    };
                    if let Some(f) = face {
                        if !planes
                            .iter()
                            .any(|g| g.0.dot(f.0) > 1.0 - 1e-12 && (g.1 - f.1).abs() <= slack)
                        {
                            planes.push(f);
                        }
                    }
                }
            }
        }
        Shaft {
            points,
            planes,
            lo,
            hi,
            slack,
        }
    }

    /// Whether `q` (a planar polygon) may meet a segment from one polygon to the other
    /// (beyond the slack): false where a face of the shaft, or `q`'s own plane, has `q`
    /// and the shaft on its two sides.
    pub fn may_block(&self, q: &[DVec3]) -> bool {
        let (qlo, qhi) = q
            .iter()
            .fold((q[0], q[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let s = DVec3::splat(self.slack);
        if (qlo - s).cmpgt(self.hi).any() || (qhi + s).cmplt(self.lo).any() {
            return false;
        }
        for &(normal, d) in &self.planes {
            if q.iter().all(|p| normal.dot(*p) - d >= -self.slack) {
                return false;
            }
        }
        // q's own plane (Newell's normal), with the shaft on one side of it.
        let mut normal = DVec3::ZERO;
        for k in 0..q.len() {
            normal += q[k].cross(q[(k + 1) % q.len()]);
        }
        let len = normal.length();
        if len > 0.0 {
            let normal = normal / len;
            let d = normal.dot(q[0]);
            let sides: Vec<f64> = self.points.iter().map(|p| normal.dot(*p) - d).collect();
            if sides.iter().all(|&x| x >= -self.slack) || sides.iter().all(|&x| x <= self.slack) {
                return false;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(z: f64, flip: bool) -> Vec<DVec3> {
        let mut v = vec![
            DVec3::new(0.0, 0.0, z),
            DVec3::new(1.0, 0.0, z),
            DVec3::new(1.0, 1.0, z),
            DVec3::new(0.0, 1.0, z),
        ];
        if flip {
            v.reverse();
        }
        v
    }

    #[test]
    fn a_plate_between_blocks_and_the_walls_around_do_not() {
        let shaft = Shaft::between(&square(0.0, false), &square(1.0, true), 1e-9);
        // A small plate half way, in the middle.
        let plate: Vec<DVec3> = square(0.5, false)
            .iter()
            .map(|p| DVec3::new(0.25 + 0.5 * p.x, 0.25 + 0.5 * p.y, p.z))
            .collect();
        assert!(shaft.may_block(&plate));
        // The box's walls touch the shaft along its sides only.
        let wall = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        assert!(!shaft.may_block(&wall));
        // Beside the shaft, and below the floor.
        let beside: Vec<DVec3> = plate
            .iter()
            .map(|p| *p + DVec3::new(2.0, 0.0, 0.0))
            .collect();
        assert!(!shaft.may_block(&beside));
        assert!(!shaft.may_block(&square(-0.5, false)));
        // Coplanar with the floor, beside it.
        let next: Vec<DVec3> = square(0.0, false).iter().map(|p| *p + DVec3::X).collect();
        assert!(!shaft.may_block(&next));
    }
}
