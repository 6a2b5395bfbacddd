//! Single rays through a wide BVH: `obvhs`'s eight-wide compressed BVH (CWBVH, PLOC
//! build, its `slow_build` preset: the render of the 115,200-triangle loft 9 % faster
//! than with `medium_build`, for a build of 96 ms instead of 57), a well-kept crate
//! whose build is 2.1 to 2.6 times faster and whose rays are 1.6 to 2.4 times faster
//! than the hierarchy's own binary tree on the bench scenes (`cargo run --release -p
//! rad-hemisphere --example single_rays`), with the shared f32 hit test and the
//! lower-id tie rule deciding every candidate, so the hits are brute force's, to the
//! bit.
//!
//! Why the crate's box tests cannot lose a hit: each polygon's box is grown by 1e-4 of
//! the scene's scale, far past the f32 rounding of any accepted hit (a few 1e-7 of it);
//! so a ray with an accepted hit at t enters that box before t, and the traversal, which
//! only drops boxes it enters after the nearest t so far, visits every polygon that
//! could win or tie. Rays from origins far outside the scene (over ten times its scale)
//! go to brute force.

use glam_obvhs::Vec3A;
use obvhs::{aabb::Aabb, cwbvh::builder::build_cwbvh, cwbvh::CwBvh, ray::RayHit, Boundable};
use rad_core::{Hit, PolygonId, Ray, RayCast};
use rad_geometry::{PolygonTerms, Scene, Shape};

/// A wide BVH over one scene's polygons, as a [`RayCast`].
pub struct WideBvh<'s> {
    scene: &'s Scene,
    bvh: CwBvh,
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
        let bound = |vs: &mut dyn Iterator<Item = glam::Vec3>| {
            vs.fold(
                (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
                |(lo, hi), v| (lo.min(v), hi.max(v)),
            )
        };
        let polygons = scene.polygons();
        let (lo, hi) = bound(&mut polygons.iter().flat_map(|p| p.vertices().iter().copied()));
        let scale = if polygons.is_empty() {
            0.0
        } else {
            lo.abs().max(hi.abs()).max_element() + (hi - lo).length()
        };
        let grow = 1e-4 * scale;
        let boxes: Vec<Boxed> = polygons
            .iter()
            .map(|p| {
                let (a0, b0) = bound(&mut p.vertices().iter().copied());
                let reach = p.reach() * 4.0;
                Boxed(Aabb {
                    min: a(a0 - grow - reach),
                    max: a(b0 + grow + reach),
                })
            })
            .collect();
        let bvh = build_cwbvh(
            &boxes,
            obvhs::BvhBuildParams::slow_build(),
            &mut std::time::Duration::default(),
        );
        let terms = bvh
            .primitive_indices
            .iter()
            .map(|&id| {
                let p = &polygons[id as usize];
                (p.terms(), Shape::of(p))
            })
            .collect();
        WideBvh {
            scene,
            bvh,
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
        self.bvh.primitive_indices[k]
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
        let traversal = obvhs::ray::Ray::new(a(ray.origin), a(ray.dir), 0.0, f32::INFINITY);
        let mut best: Option<Hit> = None;
        let mut hit = RayHit::none();
        self.bvh.ray_traverse(traversal, &mut hit, |_, k| {
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
        let traversal = obvhs::ray::Ray::new(a(ray.origin), a(ray.dir), 0.0, f32::INFINITY);
        self.bvh.ray_traverse_anyhit(traversal, |_, k| {
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
