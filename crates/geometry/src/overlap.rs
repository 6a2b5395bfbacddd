//! Coplanar polygons that face the same way and overlap (a face given twice, z-fighting
//! pieces): rays would meet only the lower-numbered one (the tie rule), so the other
//! would silently receive no light. Found by grouping polygons by plane and sweeping
//! their boxes, then clipping each candidate pair in their common plane.

use crate::clip::{clip_convex, plane_frame, polygon_area_centroid};
use crate::polygon::Polygon;
use glam::DVec3;

/// Two polygons whose planes' unit normals differ by less than this (in length) and
/// whose offsets differ by less than [`PLANE_TOLERANCE`] of the scene's extent are
/// coplanar.
pub const NORMAL_TOLERANCE: f64 = 1e-6;

/// See [`NORMAL_TOLERANCE`].
pub const PLANE_TOLERANCE: f64 = 1e-7;

/// An overlap is reported when it covers more than this fraction of the smaller
/// polygon (shared edges and corners cover nothing).
pub const OVERLAP_FRACTION: f64 = 1e-6;

/// The first pair of polygons (lower index first) that are coplanar, face the same way
/// and overlap, with the area they share; `None` if there is none.
pub fn find_overlap(polygons: &[Polygon], extent: f64) -> Option<(usize, usize, f64)> {
    struct Item {
        k: usize,
        normal: DVec3,
        offset: f64,
        lo: DVec3,
        hi: DVec3,
    }
    let mut items: Vec<Item> = polygons
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let normal = p.normal().as_dvec3().normalize();
            let v = p.vertices();
            let (lo, hi) = v.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), q| (lo.min(q.as_dvec3()), hi.max(q.as_dvec3())),
            );
            let offset = normal.dot(v[0].as_dvec3());
            Item {
                k,
                normal,
                offset,
                lo,
                hi,
            }
        })
        .collect();
    // Sorted by normal (quantised coarsely enough that equal normals fall together),
    // then offset; cut into clusters of one normal whose offsets chain within the
    // tolerance; each cluster swept along x (sweep and prune), so that a large flat
    // tessellated floor costs about n log n, not n².
    let key = |n: DVec3| (n * 1e4).round().to_array().map(|c| c as i64);
    items.sort_by(|a, b| {
        key(a.normal)
            .cmp(&key(b.normal))
            .then(a.offset.total_cmp(&b.offset))
    });
    let tol = PLANE_TOLERANCE * extent.max(f64::MIN_POSITIVE);
    let mut best: Option<(usize, usize, f64)> = None;
    let mut start = 0;
    while start < items.len() {
        let mut end = start + 1;
        while end < items.len()
            && key(items[end].normal) == key(items[start].normal)
            && items[end].offset - items[end - 1].offset <= tol
        {
            end += 1;
        }
        let cluster = &mut items[start..end];
        cluster.sort_by(|a, b| a.lo.x.total_cmp(&b.lo.x));
        for (i, a) in cluster.iter().enumerate() {
            for b in &cluster[i + 1..] {
                if b.lo.x > a.hi.x + tol {
                    break;
                }
                if (a.offset - b.offset).abs() > tol
                    || (a.normal - b.normal).length() > NORMAL_TOLERANCE
                    || (1..3).any(|c| a.lo[c] > b.hi[c] + tol || b.lo[c] > a.hi[c] + tol)
                {
                    continue;
                }
                let (pa, pb) = (&polygons[a.k], &polygons[b.k]);
                let shared = shared_area(pa, pb, a.normal);
                if shared > OVERLAP_FRACTION * pa.area().min(pb.area()) {
                    let pair = (a.k.min(b.k), a.k.max(b.k), shared);
                    if best.is_none_or(|x| (pair.0, pair.1) < (x.0, x.1)) {
                        best = Some(pair);
                    }
                }
            }
        }
        start = end;
    }
    best
}

/// The area two coplanar convex polygons share, clipped in a frame of their plane.
fn shared_area(a: &Polygon, b: &Polygon, normal: DVec3) -> f64 {
    let (ex, ey) = plane_frame(normal);
    let o = a.vertices()[0].as_dvec3();
    let flat = |p: &Polygon| -> Vec<[f64; 2]> {
        p.vertices()
            .iter()
            .map(|v| {
                let d = v.as_dvec3() - o;
                [d.dot(ex), d.dot(ey)]
            })
            .collect()
    };
    // (ex, ey, normal) is right-handed, so both outlines run counter-clockwise here.
    let piece = clip_convex(&flat(a), &flat(b));
    polygon_area_centroid(&piece).0.abs()
}
