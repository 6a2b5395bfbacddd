//! The facet scan: exact item buffers on meshes of flat pieces, at the cost of the
//! pieces rather than of their triangles.
//!
//! A building, a room or a panel exported as triangles is a few hundred flat pieces cut
//! into many triangles; the report's loft cut into 115,200 triangles is still its 185
//! walls. [`rad_geometry::Facets`] joins a mesh's coplanar one-patch polygons across
//! their edges into facets, each with a grid over its plane that turns a point into the
//! few polygons that may hold it. Here the polygon scan ([`Hemisphere::scan`]) runs over
//! facets, nearest first: a facet's angular box is found once, from a rectangle of its
//! plane holding every point any of its polygons' tests accepts, and each cell of it
//! whose ray may still meet the facet no farther than the cell's nearest hit so far
//! finds, in the facet's grid, the polygon its ray's point lies in. That polygon's own
//! f32 test (the grid's, [`crate::NearestHits::test_cell`]; for a point well inside it,
//! its t alone, which is the facet plane's where its f32 plane is the facet's to the
//! bit) then decides, with ties in t
//! going to the lower polygon id whatever the order: so the item buffers are the grid's,
//! bit for bit. Where the point lies within the facet's margin of an edge, every polygon
//! that may hold it is tested.
//!
//! Why it is exact: the point where a cell's ray meets the facet's plane (in f32) and
//! the point where the same ray meets a member's own plane (the member's own f32 test)
//! differ by the members' tilt off the facet's plane, seen along the ray, and by f32
//! rounding; from each origin both are bounded (the farthest a member's accepted point
//! lies off the plane over the nearest the plane comes, times the farthest the facet
//! lies; a few dozen ulps of the coordinates and distances, magnified alike). A facet is
//! located only when that bound, plus how far past its edges any member's test reaches,
//! is within half the facet's margin: then a point located in none of the polygons is
//! accepted by none, and one well inside a polygon is accepted by no other. Otherwise
//! (a facet nearly edge-on, or through the origin: the patch's own, say) its polygons
//! are scanned one by one, as [`Hemisphere::scan`] does them. Facets of one polygon are
//! scanned as the scan does them, nearest first too.
//!
//! Single rays (improved estimation's, boundary lists') go through a [`Hierarchy`];
//! [`FacetRays`] casts single rays at the cost of the facets too (rendering's).

use crate::scan::{
    cannot_hit_near_plane, edge_reach, padded_corners, region_of, Region, ScanOrigin,
};
use crate::{
    Caster, Hemisphere, Hierarchy, HierarchyScratch, ItemBuffer, NearestHits, ScanScratch,
    Viewpoint,
};
use glam::DVec3;
use rad_core::{prefetch, Hit, PolygonId, Ray, Vec3};
use rad_geometry::{Facets, LocateScratch, Located, Polygon, PolygonTerms, Scene, Shape};

mod rays;
pub use rays::{FacetRays, FacetRaysScratch, BIN_RAYS_PER_FACET, MIN_BIN_RAYS};

/// The facet scan (see the module's text), made for one scene.
#[derive(Clone, Debug)]
pub struct FacetScan {
    /// By facet: a sphere holding it (centre, radius), for the nearest-first order.
    spheres: Vec<(DVec3, f64)>,
    /// By facet: its piece in `pieces` (facets of several polygons), else `NONE`.
    piece_of: Vec<u32>,
    pieces: Vec<Piece>,
    /// The scene's facets, with margins for exact casting ([`Facets::exact`]).
    facets: Facets,
    /// By polygon: what its hit test reads, together.
    members: Vec<Member>,
    /// By polygon: its plane (normal, d), and whether it is front-only (empty if none
    /// is): all a hit well inside it needs.
    planes: Vec<(Vec3, f32)>,
    front_only: Vec<bool>,
    /// By polygon, a bit: whether its f32 plane is its facet's, to the bit (so that the
    /// t a ray's point is located at is its own test's).
    same_plane: Vec<u64>,
    /// Single rays.
    rays: Hierarchy,
    polygons: usize,
}

