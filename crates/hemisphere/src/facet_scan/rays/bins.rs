//! Facets binned by direction from one origin: a light buffer (Haines and Greenberg,
//! 1986) for [`super::FacetRays`]. The directions from the origin are cut as a cube's
//! faces are, each face into `SIDE × SIDE` cells; a cell lists every facet whose box
//! any direction of the cell meets, nearest box first. A ray from that origin then
//! resolves its cell's facets in that order, until the next box lies farther than its
//! nearest hit: no tree is walked. Many rays from one origin (a camera's) pay for it.

use glam::{DVec3, Vec3};

/// Cells along a cube face's side.
pub(super) const SIDE: usize = 64;

/// The most entries (cell, facet) a set of bins may hold (8 bytes each): beyond it, the
/// rays from that origin go through the tree.
pub(super) const MAX_ENTRIES: usize = 1 << 22;

/// Widening of a box's footprint on a face (in its coordinates, which run −1 to 1):
/// covers the f32 rounding of a ray's cell.
const PAD: f64 = 1e-4;

/// The facets binned from one origin (see the module's text).
#[derive(Clone, Debug)]
pub(super) struct Bins {
    /// The cell `c`'s entries: `entries[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    /// (the box's distance from the origin, rounded down; the facet), nearest first.
    entries: Vec<(f32, u32)>,
}

/// The cell of direction `d`, its cube face (0..6: +x, −x, +y, −y, +z, −z) first
/// (None for a zero, infinite or NaN direction).
#[inline]
pub(super) fn cell_of(d: Vec3) -> Option<usize> {
    let a = d.abs();
    let (axis, major) = if a.x >= a.y && a.x >= a.z {
        (0, d.x)
    } else if a.y >= a.z {
        (1, d.y)
    } else {
        (2, d.z)
    };
    let m = major.abs();
    if !(m > 0.0 && m < f32::INFINITY) {
        return None;
    }
    let face = 2 * axis + usize::from(major < 0.0);
    let (u, v) = (d[(axis + 1) % 3] / m, d[(axis + 2) % 3] / m);
    let at = |w: f32| (((w + 1.0) * (0.5 * SIDE as f32)) as usize).min(SIDE - 1);
    // (u, v lie in [−1, 1]: a negative float's cast gives 0.)
    Some((face * SIDE + at(v)) * SIDE + at(u))
}

