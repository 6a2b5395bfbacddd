//! Single rays at the cost of facets: [`FacetRays`], a tree of boxes ([`BoxTree`], such
//! as `rad_accel::WideTree`) over a scene's facets rather than its polygons, for
//! rendering and any other [`RayCast`] use. A ray entering a facet's box meets its plane at one point, and the
//! facet's grid gives the few members that may hold that point (within the facet's
//! margin); their own hit tests decide, with ties in t going to the lower polygon id
//! whatever the order, so the hits are brute force's, to the bit. The bounds are the
//! facet scan's ([`Piece::stray`]): a ray meeting the plane at a slant has every member
//! within the stray of its point tested; from an origin (nearly) in the facet's plane,
//! every member near enough the origin's foot that the ray could reach it
//! ([`Piece::near_radius_along`]); a ray along that plane, every member. A 115,200
//! triangle mesh of 180 flat pieces costs about what those 180 pieces as polygons would.

mod bins;

use super::{Piece, Stray, NONE};
use bins::Bins;
use glam::{DVec3, Vec3};
use rad_core::{BoxTree, Hit, PolygonId, Ray, RayCast};
use rad_geometry::{Facets, PolygonTerms, Scene, Shape};

/// Single rays through a scene's facets (see the module's text).
pub struct FacetRays<'s, T> {
    scene: &'s Scene,
    facets: Facets,
    /// By facet: its piece in `pieces` (facets of several polygons), else `NONE`.
    piece_of: Vec<u32>,
    pieces: Vec<Piece>,
    /// The tree over the facets' boxes (each its members' [`rad_geometry::Polygon::tree_box`]).
    tree: T,
    /// Those boxes, by facet.
    boxes: Vec<(Vec3, Vec3)>,
    /// After how many rays from one origin (in a row, through one scratch) the facets
    /// are binned by direction from it ([`FacetRays::bin_after`]).
    bin_after: u64,
    /// The facets binned from one origin for every scratch ([`FacetRays::bin_from`]):
    /// the origin's bits and the bins.
    shared: Option<([u32; 3], Bins)>,
    /// By polygon: its hit-test terms and shape.
    terms: Vec<(PolygonTerms, Shape)>,
    scale: f32,
    /// Unique to this caster (a scratch made for another is not trusted).
    id: u64,
}

/// After how many rays from one origin, per facet, in a row through one scratch (a
/// rayon job's), [`FacetRays`] bins the facets by direction from it (a light buffer:
/// its rays then walk no tree), unless binned from it already ([`FacetRays::bin_from`]). Binning a facet
/// costs about what a few rays do: a 640 × 480 image of 2 × 2 rays a pixel of the
/// 20,488-facet `blob_room`, on one thread, takes 0.17 s binned and 0.22 s through
/// the tree.
pub const BIN_RAYS_PER_FACET: u64 = 16;

/// The fewest rays from one origin after which [`FacetRays`] bins.
pub const MIN_BIN_RAYS: u64 = 4096;

/// The next [`FacetRays`]' `id`.
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Per-thread memory of [`FacetRays`]: each facet's stray from the last origin.
#[derive(Clone, Debug, Default)]
pub struct FacetRaysScratch {
    /// The caster it was made for ([`FacetRays`]' `id`) and the origin.
    origin: Option<(u64, [u32; 3])>,
    stamp: u32,
    /// By facet: the stamp it was made for, and its stray (None: the origin lies
    /// (nearly) in its plane).
    strays: Vec<(u32, Option<Stray>)>,
    /// The facet the last ray from this origin met nearest (a camera's next ray most
    /// often meets it too: resolved first, its hit bounds the traversal).
    last: Option<((u64, [u32; 3]), u32, PolygonId)>,
    /// The origin the last rays came from, and how many in a row.
    run: Option<((u64, [u32; 3]), u64)>,
    /// The facets binned by direction from that origin (None inside: too many entries).
    bins: Option<((u64, [u32; 3]), Option<std::sync::Arc<Bins>>)>,
}