/// A polygon's hit-test terms and inside test, in two cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Member {
    terms: PolygonTerms,
    shape: Shape,
    /// Its reach, for a front-only polygon ([`OriginTerms::front_only`]); else NaN.
    front_only: f32,
}

const NONE: u32 = u32::MAX;

/// What the scan needs of a facet of several polygons (all in f64).
#[derive(Clone, Debug)]
struct Piece {
    /// A rectangle of the facet's plane (world corners, in order) whose points, moved
    /// off the plane by at most `off`, hold every point any member's test accepts.
    corners: [DVec3; 4],
    /// The largest angle (radians) between a member's normal and the plane's.
    tilt: f64,
    /// The same for the members' vertices alone (unpadded), and their least reach.
    vertex_corners: [DVec3; 4],
    least_reach: f64,
    /// The plane n·p = d with |n| = 1 (the facet's f32 plane).
    n: DVec3,
    d: f64,
    off: f64,
    /// How far past its edges any member's test reaches ([`edge_reach`]).
    reach: f64,
    /// The facet's margin ([`Facets::margin`]).
    margin: f64,
    /// The largest coordinate of the corners.
    magnitude: f64,
}

/// Work counts of [`FacetScan`], summed over calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FacetScanStats {
    pub hemispheres: u64,
    /// Facets of several polygons located cell by cell.
    pub located: u64,
    /// Facets of several polygons scanned polygon by polygon (edge-on or too near).
    pub one_by_one: u64,
    /// Their polygons.
    pub one_by_one_polygons: u64,
    /// Cells located, and of those the rays that may meet the facet near enough.
    pub cells: u64,
    pub cells_near: u64,
    /// Hemispheres scanned plainly (some ring's rays do not all leave the plane
    /// forwards).
    pub plain: u64,
    /// Cells given the facet plane's t as located ([`FacetScan`]'s shortcut for a
    /// member whose f32 plane is the facet's).
    pub direct: u64,
}

/// Per-thread working memory of [`FacetScan`].
#[derive(Clone, Debug, Default)]
pub struct FacetScanScratch {
    scan: ScanScratch,
    rays: HierarchyScratch,
    order: Vec<(f64, u32)>,
    /// The members of a facet scanned one by one.
    near: Vec<PolygonId>,
    /// By polygon: the hemisphere its `behind` was made for.
    made: Vec<u32>,
    behind: Vec<bool>,
    stamp: u32,
    nearer: Vec<f32>,
    located: Vec<Located>,
    locate: LocateScratch,
    /// Cells by an edge, and the polygons to test on them.
    pending: Vec<(u32, PolygonId, bool)>,
    pub stats: FacetScanStats,
}

impl FacetScanScratch {
    /// The work counts of the underlying scan.
    pub fn scan_stats(&self) -> crate::ScanStats {
        self.scan.stats
    }
}

/// Half the f32 epsilon.
const ULP: f64 = f32::EPSILON as f64 * 0.5;

/// By facet: its piece's index (facets of several polygons) or `NONE`; and the pieces.
fn pieces_of(facets: &Facets, polygons: &[Polygon]) -> (Vec<u32>, Vec<Piece>) {
    let mut pieces = Vec::new();
    let piece_of = (0..facets.len() as u32)
        .map(|f| {
            if facets.polygons(f).len() == 1 {
                NONE
            } else {
                pieces.push(Piece::of(facets, f, polygons));
                pieces.len() as u32 - 1
            }
        })
        .collect();
    (piece_of, pieces)
}