impl Bins {
    /// The bins of `boxes` (lower and upper corners) from `o`; None if they would hold
    /// more than [`MAX_ENTRIES`] entries.
    pub(super) fn new(o: Vec3, boxes: &[(Vec3, Vec3)]) -> Option<Bins> {
        let o = o.as_dvec3();
        // Nearest box first.
        let mut order: Vec<(f64, u32)> = boxes
            .iter()
            .enumerate()
            .map(|(f, &(lo, hi))| {
                let gap = (lo.as_dvec3() - o).max(o - hi.as_dvec3()).max(DVec3::ZERO);
                (gap.length(), f as u32)
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let cells = 6 * SIDE * SIDE;
        // Each cell's count, then (summed) its start.
        let mut start = vec![0u32; cells + 1];
        let mut total = 0usize;
        for &(dist, f) in &order {
            let (lo, hi) = boxes[f as usize];
            footprint(lo.as_dvec3() - o, hi.as_dvec3() - o, dist, |c| {
                start[c + 1] += 1;
                total += 1;
            });
            if total > MAX_ENTRIES {
                return None;
            }
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut next = start.clone();
        let mut entries = vec![(0.0f32, 0u32); total];
        for &(dist, f) in &order {
            let (lo, hi) = boxes[f as usize];
            // Rounded down (a box is never nearer than its entry says).
            let mut near = (dist * (1.0 - 1e-6)) as f32;
            if near as f64 > dist {
                // (Among subnormals the cast may round up.)
                near = f32::from_bits(near.to_bits() - 1);
            }
            footprint(lo.as_dvec3() - o, hi.as_dvec3() - o, dist, |c| {
                entries[next[c] as usize] = (near, f);
                next[c] += 1;
            });
        }
        Some(Bins { start, entries })
    }

    /// Cell `c`'s facets, nearest box first.
    #[inline]
    pub(super) fn cell(&self, c: usize) -> &[(f32, u32)] {
        &self.entries[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// Calls `call` with each cell that a direction from the origin to a point of the box
/// `lo..hi` (relative to the origin, `dist` from it) may fall in, once each.
fn footprint(lo: DVec3, hi: DVec3, dist: f64, mut call: impl FnMut(usize)) {
    for face in 0..6 {
        let axis = face / 2;
        let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
        // The major coordinate's range; a direction of this face has it at 1/√3 of its
        // length or more, so the box's points it may reach lie at dist/√3 or more.
        let (m_lo, m_hi) = if face % 2 == 0 {
            (lo[axis], hi[axis])
        } else {
            (-hi[axis], -lo[axis])
        };
        let m_lo = m_lo.max(0.999 * dist / 3f64.sqrt());
        if !(m_hi >= m_lo) {
            continue;
        }
        let range = |w_lo: f64, w_hi: f64| -> Option<(usize, usize)> {
            let (a, b) = if m_lo > 0.0 {
                (
                    if w_lo < 0.0 { w_lo / m_lo } else { w_lo / m_hi },
                    if w_hi > 0.0 { w_hi / m_lo } else { w_hi / m_hi },
                )
            } else {
                (-1.0, 1.0)
            };
            let (a, b) = (a - PAD * (1.0 + a.abs()), b + PAD * (1.0 + b.abs()));
            if b < -1.0 || a > 1.0 || a.is_nan() || b.is_nan() {
                return None;
            }
            let at =
                |w: f64| (((w.clamp(-1.0, 1.0) + 1.0) * 0.5 * SIDE as f64) as usize).min(SIDE - 1);
            Some((at(a), at(b)))
        };
        let Some((i0, i1)) = range(lo[u_axis], hi[u_axis]) else {
            continue;
        };
        let Some((j0, j1)) = range(lo[v_axis], hi[v_axis]) else {
            continue;
        };
        for j in j0..=j1 {
            for i in i0..=i1 {
                call((face * SIDE + j) * SIDE + i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every direction to a point of a box falls in a cell that lists the box, the
    /// listed distance being no farther than the point.
    #[test]
    fn every_direction_into_a_box_finds_it() {
        let boxes = [
            (Vec3::new(1.0, -0.5, -0.5), Vec3::new(2.0, 0.5, 0.5)),
            (Vec3::new(-3.0, -3.0, 2.0), Vec3::new(3.0, 3.0, 2.1)),
            // The origin inside.
            (Vec3::new(-0.1, -0.1, -0.1), Vec3::new(0.1, 0.1, 0.1)),
            (Vec3::new(0.3, 0.3, -5.0), Vec3::new(0.4, 5.0, -4.0)),
        ];
        let o = Vec3::new(0.01, 0.02, -0.03);
        let bins = Bins::new(o, &boxes).unwrap();
        let mut k = 0u32;
        for (f, &(lo, hi)) in boxes.iter().enumerate() {
            for a in 0..=8 {
                for b in 0..=8 {
                    for c in 0..=8 {
                        k = k.wrapping_mul(747796405).wrapping_add(2891336453);
                        let w = Vec3::new(a as f32, b as f32, c as f32) / 8.0;
                        let p = lo + (hi - lo) * w;
                        let d = (p - o) * (1.0 + (k >> 16) as f32 / 65536.0);
                        let Some(cell) = cell_of(d) else { continue };
                        let entry = bins.cell(cell).iter().find(|e| e.1 == f as u32);
                        let entry =
                            entry.unwrap_or_else(|| panic!("box {f} not in the cell of {d}"));
                        assert!(
                            entry.0 <= (p - o).length(),
                            "box {f}: {} > {}",
                            entry.0,
                            (p - o).length()
                        );
                    }
                }
            }
        }
        // The box about the origin is in every cell; the box along +x in none of −x's.
        for c in 0..6 * SIDE * SIDE {
            assert!(bins.cell(c).iter().any(|e| e.1 == 2));
        }
        let behind = cell_of(Vec3::new(-1.0, 0.1, 0.2)).unwrap();
        assert!(bins.cell(behind).iter().all(|e| e.1 != 0));
        // Nearest first in every cell.
        for c in 0..6 * SIDE * SIDE {
            assert!(bins.cell(c).windows(2).all(|w| w[0].0 <= w[1].0));
        }
    }

    /// Bins that would hold more than `MAX_ENTRIES` entries are not made (the rays go
    /// through the tree).
    #[test]
    fn too_many_entries_make_no_bins() {
        let about = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let cells = 6 * SIDE * SIDE;
        let fits = vec![about; MAX_ENTRIES / cells];
        assert!(Bins::new(Vec3::ZERO, &fits).is_some());
        let over = vec![about; MAX_ENTRIES / cells + 1];
        assert!(Bins::new(Vec3::ZERO, &over).is_none());
    }
}
