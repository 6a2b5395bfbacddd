//! Single rays through a wide BVH: `obvhs`'s eight-wide compressed BVH (CWBVH, PLOC
//! build, its `slow_build` preset: the render of the 115,200-triangle loft 9 % faster
//! than with `medium_build`, for a build of 96 ms instead of 57), a well-kept crate
//! whose build is 2.1 to 2.6 times faster and whose rays are 1.6 to 2.4 times faster
//! than the hierarchy's own binary tree on the bench scenes (`cargo run --release -p
//! rad-repro --example single_rays`), with the shared f32 hit test and the
//! lower-id tie rule deciding every candidate, so the hits are brute force's, to the
//! bit.
//!
//! Why the crate's box tests cannot lose a hit: each polygon's box holds every point its
//! test accepts (twice its hull reach past its vertices: far along a sliver) and is
//! grown by 1e-4 of the scene's scale, far past the f32 rounding of any accepted hit (a
//! few 1e-7 of it);
//! so a ray with an accepted hit at t enters that box before t, and the traversal, which
//! only drops boxes it enters after the nearest t so far, visits every polygon that
//! could win or tie. Rays from origins far outside the scene (over ten times its scale)
//! go to brute force.

use glam_obvhs::Vec3A;
use obvhs::{aabb::Aabb, cwbvh::builder::build_cwbvh, cwbvh::CwBvh, ray::RayHit, Boundable};
use rad_core::{BoxTree, Hit, PolygonId, Ray, RayCast};
use rad_geometry::{PolygonTerms, Scene, Shape};

/// How far back along the ray traversal starts: `obvhs` drops boxes the ray leaves
/// before t = 1e-4 (a fixed distance, its `EPSILON`), which in a scene smaller than
/// about 1 (whose boxes grow by less) would lose hits nearer than that.
const BACK_OFF: f32 = 2e-4;

/// `obvhs`'s eight-wide BVH over boxes, for casters whose leaves are not one polygon
/// each (a facet of many, say): the leaves are the boxes' indices in the tree's order.
pub struct WideTree {
    bvh: CwBvh,
}

impl WideTree {
    /// The tree over boxes (lower, upper corner), built as [`WideBvh`]'s is.
    pub fn new(boxes: &[(glam::Vec3, glam::Vec3)]) -> WideTree {
        let boxes: Vec<Boxed> = boxes
            .iter()
            .map(|&(lo, hi)| {
                Boxed(Aabb {
                    min: a(lo),
                    max: a(hi),
                })
            })
            .collect();
        WideTree {
            bvh: build_cwbvh(
                &boxes,
                obvhs::BvhBuildParams::slow_build(),
                &mut std::time::Duration::default(),
            ),
        }
    }
}

impl BoxTree for WideTree {
    #[inline]
    fn index(&self, k: usize) -> u32 {
        self.bvh.primitive_indices[k]
    }

    #[inline]
    fn closest_within(
        &self,
        origin: glam::Vec3,
        dir: glam::Vec3,
        t_max: f32,
        leaf: impl FnMut(usize) -> f32,
    ) {
        let mut leaf = leaf;
        let ray = obvhs::ray::Ray::new(a(origin - dir * BACK_OFF), a(dir), 0.0, t_max + BACK_OFF);
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(ray, &mut hit, |_, k| leaf(k) + BACK_OFF);
    }

    #[inline]
    fn every(&self, origin: glam::Vec3, dir: glam::Vec3, leaf: impl FnMut(usize)) {
        let mut leaf = leaf;
        let ray = obvhs::ray::Ray::new(a(origin - dir * BACK_OFF), a(dir), 0.0, f32::INFINITY);
        self.bvh.ray_traverse_anyhit(ray, |_, k| leaf(k));
    }
}

/// A wide BVH over one scene's polygons, as a [`RayCast`].
pub struct WideBvh<'s> {
    scene: &'s Scene,
    tree: WideTree,
    /// Each polygon's hit-test terms and shape, in the tree's order (what a leaf reads:
    /// [`Shape::hit_from`] gives [`rad_geometry::Polygon::intersect`]'s answer).
    terms: Vec<(PolygonTerms, Shape)>,
    /// The scene's largest coordinate plus its diagonal.
    scale: f32,
}

struct Boxed(Aabb);

impl Boundable for Boxed {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

fn a(v: glam::Vec3) -> Vec3A {
    Vec3A::new(v.x, v.y, v.z)
}

impl<'s> WideBvh<'s> {
    pub fn new(scene: &'s Scene) -> WideBvh<'s> {
        let polygons = scene.polygons();
        let scale = scene.scale();
        let grow = 1e-4 * scale;
        let boxes: Vec<(glam::Vec3, glam::Vec3)> =
            polygons.iter().map(|p| p.tree_box(grow)).collect();
        let tree = WideTree::new(&boxes);
        let terms = tree
            .bvh
            .primitive_indices
            .iter()
            .map(|&id| {
                let p = &polygons[id as usize];
                (p.terms(), Shape::of(p))
            })
            .collect();
        WideBvh {
            scene,
            tree,
            terms,
            scale,
        }
    }

    /// Rays whose origin lies far outside the scene go to brute force (see the module
    /// documentation).
    fn near(&self, ray: &Ray) -> bool {
        ray.origin.abs().max_element() <= 10.0 * self.scale && !self.scene.polygons().is_empty()
    }

    fn id(&self, k: usize) -> PolygonId {
        self.tree.index(k)
    }

    /// The hit of `ray` on the polygon at tree position `k` (`Polygon::intersect`).
    #[inline]
    fn hit(&self, k: usize, ray: &Ray) -> Option<rad_geometry::PolygonHit> {
        let (terms, shape) = &self.terms[k];
        let poly = || &self.scene.polygons()[self.id(k) as usize];
        let terms = self.scene.seen(self.id(k) as usize, terms.at(ray.origin));
        shape.hit_from(poly, &terms, ray.dir, ray.t_max)
    }
}

impl RayCast for WideBvh<'_> {
    /// The traversal keeps its state on the stack.
    type Scratch = ();

    fn new_scratch(&self) {}

    fn closest_hit(&self, ray: &Ray, _: &mut ()) -> Option<Hit> {
        if !self.near(ray) {
            return crate::BruteForce::new(self.scene).closest_hit(ray, &mut ());
        }
        let mut best: Option<Hit> = None;
        self.tree.closest(ray.origin, ray.dir, |k| {
            let id = self.id(k);
            if id == ray.skip {
                return f32::INFINITY;
            }
            match self.hit(k, ray) {
                Some((t, u, v, front)) => {
                    // The lower id wins a tie, whatever the order candidates come in.
                    if best.is_none_or(|b| t < b.t || (t == b.t && id < b.polygon)) {
                        best = Some(Hit {
                            polygon: id,
                            u,
                            v,
                            t,
                            front,
                        });
                    }
                    t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    fn all_hits(&self, ray: &Ray, _: &mut (), out: &mut Vec<Hit>) {
        if !self.near(ray) {
            return self.scene.all_hits(ray, out);
        }
        out.clear();
        self.tree.every(ray.origin, ray.dir, |k| {
            let id = self.id(k);
            if id == ray.skip {
                return;
            }
            if let Some((t, u, v, front)) = self.hit(k, ray) {
                out.push(Hit {
                    polygon: id,
                    u,
                    v,
                    t,
                    front,
                });
            }
        });
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
    }
}