impl FacetScan {
    /// The facet scan of `scene` (its facets, [`Scene::facets`], and a [`Hierarchy`]
    /// for single rays).
    pub fn new(scene: &Scene) -> FacetScan {
        let facets = Facets::exact(scene);
        let polygons = scene.polygons();
        let mut out = FacetScan {
            spheres: Vec::with_capacity(facets.len()),
            piece_of: Vec::new(),
            pieces: Vec::new(),
            facets: Facets::default(),
            members: polygons
                .iter()
                .map(|p| Member {
                    terms: p.terms(),
                    shape: Shape::of(p),
                    front_only: if p.front_only() { p.reach() } else { f32::NAN },
                })
                .collect(),
            planes: polygons
                .iter()
                .map(|p| (p.terms().normal, p.terms().plane_d))
                .collect(),
            front_only: if scene.has_front_only() {
                polygons.iter().map(|p| p.front_only()).collect()
            } else {
                Vec::new()
            },
            same_plane: vec![0; polygons.len().div_ceil(64)],
            rays: Hierarchy::new(scene),
            polygons: polygons.len(),
        };
        for f in 0..facets.len() as u32 {
            let members = facets.polygons(f);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            let mut reach = 0.0f64;
            for &p in members {
                let poly = &polygons[p as usize];
                for v in poly.vertices() {
                    (lo, hi) = (lo.min(v.as_dvec3()), hi.max(v.as_dvec3()));
                }
                reach = reach.max(poly.reach() as f64);
            }
            out.spheres
                .push((0.5 * (lo + hi), 0.5 * (hi - lo).length() + 2.0 * reach));
            let (n, d) = facets.plane(f);
            for &p in members {
                let terms = polygons[p as usize].terms();
                let bits = |n: Vec3, d: f32| (n.to_array().map(f32::to_bits), d.to_bits());
                if bits(terms.normal, terms.plane_d) == bits(n, d) {
                    out.same_plane[p as usize / 64] |= 1 << (p % 64);
                }
            }
        }
        (out.piece_of, out.pieces) = pieces_of(&facets, polygons);
        out.facets = facets;
        out
    }

    /// How many facets the scene has (what this caster's cost follows).
    pub fn facet_count(&self) -> usize {
        self.spheres.len()
    }

    fn check(&self, scene: &Scene) {
        assert_eq!(
            scene.polygons().len(),
            self.polygons,
            "a FacetScan is used with the scene it was built for"
        );
    }

    /// The exact item buffer of the hemisphere `hemi` at `from` (see the module's text).
    pub fn scan_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        from: Viewpoint,
        s: &mut FacetScanScratch,
        buf: &mut ItemBuffer,
    ) {
        self.check(scene);
        s.stats.hemispheres += 1;
        let mut at = hemi.scan_begin(scene, from, &mut s.scan);
        if !Hemisphere::scan_all_forward(&s.scan) {
            // The grid culls polygons behind the plane ring by ring: scan plainly.
            s.stats.plain += 1;
            s.scan.stats.hemispheres -= 1;
            hemi.scan_at(scene, from, &mut s.scan, buf);
            return;
        }
        let tests_before = s.scan.hits.tests;
        let polygons = scene.polygons();
        let facets = &self.facets;
        if s.made.len() != polygons.len() || s.stamp == u32::MAX {
            s.made.clear();
            s.made.resize(polygons.len(), 0);
            s.behind.resize(polygons.len(), false);
            s.stamp = 0;
        }
        s.stamp += 1;
        // Nearest first, so that far facets find most cells already nearer.
        s.order.clear();
        s.order.extend(
            self.spheres
                .iter()
                .enumerate()
                .map(|(f, &(c, r))| ((c - at.o64).length() - r, f as u32)),
        );
        s.order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let order = std::mem::take(&mut s.order);
        for &(_, f) in &order {
            let members = facets.polygons(f);
            let piece = self.piece_of[f as usize];
            if piece == NONE {
                if members[0] != at.own {
                    let poly = &polygons[members[0] as usize];
                    hemi.scan_polygon::<true>(&mut at, poly, members[0], None, &mut s.scan, |_| {});
                }
                continue;
            }
            let piece = &self.pieces[piece as usize];
            if !piece.locate(facets, f, self, hemi, &mut at, scene, s) {
                s.stats.one_by_one += 1;
                // Through (or nearly through) the origin (the patch's own facet, say):
                // only members near the origin's foot can be hit, and of those most are
                // proved unseen before any box is made.
                let mut list = std::mem::take(&mut s.near);
                list.clear();
                let near = piece.stray(at.o64).is_none();
                match near.then(|| piece.near_radius(&mut at, hemi)).flatten() {
                    Some(r) => {
                        self.facets
                            .for_each_near(f, at.o, r as f32, |p| list.push(p));
                        list.sort_unstable();
                        list.dedup();
                    }
                    None => list.extend_from_slice(members),
                }
                s.stats.one_by_one_polygons += list.len() as u64;
                for &p in &list {
                    if p != at.own {
                        let poly = &polygons[p as usize];
                        if near {
                            let min_cos = at.min_cos(hemi);
                            if cannot_hit_near_plane(poly, &poly.terms_at(at.o), at.own_n, min_cos)
                            {
                                s.scan.stats.coplanar_skips += 1;
                                continue;
                            }
                        }
                        hemi.scan_polygon::<true>(&mut at, poly, p, None, &mut s.scan, |_| {});
                    }
                }
                s.near = list;
            } else {
                s.stats.located += 1;
            }
        }
        s.order = order;
        s.scan.stats.tests += s.scan.hits.tests - tests_before;
        hemi.scan_finish(scene, &at, &s.scan.hits, buf);
    }
}