impl FacetRaysScratch {
    /// Facet `f`'s stray from `o` (made once an origin).
    #[inline]
    fn stray<T>(&mut self, rays: &FacetRays<T>, f: u32, piece: &Piece, o: Vec3) -> Option<Stray> {
        let key = (rays.id, o.to_array().map(f32::to_bits));
        if self.origin != Some(key) || self.strays.len() != rays.piece_of.len() {
            self.origin = Some(key);
            if self.strays.len() != rays.piece_of.len() || self.stamp == u32::MAX {
                self.strays.clear();
                self.strays.resize(rays.piece_of.len(), (0, None));
                self.stamp = 0;
            }
            self.stamp += 1;
        }
        let slot = &mut self.strays[f as usize];
        if slot.0 != self.stamp {
            *slot = (self.stamp, piece.stray(o.as_dvec3()));
        }
        slot.1
    }
}

impl<'s, T: BoxTree> FacetRays<'s, T> {
    /// The facets of `scene` ([`Facets::exact`]) and a tree over their boxes, built by
    /// `tree` (`rad_accel::WideTree::new`, say).
    pub fn new(scene: &'s Scene, tree: impl FnOnce(&[(Vec3, Vec3)]) -> T) -> FacetRays<'s, T> {
        let facets = Facets::exact(scene);
        let polygons = scene.polygons();
        let (piece_of, pieces) = super::pieces_of(&facets, polygons);
        let scale = scene.scale();
        let grow = 1e-4 * scale;
        let boxes: Vec<(Vec3, Vec3)> = (0..facets.len() as u32)
            .map(|f| {
                facets.polygons(f).iter().fold(
                    (Vec3::INFINITY, Vec3::NEG_INFINITY),
                    |(lo, hi), &p| {
                        let (a, b) = polygons[p as usize].tree_box(grow);
                        (lo.min(a), hi.max(b))
                    },
                )
            })
            .collect();
        FacetRays {
            scene,
            tree: tree(&boxes),
            bin_after: (BIN_RAYS_PER_FACET * boxes.len() as u64).max(MIN_BIN_RAYS),
            shared: None,
            boxes,
            terms: polygons.iter().map(|p| (p.terms(), Shape::of(p))).collect(),
            facets,
            piece_of,
            pieces,
            scale,
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// This caster with its facets binned by direction from `origin` once for every
    /// thread (a camera's: see [`BIN_RAYS_PER_FACET`]); unchanged if the bins would
    /// hold too many entries. The hits are the same either way.
    pub fn bin_from(mut self, origin: Vec3) -> Self {
        if let Some(bins) = Bins::new(origin, &self.boxes) {
            self.shared = Some((origin.to_array().map(f32::to_bits), bins));
        }
        self
    }

    /// This caster binning the facets by direction from an origin once `rays` rays in a
    /// row (through one scratch: a rayon job's) have come from it, rather than after
    /// [`BIN_RAYS_PER_FACET`] a facet (at least [`MIN_BIN_RAYS`]): the hits are the
    /// same either way.
    pub fn bin_after(mut self, rays: u64) -> Self {
        self.bin_after = rays;
        self
    }

    /// How many facets the tree holds (what a ray's cost follows).
    pub fn facet_count(&self) -> usize {
        self.facets.len()
    }

    /// Rays whose origin lies far outside the scene go to brute force (as
    /// `rad_accel::WideBvh`'s do).
    fn near(&self, ray: &Ray) -> bool {
        ray.origin.abs().max_element() <= 10.0 * self.scale && !self.scene.polygons().is_empty()
    }

    /// The hit of `ray` on polygon `p` (`Polygon::intersect`).
    #[inline]
    fn hit(&self, p: PolygonId, ray: &Ray) -> Option<rad_geometry::PolygonHit> {
        let (terms, shape) = &self.terms[p as usize];
        let poly = || &self.scene.polygons()[p as usize];
        let terms = self.scene.seen(p as usize, terms.at(ray.origin));
        shape.hit_from(poly, &terms, ray.dir, ray.t_max)
    }

    /// Facet `f`'s members' hits of `ray` offered to `best` (the nearest kept, the
    /// lower id winning a tie whatever the order); the nearest t among them. `likely`:
    /// a member the ray's point may well lie in (the last ray's).
    #[inline]
    fn resolve(
        &self,
        f: u32,
        ray: &Ray,
        likely: Option<PolygonId>,
        s: &mut FacetRaysScratch,
        best: &mut Option<Hit>,
    ) -> f32 {
        let mut nearest = f32::INFINITY;
        let bt = best.map_or(f32::INFINITY, |b| b.t);
        self.candidates(f, ray, bt, likely, s, |p| {
            if p == ray.skip {
                return;
            }
            if let Some((t, u, v, front)) = self.hit(p, ray) {
                if best.is_none_or(|b| t < b.t || (t == b.t && p < b.polygon)) {
                    *best = Some(Hit {
                        polygon: p,
                        u,
                        v,
                        t,
                        front,
                    });
                }
                nearest = nearest.min(t);
            }
        });
        nearest
    }

    /// Calls `call` with every member of facet `f` whose test may accept `ray` no
    /// farther than `best` (a polygon may come more than once).
    #[inline]
    fn candidates(
        &self,
        f: u32,
        ray: &Ray,
        best: f32,
        likely: Option<PolygonId>,
        s: &mut FacetRaysScratch,
        mut call: impl FnMut(PolygonId),
    ) {
        let members = self.facets.polygons(f);
        let piece = self.piece_of[f as usize];
        if piece == NONE {
            return call(members[0]);
        }
        let piece = &self.pieces[piece as usize];
        let (o, dir) = (ray.origin, ray.dir);
        let (n32, d32) = self.facets.plane(f);
        let dn = n32.dot(dir);
        let cos = dn.abs();
        let Some(stray) = s.stray(self, f, piece, o) else {
            // The origin lies (nearly) in the plane.
            let cos64 = piece.n.dot(dir.as_dvec3()).abs();
            match piece.near_radius_along(o.as_dvec3(), cos64) {
                Some(r) => self.facets.for_each_near(f, o, r as f32, call),
                None => members.iter().for_each(|&p| call(p)),
            }
            return;
        };
        if (cos as f64) < stray.mu_min {
            // (It cannot meet the facet's rectangle.)
            return;
        }
        let reach = stray.at(cos as f64);
        let t = (d32 - n32.dot(o)) / dn;
        // A member's t and the plane's differ by the stray at most.
        let limit = best.min(ray.t_max) as f64;
        if !(t > 0.0) || t as f64 > limit * (1.0 + 1e-3) + 2.0 * reach {
            return;
        }
        if cos as f64 >= stray.mu_located {
            self.facets.for_each_holding_at(f, o, dir, t, likely, call);
        } else {
            let r = reach + piece.margin;
            if r > 4.0 * self.facets.cell_size(f) as f64 {
                members.iter().for_each(|&p| call(p));
            } else {
                self.facets.for_each_within(f, o, dir, r as f32, call);
            }
        }
    }
}

impl<T: BoxTree> FacetRays<'_, T> {
    /// The bins from origin `o` (of `key`), made once `bin_after` rays in a row have
    /// come from it; None before, or if there would be too many entries.
    fn bins_for(
        &self,
        key: (u64, [u32; 3]),
        o: Vec3,
        s: &mut FacetRaysScratch,
    ) -> Option<std::sync::Arc<Bins>> {
        if let Some((k, bins)) = &s.bins {
            if *k == key {
                return bins.clone();
            }
        }
        let run = match s.run {
            Some((k, n)) if k == key => n + 1,
            _ => 1,
        };
        s.run = Some((key, run));
        if run < self.bin_after {
            return None;
        }
        let bins = Bins::new(o, &self.boxes).map(std::sync::Arc::new);
        s.bins = Some((key, bins.clone()));
        bins
    }

    /// `ray`'s nearest hit offered to `best` from the facets of its cell in `bins`,
    /// nearest box first, until a box lies beyond the nearest hit (`guess`, resolved
    /// already, skipped); false if the ray has no cell (a zero, infinite or NaN
    /// direction) or a length too small to bound its distances in f32.
    fn closest_binned(
        &self,
        bins: &Bins,
        ray: &Ray,
        guess: Option<u32>,
        s: &mut FacetRaysScratch,
        best: &mut Option<Hit>,
    ) -> bool {
        let Some(cell) = bins::cell_of(ray.dir) else {
            return false;
        };
        // A hit at t lies t |dir| from the origin, in its facet's box (the entry's
        // distance is rounded down; the slack covers this product's rounding).
        let len = ray.dir.length() * (1.0 + 1e-5);
        if !len.is_normal() {
            return false;
        }
        for &(near, f) in bins.cell(cell) {
            let t = best.map_or(ray.t_max, |b| b.t.min(ray.t_max));
            if near > t * len {
                break;
            }
            if Some(f) != guess {
                self.resolve(f, ray, None, s, best);
            }
        }
        true
    }
}

impl<T: BoxTree + Sync> RayCast for FacetRays<'_, T> {
    type Scratch = FacetRaysScratch;

    fn new_scratch(&self) -> FacetRaysScratch {
        FacetRaysScratch::default()
    }

    fn closest_hit(&self, ray: &Ray, s: &mut FacetRaysScratch) -> Option<Hit> {
        if !self.near(ray) {
            // (Brute force: the nearest, the lower id on a tie.)
            let mut all = Vec::new();
            self.scene.all_hits(ray, &mut all);
            return all.first().copied();
        }
        let mut best: Option<Hit> = None;
        let key = (self.id, ray.origin.to_array().map(f32::to_bits));
        // The last ray's facet first: boxes entered beyond its hit are never visited
        // (and a tie at that t still is: its box is entered no later).
        let last = s.last.filter(|l| l.0 == key);
        let guess = last.map(|l| l.1);
        if let Some((_, g, p)) = last {
            self.resolve(g, ray, Some(p), s, &mut best);
        }
        let binned = match &self.shared {
            Some((o, bins)) if *o == key.1 => self.closest_binned(bins, ray, guess, s, &mut best),
            _ => match self.bins_for(key, ray.origin, s) {
                Some(bins) => self.closest_binned(&bins, ray, guess, s, &mut best),
                None => false,
            },
        };
        if !binned {
            let t_max = best.map_or(f32::INFINITY, |b| b.t);
            self.tree.closest_within(ray.origin, ray.dir, t_max, |k| {
                let f = self.tree.index(k);
                if Some(f) == guess {
                    return f32::INFINITY;
                }
                self.resolve(f, ray, None, s, &mut best)
            });
        }
        if let Some(b) = best {
            s.last = Some((key, self.facets.facet_of(b.polygon), b.polygon));
        }
        best
    }

    fn all_hits(&self, ray: &Ray, s: &mut FacetRaysScratch, out: &mut Vec<Hit>) {
        if !self.near(ray) {
            return self.scene.all_hits(ray, out);
        }
        out.clear();
        self.tree.every(ray.origin, ray.dir, |k| {
            let f = self.tree.index(k);
            self.candidates(f, ray, f32::INFINITY, None, s, |p| {
                if p == ray.skip {
                    return;
                }
                if let Some((t, u, v, front)) = self.hit(p, ray) {
                    out.push(Hit {
                        polygon: p,
                        u,
                        v,
                        t,
                        front,
                    });
                }
            });
        });
        // (A polygon found twice is the same hit twice.)
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
        out.dedup_by_key(|h| (h.t.to_bits(), h.polygon));
    }
}

impl Piece {
    /// For a ray from `o` (nearly in the facet's plane: [`Piece::stray`] is None)
    /// meeting the plane at a cosine of `cos`: how far from `o`'s foot on the plane a
    /// member must come to be hit at all (None if the ray runs nearly along the plane),
    /// as [`Piece::near_radius`] bounds it for a hemisphere's rays.
    fn near_radius_along(&self, o: DVec3, cos: f64) -> Option<f64> {
        let d_min = cos - 2.0 * self.tilt - 1e-5;
        if d_min <= 1e-5 {
            return None;
        }
        let size = o.abs().max_element() + self.magnitude;
        let num = (self.n.dot(o) - self.d).abs()
            + self.off
            + 16.0 * super::ULP * (self.d.abs() + 3.0 * size);
        let t_max = 1.01 * num / d_min;
        Some(t_max + self.reach + self.off + 1e-5 * (1.0 + size) + self.margin)
    }
}
