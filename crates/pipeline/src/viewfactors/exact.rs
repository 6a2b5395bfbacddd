//! Which pairs of a scene's polygons no polygon can come between, and their factors in
//! closed form ([`rad_exact`]): each polygon of a pair clipped to the half-space the
//! other faces, the shaft between the two tested against every other polygon (boxes
//! first), and the pairs found clear integrated over their outlines.

use crate::Error;
use glam::DVec3;
use rad_exact::{area_factor, clip_to_front, Shaft};
use rad_geometry::{Polygon, Scene};
use rayon::prelude::*;

/// Points within this share of a pair's extent of a shaft face count as on it.
const SHAFT_SLACK: f64 = 1e-9;

/// A polygon whose vertices lie within this share of a pair's extent of the other's
/// plane lies in it.
const COPLANAR: f64 = 1e-9;

/// The polygons' pairs: the clear ones' `A_p F_pq` in closed form, and which polygons
/// have a pair that another polygon may come between.
#[derive(Clone, Debug, Default)]
pub struct PolygonPairs {
    /// `(p, q, A_p F_pq, its error estimate)` for `p < q` of every clear pair that sees
    /// anything (`A_q F_qp` is the same value), in order of `p`, then `q`.
    pub clear: Vec<(u32, u32, f64, f64)>,
    /// By polygon: whether some pair of it is not clear (its patches' hemispheres give
    /// that pair's factor).
    pub obstructed: Vec<bool>,
    /// Pairs not clear, `p < q`, the first few, with a polygon that may come between.
    pub first_obstructed: Vec<(u32, u32, u32)>,
    pub n_obstructed: usize,
}

/// A polygon's outline in f64.
fn outline(p: &Polygon) -> Vec<DVec3> {
    p.vertices().iter().map(|v| v.as_dvec3()).collect()
}

/// A polygon's plane: its unit normal and offset, in f64.
fn plane(outline: &[DVec3]) -> (DVec3, f64) {
    let mut n = DVec3::ZERO;
    for k in 0..outline.len() {
        n += outline[k].cross(outline[(k + 1) % outline.len()]);
    }
    let n = n.normalize_or_zero();
    (n, n.dot(outline[0]))
}

/// The pairs of `scene`'s polygons that take part (`takes_part[p]`), each clear pair's factor to `tolerance`
/// (relative, of the first polygon's area).
pub fn polygon_pairs(
    scene: &Scene,
    takes_part: &[bool],
    tolerance: f64,
) -> Result<PolygonPairs, Error> {
    let polygons = scene.polygons();
    let n = polygons.len();
    let outlines: Vec<Vec<DVec3>> = polygons.iter().map(outline).collect();
    let planes: Vec<(DVec3, f64)> = outlines.iter().map(|o| plane(o)).collect();
    let boxes: Vec<(DVec3, DVec3)> = outlines
        .iter()
        .map(|o| {
            o.iter()
                .fold((o[0], o[0]), |(lo, hi), &v| (lo.min(v), hi.max(v)))
        })
        .collect();
    // Per first polygon p, in parallel: its pairs with every later q.
    type Found = (Vec<(u32, u32, f64, f64)>, Vec<(u32, u32)>);
    let per_p: Vec<Found> = (0..n)
        .into_par_iter()
        .map(|p| {
            let mut clear = Vec::new();
            let mut blocked = Vec::new();
            if !takes_part[p] {
                return (clear, blocked);
            }
            for q in p + 1..n {
                if !takes_part[q] {
                    continue;
                }
                let (np, dp) = planes[p];
                let (nq, dq) = planes[q];
                // Nothing passes between polygons of one plane (a two-sided polygon's
                // sides, a mesh's flat piece).
                let (lo, hi) = (boxes[p].0.min(boxes[q].0), boxes[p].1.max(boxes[q].1));
                let tol = COPLANAR * (hi - lo).max_element();
                if outlines[q].iter().all(|v| (np.dot(*v) - dp).abs() <= tol) {
                    continue;
                }
                let q_seen = clip_to_front(&outlines[q], np, dp);
                if q_seen.is_empty() {
                    continue;
                }
                let p_seen = clip_to_front(&outlines[p], nq, dq);
                if p_seen.is_empty() {
                    continue;
                }
                let shaft = Shaft::between(&p_seen, &q_seen, SHAFT_SLACK);
                let (slo, shi) = (lo, hi);
                let blocker = (0..n).find(|&r| {
                    r != p
                        && r != q
                        && !(boxes[r].0.cmpgt(shi).any() || boxes[r].1.cmplt(slo).any())
                        && shaft.may_block(&outlines[r])
                });
                match blocker {
                    Some(r) => blocked.push((q as u32, r as u32)),
                    None => {
                        let f = area_factor(&p_seen, &q_seen, tolerance);
                        if f.value > 0.0 {
                            clear.push((p as u32, q as u32, f.value, f.error));
                        }
                    }
                }
            }
            (clear, blocked)
        })
        .collect();
    let mut out = PolygonPairs {
        obstructed: vec![false; n],
        ..PolygonPairs::default()
    };
    for (p, (clear, blocked)) in per_p.into_iter().enumerate() {
        out.clear.extend(clear);
        for (q, r) in blocked {
            if out.first_obstructed.len() < 4 {
                out.first_obstructed.push((p as u32, q, r));
            }
            out.obstructed[p] = true;
            out.obstructed[q as usize] = true;
            out.n_obstructed += 1;
        }
    }
    Ok(out)
}