impl Piece {
    /// Facet `f`'s piece (of several polygons).
    fn of(facets: &Facets, f: u32, polygons: &[Polygon]) -> Piece {
        let (n32, d32) = facets.plane(f);
        let n = n32.as_dvec3();
        let len = n.length();
        let (n, d) = (n / len, d32 as f64 / len);
        let a0 = n.any_orthonormal_vector();
        let a1 = n.cross(a0);
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let (mut off, mut reach) = (0.0f64, 0.0f64);
        let (mut vlo, mut vhi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut least_reach = f64::INFINITY;
        let mut tilt = 0.0f64;
        for &p in facets.polygons(f) {
            let poly = &polygons[p as usize];
            least_reach = least_reach.min(poly.reach() as f64);
            for v in poly.vertices() {
                let (x, y) = (v.as_dvec3().dot(a0), v.as_dvec3().dot(a1));
                (vlo[0], vhi[0]) = (vlo[0].min(x), vhi[0].max(x));
                (vlo[1], vhi[1]) = (vlo[1].min(y), vhi[1].max(y));
                off = off.max((n.dot(v.as_dvec3()) - d).abs());
            }
            for c in padded_corners(poly) {
                let (x, y) = (c.dot(a0), c.dot(a1));
                (lo[0], hi[0]) = (lo[0].min(x), hi[0].max(x));
                (lo[1], hi[1]) = (lo[1].min(y), hi[1].max(y));
                off = off.max((n.dot(c) - d).abs());
            }
            let np = poly.normal().as_dvec3().normalize();
            tilt = tilt.max(np.cross(n).length().asin() + 1e-12);
            let vs: Vec<DVec3> = poly.vertices().iter().map(|v| v.as_dvec3()).collect();
            reach = reach.max(edge_reach(poly, &vs));
        }
        let rectangle = |lo: [f64; 2], hi: [f64; 2]| {
            [
                (lo[0], lo[1]),
                (hi[0], lo[1]),
                (hi[0], hi[1]),
                (lo[0], hi[1]),
            ]
            .map(|(x, y)| n * d + a0 * x + a1 * y)
        };
        let (corners, vertex_corners) = (rectangle(lo, hi), rectangle(vlo, vhi));
        let magnitude = corners
            .iter()
            .map(|c| c.abs().max_element())
            .fold(0.0, f64::max);
        Piece {
            corners,
            tilt,
            vertex_corners,
            least_reach,
            n,
            d,
            // (The corners' own f64 rounding, far below f32's.)
            off: off + 1e-12 * magnitude,
            reach,
            margin: facets.margin(f) as f64,
            magnitude,
        }
    }

    /// From `o`, how far (world units) the point where a ray meets the facet's plane
    /// may lie from where it meets a member's own (both in f32), for rays meeting the
    /// plane at a cosine of at least μ: `base / μ + flat`; and the least μ of a ray that
    /// can meet the facet. None where the facet is nearly edge-on (see the module's
    /// text).
    fn stray(&self, o: DVec3) -> Option<Stray> {
        let h = (self.n.dot(o) - self.d).abs() - self.off;
        let far = self
            .corners
            .iter()
            .map(|c| (*c - o).length())
            .fold(0.0, f64::max)
            + self.off;
        let size = o.abs().max_element() + self.magnitude + far;
        let flat = 32.0 * ULP * size;
        // (At a cosine of 1e-4, t's f32 rounding is still within 2e-3 of it; and an
        // origin within a few roundings of the plane may see its f32 side wrong, as for
        // a small facet far from the coordinates' origin.)
        if h <= 2e-4 * far || h <= 4.0 * flat {
            return None;
        }
        let stray = Stray {
            base: self.off + flat,
            flat,
            mu_min: h / (2.0 * far),
            mu_located: 0.0,
        };
        // Rays at a cosine of at least `mu_located` are located; the others (grazing)
        // have their candidates sought around the point.
        let room = self.margin - self.reach - flat;
        let mu_located = if room > 0.0 {
            stray.base / room
        } else {
            f64::INFINITY
        };
        Some(Stray {
            mu_located,
            ..stray
        })
    }

    /// For a facet whose plane passes (nearly) through the origin and faces nearly as
    /// the patch's does (its own, say): how far from the origin's foot on the plane a
    /// member must come to be hit at all (None if the facet is not so). A ray leaving
    /// forwards meets every member's plane at a cosine of at least `d_min` (the
    /// hemisphere's widest angle, the planes' angle and the members' tilt), so within
    /// t_max = |num| / d_min of the origin, if at all; a hit lies within its member's
    /// reach of it; add the members' distance off the plane and rounding.
    fn near_radius(&self, at: &mut ScanOrigin, hemi: &Hemisphere) -> Option<f64> {
        let min_cos = at.min_cos(hemi).clamp(0.0, 1.0);
        let own = at.own_n.normalize();
        let (cos_g, sin_g) = (self.n.dot(own), self.n.cross(own).length());
        let sin_t = (1.0 - min_cos * min_cos).sqrt();
        let d_min = cos_g.abs() * min_cos - sin_g * sin_t - 2.0 * self.tilt - 1e-5;
        if d_min <= 1e-5 {
            return None;
        }
        let o = at.o64;
        let size = o.abs().max_element() + self.magnitude;
        let num =
            (self.n.dot(o) - self.d).abs() + self.off + 16.0 * ULP * (self.d.abs() + 3.0 * size);
        let t_max = 1.01 * num / d_min;
        Some(t_max + self.reach + self.off + 1e-5 * (1.0 + size) + self.margin)
    }

    /// Resolves facet `f` on every cell of its angular box from `at`, by its grid (see
    /// the module's text); false (nothing done) where it cannot be located exactly.
    #[allow(clippy::too_many_arguments)]
    fn locate(
        &self,
        facets: &Facets,
        f: u32,
        all: &FacetScan,
        hemi: &Hemisphere,
        at: &mut ScanOrigin,
        scene: &Scene,
        s: &mut FacetScanScratch,
    ) -> bool {
        let Some(stray) = self.stray(at.o64) else {
            return false;
        };
        // The widest search about a grazing ray's point: a few grid cells at most.
        let cell = facets.cell_size(f) as f64;
        if stray.at(stray.mu_min) + self.margin > 4.0 * cell {
            return false;
        }
        let members = facets.polygons(f);
        if members.contains(&at.own) {
            return false;
        }
        let (n32, d32) = facets.plane(f);
        let num = d32 - n32.dot(at.o);
        if num == 0.0 || num.is_nan() {
            return false;
        }
        let gap = (self.n.dot(at.o64) - self.d).abs();
        // The nearest any point of the facet's rectangle lies (less its members' offset).
        let dmin = {
            let [c0, c1, _, c3] = self.corners;
            let (e1, e2, p) = (c1 - c0, c3 - c0, at.o64 - c0);
            let s1 = (p.dot(e1) / e1.length_squared()).clamp(0.0, 1.0);
            let s2 = (p.dot(e2) / e2.length_squared()).clamp(0.0, 1.0);
            let q = c0 + e1 * s1 + e2 * s2;
            (((at.o64 - q).length() - self.off) * (1.0 - 1e-5)) as f32
        };
        let (theta, phi) = match region_of(
            &self.corners,
            self.corners[0],
            gap,
            at.o64,
            num,
            at.frame,
            self.off,
        ) {
            Region::None => return true,
            Region::All => return false,
            Region::Box { theta, phi } => (theta, phi),
        };
        let np = hemi.n_phi();
        let spans = phi.and_then(|(lo, hi)| hemi.phi_spans(lo, hi));
        for i in hemi.rings(theta.0, theta.1) {
            let ring = i * np;
            let pieces = match spans {
                None => [(ring, ring + np), (0, 0)],
                Some([(a, b), (c, d)]) => [(ring + a, ring + b), (ring + c, ring + d)],
            };
            for (a, b) in pieces {
                if b > a {
                    self.locate_cells(facets, f, all, a..b, stray, dmin, at, scene, s);
                }
            }
        }
        true
    }

    /// [`Piece::locate`] on cells `cells`.
    #[allow(clippy::too_many_arguments)]
    fn locate_cells(
        &self,
        facets: &Facets,
        f: u32,
        all: &FacetScan,
        cells: std::ops::Range<usize>,
        stray: Stray,
        dmin: f32,
        at: &ScanOrigin,
        scene: &Scene,
        s: &mut FacetScanScratch,
    ) {
        let FacetScanScratch {
            stats,
            scan,
            made,
            behind,
            stamp,
            nearer,
            located,
            locate,
            pending,
            ..
        } = s;
        let hits = &mut scan.hits;
        // A member met no farther than the nearest hit may win (or tie); its t and the
        // plane's differ by the stray seen along the ray at most (well within this, for
        // the located rays).
        let slack = (4.0 * self.margin) as f32;
        nearer.clear();
        nearer.extend(
            hits.best_t()[cells.clone()]
                .iter()
                .map(|&t| t + (t * 1e-3 + slack)),
        );
        let o = at.o;
        let (n32, d32) = facets.plane(f);
        let num = d32 - n32.dot(o);
        // Members may lie wholly behind the patch's plane (which the grid culls: every
        // ring is forwards) only if some vertex may lie behind it by their reach.
        let cull = self
            .vertex_corners
            .iter()
            .any(|c| (*c - at.o64).dot(at.own_n) < 2.0 * self.off - self.least_reach);
        let up = at.own_n.normalize().as_vec3();
        let mut tests = Tests {
            all,
            polygons: scene.polygons(),
            at,
            cull,
            up,
            // A point located well inside a member this far in front of the patch's
            // plane is the member's within its distance off the facet's plane, the
            // margin and the stray: so some vertex lies in front, and the member is not
            // wholly behind.
            sure: (self.off + 3.0 * self.margin) as f32,
            made,
            behind,
            stamp: *stamp,
        };
        let mu_located = stray.mu_located as f32;
        // Runs of cells whose nearest hit so far may be beyond the facet (the rest see
        // something nearer than any point of it), each located in one pass.
        let first = cells.start;
        let mut k = 0;
        while k < nearer.len() {
            if nearer[k] < dmin {
                k += 1;
                continue;
            }
            let a = k;
            while k < nearer.len() && nearer[k] >= dmin {
                k += 1;
            }
            let run = first + a..first + k;
            stats.cells += run.len() as u64;
            // (Rays meeting the plane at a slant are left to `graze`.)
            facets.locate_span_steep(
                f,
                o,
                hits.directions_of(run.clone()),
                &nearer[a..k],
                mu_located,
                located,
                locate,
            );
            for (c, &l) in run.zip(located.iter()) {
                if l == Located::Outside {
                    continue;
                }
                let dir = hits.direction(c);
                stats.cells_near += 1;
                match l {
                    Located::Clear(p, t) => {
                        stats.direct += u64::from(tests.clear(hits, p, c, t, dir));
                    }
                    _ => {
                        // (Tested below, their terms fetched meanwhile.)
                        let t = num / n32.dot(dir);
                        let front = tests.surely_front(t, dir);
                        facets.for_each_holding(f, o, dir, |p| {
                            prefetch(&all.members[p as usize]);
                            pending.push((c as u32, p, front));
                        });
                    }
                }
            }
            // (Ties go to the lower id whatever the order of the tests.)
            for (c, p, front) in pending.drain(..) {
                tests.test(hits, p, c as usize, false, front);
            }
        }
        if stray.mu_located > stray.mu_min {
            self.graze(facets, f, cells, stray, &mut tests, hits);
        }
    }

    /// The grazing rays of `cells` (met by the plane at a cosine under
    /// `stray.mu_located`): every polygon within the stray (and the margin) of the ray's
    /// point, if it may be near enough.
    fn graze(
        &self,
        facets: &Facets,
        f: u32,
        cells: std::ops::Range<usize>,
        stray: Stray,
        tests: &mut Tests,
        hits: &mut NearestHits,
    ) {
        let o = tests.at.o;
        let (n32, d32) = facets.plane(f);
        let num = d32 - n32.dot(o);
        let (mu_located, mu_min) = (stray.mu_located as f32, stray.mu_min as f32);
        for c in cells {
            let dir = hits.direction(c);
            let cos = n32.dot(dir).abs();
            if cos < mu_located && cos >= mu_min {
                let reach = stray.at(cos as f64);
                let t = num / n32.dot(dir);
                let best = hits.best_t()[c];
                if t > 0.0 && (t as f64) <= best as f64 * (1.0 + 1e-3) + 2.0 * reach {
                    let r = (reach + self.margin) as f32;
                    let front = !tests.cull;
                    facets.for_each_within(f, o, dir, r, |p| tests.test(hits, p, c, false, front));
                }
            }
            // (Else the ray meets the plane beyond twice the facet's farthest point: so
            // do the members' own, within their rounding.)
        }
    }
}

/// Testing a facet's members from one origin.
struct Tests<'a> {
    all: &'a FacetScan,
    polygons: &'a [Polygon],
    at: &'a ScanOrigin,
    /// Whether some member may lie wholly behind the patch's plane.
    cull: bool,
    /// The patch's unit normal, and how far in front of its plane a point located in a
    /// member proves it not wholly behind.
    up: Vec3,
    sure: f32,
    /// By polygon: the hemisphere (`stamp`) its `behind` was made for.
    made: &'a mut [u32],
    behind: &'a mut [bool],
    stamp: u32,
}

