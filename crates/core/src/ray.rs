//! Rays, hits and the [`RayCast`] trait implemented by accelerators.

use crate::{PolygonId, NO_POLYGON};
use glam::Vec3;

/// A ray `origin + t·dir`, `0 < t < t_max` (both ends exclusive).
///
/// Self-intersection rule: a ray leaving a patch carries its polygon in `skip`; that
/// polygon is never reported. A planar polygon cannot be hit again by a ray that leaves
/// its own plane, so the rule is exact, needs no epsilon offset, and loses no hit on
/// the polygons that meet it at its edges.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Exclusive upper bound on `t`; `f32::INFINITY` for none.
    pub t_max: f32,
    /// Polygon that is never hit (the ray's own), or [`NO_POLYGON`].
    pub skip: PolygonId,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir,
            t_max: f32::INFINITY,
            skip: NO_POLYGON,
        }
    }
}

/// A ray–polygon intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub polygon: PolygonId,
    /// Polygon parameters of the hit point: u along edge 0→1, v along edge 0→last.
    pub u: f32,
    pub v: f32,
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// True when the ray meets the polygon's emitting/reflecting side (against its normal).
    pub front: bool,
}

/// Visibility queries against a scene's polygons.
///
/// `Scratch` is per-thread working memory (the mailbox); make one per thread with
/// [`RayCast::new_scratch`].
pub trait RayCast: Sync {
    type Scratch: Send;

    fn new_scratch(&self) -> Self::Scratch;

    /// The nearest hit with `0 < t < ray.t_max`, whichever side it meets.
    fn closest_hit(&self, ray: &Ray, scratch: &mut Self::Scratch) -> Option<Hit>;

    /// Every polygon the ray crosses with `0 < t < ray.t_max`, sorted by `t`, appended to
    /// `out` after clearing it. Each polygon appears once.
    fn all_hits(&self, ray: &Ray, scratch: &mut Self::Scratch, out: &mut Vec<Hit>);

    /// The closest hit of each ray `origin + t·dirs[k]` (unit directions, `t_max`
    /// infinite, never hitting `skip`), written to `out[k]` after clearing `out`.
    ///
    /// The same answers as [`RayCast::closest_hit`] ray by ray; a hemisphere's rays share
    /// their origin, and an accelerator may share work between them.
    fn closest_hits_from(
        &self,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut Self::Scratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        out.clear();
        let mut ray = Ray::new(origin, Vec3::Z);
        ray.skip = skip;
        for &d in dirs {
            ray.dir = d;
            out.push(self.closest_hit(&ray, scratch));
        }
    }
}

/// A bounding volume hierarchy over boxes, traversed nearest first: what an
/// accelerator crate lends a caster whose leaves are its own (a facet of many polygons,
/// say), so that the caster need not know the tree.
pub trait BoxTree {
    /// The box at leaf position `k` (what a leaf call is given): its index in the
    /// boxes the tree was built from.
    fn index(&self, k: usize) -> u32;
    /// Each leaf position `k` whose box the ray from `origin` along `dir` enters (from
    /// t = 0 on, at any distance), in a near-to-far order, passed to `leaf`, which
    /// returns the distance of a hit found there (or infinity): boxes entered beyond
    /// the nearest such distance are skipped.
    fn closest(&self, origin: Vec3, dir: Vec3, leaf: impl FnMut(usize) -> f32) {
        self.closest_within(origin, dir, f32::INFINITY, leaf)
    }
    /// [`BoxTree::closest`] with the boxes entered beyond `t_max` skipped from the
    /// start (a hit at `t_max` found by other means).
    fn closest_within(&self, origin: Vec3, dir: Vec3, t_max: f32, leaf: impl FnMut(usize) -> f32);
    /// Every leaf position whose box the ray enters, passed to `leaf`.
    fn every(&self, origin: Vec3, dir: Vec3, leaf: impl FnMut(usize));
}