impl Tests<'_> {
    /// [`Tests::test`] for a ray located well inside polygon `p` at the facet plane's
    /// `t` along `dir`: where `p`'s plane is the facet's to the bit, `t` is its own
    /// test's, and where that point lies well in front of the patch's plane, `p` is
    /// not wholly behind it; so `t` is offered as it stands.
    /// True where `t` was offered as it stands.
    #[inline]
    fn clear(&mut self, hits: &mut NearestHits, p: PolygonId, c: usize, t: f32, dir: Vec3) -> bool {
        let k = p as usize;
        let same = self.all.same_plane[k / 64] & (1 << (k % 64)) != 0;
        let front = self.surely_front(t, dir);
        if !same || p == self.at.own || self.all.front_only.get(k) == Some(&true) || !front {
            self.test(hits, p, c, true, front);
            return false;
        }
        hits.offer(c, p, t, 0.0, 0.0);
        true
    }

    /// Whether a member within the margin of the point at the facet plane's `t` along
    /// `dir` is surely not wholly behind the patch's plane (or none may be).
    #[inline]
    fn surely_front(&self, t: f32, dir: Vec3) -> bool {
        !self.cull || t * (dir.dot(self.up) - 1e-5) > self.sure
    }

    /// Polygon `p`'s test on cell `c`, as the grid's (the own polygon, and those wholly
    /// behind the plane, never): with `clear`, `p` holds the ray's point well inside
    /// (and no other polygon comes within its reach), so its test accepts whatever the
    /// ray's (u, v) (which a polygon of one patch does not need), and its t alone, by the
    /// very sums of its test, is offered.
    #[inline]
    fn test(&mut self, hits: &mut NearestHits, p: PolygonId, c: usize, clear: bool, front: bool) {
        let (at, all, polygons) = (self.at, self.all, self.polygons);
        if p == at.own {
            return;
        }
        let k = p as usize;
        if !front {
            if self.made[k] != self.stamp {
                self.made[k] = self.stamp;
                self.behind[k] = polygons[k].wholly_behind(at.o64, at.own_n);
            }
            // (The grid culls polygons wholly behind the plane: every ring is forwards.)
            if self.behind[k] {
                return;
            }
        }
        if clear && all.front_only.get(k) != Some(&true) {
            let (n, d) = all.planes[k];
            let num = d - n.dot(at.o);
            let [x, y, z] = hits.direction(c).to_array();
            let t = num / ((n.x * x + n.y * y) + n.z * z);
            hits.offer(c, p, t, 0.0, 0.0);
            return;
        }
        let m = &all.members[k];
        let mut h = m.terms.at(at.o);
        if !m.front_only.is_nan() {
            h = h.front_only(m.front_only);
        }
        hits.test_cell_shaped(&m.shape, || &polygons[k], p, &h, c);
    }
}

/// How far a ray's point in a facet's plane may stray from a member's ([`Piece::stray`]).
#[derive(Clone, Copy, Debug)]
struct Stray {
    base: f64,
    flat: f64,
    /// The least cosine of a ray that can meet the facet.
    mu_min: f64,
    /// The least cosine of a ray located by the grid alone.
    mu_located: f64,
}

impl Stray {
    /// The stray of a ray meeting the plane at a cosine of `mu`.
    fn at(&self, mu: f64) -> f64 {
        self.base / mu + self.flat
    }
}

impl Caster for FacetScan {
    type Scratch = FacetScanScratch;

    fn scratch(&self) -> FacetScanScratch {
        FacetScanScratch::default()
    }

    fn item_buffer_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        at: Viewpoint,
        scratch: &mut FacetScanScratch,
        buf: &mut ItemBuffer,
    ) {
        self.scan_at(scene, hemi, at, scratch, buf)
    }

    fn closest_hits(
        &self,
        scene: &Scene,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut FacetScanScratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        self.rays
            .closest_hits(scene, origin, skip, dirs, &mut scratch.rays, out)
    }

    fn all_hits_along(
        &self,
        scene: &Scene,
        ray: &Ray,
        scratch: &mut FacetScanScratch,
        out: &mut Vec<Hit>,
    ) {
        self.rays.all_hits_along(scene, ray, &mut scratch.rays, out)
    }
}
