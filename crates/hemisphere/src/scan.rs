//! Exact item buffers by scanning polygons over the hemisphere's cells instead of
//! walking rays through a grid.
//!
//! Every ray of a hemisphere leaves the same point. So rather than take each ray and
//! look for the polygon it meets first (ray-major, through a voxel grid), take each
//! polygon, bound the cells whose rays can meet it (an angular box from its corners as
//! seen from the origin, with margins for f32 rounding), and run the very ray–polygon
//! test of [`rad_accel`'s grid](Hemisphere::cast) on those cells, keeping the nearest
//! hit per cell (polygon-major, like a z-buffer, but with one exact ray per cell). This
//! is the light buffer of Haines and Greenberg (1986) turned inside out.
//!
//! The result is the grid's, cell for cell and bit for bit: the same f32 arithmetic per
//! (cell, polygon) pair, the same culling of polygons behind the patch's plane, and the
//! same rule for ties (the lower polygon id wins). The bounds only decide which pairs
//! are tested; they are conservative, and a polygon whose box could be unreliable (its
//! plane passes within rounding of the origin) is tested on every cell.

use crate::item_buffer::{ItemBuffer, Viewpoint};
use crate::Hemisphere;
use glam::{DVec3, Vec3};
use rad_core::{with_isa, Hit, Isa, PatchId, PolygonId, BACK, ESCAPED, NO_POLYGON};
use rad_geometry::{OriginTerms, Polygon, Scene, Shape, Triangle, SEVERAL};
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::ops::Range;

/// The nearest hit of every cell's ray of one hemisphere, against polygons tested on
/// chosen cells: the voxel grid's ray–polygon test, term for term (so the same bits),
/// run over spans of cells (vectorised), keeping per cell the nearest hit, ties to the
/// polygon tested first. [`Hemisphere::scan`] tests each polygon on its angular box;
/// the improved estimator tests the polygons guessed around each cell.
#[derive(Clone, Debug, Default)]
pub struct NearestHits {
    /// The frame and normal (bits) `dx, dy, dz` and `forward` are for, and the
    /// hemisphere (N_θ, N_φ, φ shift) they were made with.
    dirs_for: Option<([u32; 12], usize, usize, u64)>,
    /// Local directions, by component (for the hemisphere in `dirs_for`).
    lx: Vec<f32>,
    ly: Vec<f32>,
    lz: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
    dz: Vec<f32>,
    /// Per ring: every direction leaves the polygon's plane forwards (as the grid checks
    /// it for each ring's query).
    forward: Vec<bool>,
    best_t: Vec<f32>,
    best_p: Vec<u32>,
    best_u: Vec<f32>,
    best_v: Vec<f32>,
    /// Cells of a span that passed the vectorised part of a test (for the scalar rest).
    mask: Vec<u8>,
    /// (cell, polygon) tests so far.
    pub tests: u64,
}

/// Per-thread working memory of [`Hemisphere::scan`].
#[derive(Clone, Debug, Default)]
pub struct ScanScratch {
    pub(crate) hits: NearestHits,
    /// For single rays ([`crate::Caster::closest_hits`]).
    pub(crate) rays: NearestHits,
    /// Work counts so far.
    pub stats: ScanStats,
}

/// Work counts of [`Hemisphere::scan`], summed over calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanStats {
    pub hemispheres: u64,
    /// (cell, polygon) pairs tested.
    pub tests: u64,
    /// Polygons tested on every cell (no reliable angular box).
    pub full: u64,
    /// Polygons whose plane passes within rounding of the origin but that no cell's
    /// ray can hit (`cannot_hit_near_plane`): not tested at all.
    pub coplanar_skips: u64,
}

/// A plane within this many times the rounding slack of the origin gives no reliable
/// angular box (its margin, 4 slack / distance, would pass 0.4 rad).
const NEAR_PLANE: f64 = 10.0;

/// Cells whose ray may meet a polygon.
#[derive(Debug, PartialEq)]
pub(crate) enum Region {
    None,
    All,
    /// θ in [lo, hi]; φ in [lo, hi] (unwrapped, may leave [0, 2π)) or every φ.
    Box {
        theta: (f64, f64),
        phi: Option<(f64, f64)>,
    },
}

/// What scanning one hemisphere knows of its origin: the patch centre, its polygon,
/// normal and frame.
pub(crate) struct ScanOrigin {
    pub o: Vec3,
    pub o64: DVec3,
    pub own: PolygonId,
    pub own_n: DVec3,
    /// The patch's local frame `[t, b, n]`.
    pub frame: [DVec3; 3],
    /// The lowest cosθ of any cell's direction, once needed.
    min_cos: Option<f64>,
}

impl Hemisphere {
    /// The item buffer of `patch`, exactly as [`Hemisphere::cast`] through a
    /// [`rad_core::RayCast`] gives it (same patch, same distance, to the bit), computed
    /// polygon by polygon (see the module documentation).
    pub fn scan(
        &self,
        scene: &Scene,
        patch: PatchId,
        scratch: &mut ScanScratch,
        buf: &mut ItemBuffer,
    ) {
        self.scan_at(scene, Viewpoint::of_patch(scene, patch), scratch, buf)
    }

    /// [`Hemisphere::scan`] from any point of a polygon.
    pub fn scan_at(
        &self,
        scene: &Scene,
        from: Viewpoint,
        scratch: &mut ScanScratch,
        buf: &mut ItemBuffer,
    ) {
        let mut at = self.scan_begin(scene, from, scratch);
        let tests_before = scratch.hits.tests;
        for (id, poly) in scene.polygons().iter().enumerate() {
            if id != at.own as usize {
                self.scan_polygon::<false>(&mut at, poly, id as PolygonId, None, scratch, |_| {});
            }
        }
        scratch.stats.tests += scratch.hits.tests - tests_before;
        self.scan_finish(scene, &at, &scratch.hits, buf);
    }

    /// Starts scanning the hemisphere at `from`: no hits yet, the cells' directions in
    /// its polygon's frame.
    pub(crate) fn scan_begin(
        &self,
        scene: &Scene,
        from: Viewpoint,
        s: &mut ScanScratch,
    ) -> ScanOrigin {
        let own = from.polygon;
        let polygon = &scene.polygons()[own as usize];
        s.hits.begin(self, scene, own);
        s.stats.hemispheres += 1;
        let frame = polygon.frame();
        ScanOrigin {
            o: from.point,
            o64: from.point.as_dvec3(),
            own,
            own_n: polygon.normal().as_dvec3(),
            frame: [frame.t, frame.b, frame.n].map(Vec3::as_dvec3),
            min_cos: None,
        }
    }

    /// Whether every ring's rays leave the patch's plane forwards (so that polygons
    /// wholly behind it are never tested: the grid's culling).
    pub(crate) fn scan_all_forward(s: &ScanScratch) -> bool {
        s.hits.forward.iter().all(|&f| f)
    }

    /// Tests polygon `id` (= `poly`, not the patch's own) on every cell whose ray may
    /// meet it, as the grid would, keeping the nearest hits; `span` is told each run of
    /// cells tested. With `ANY_ORDER`, ties in t go to the lower id whatever the order
    /// polygons come in; otherwise to the polygon tested first (polygons in increasing
    /// id give the same).
    pub(crate) fn scan_polygon<const ANY_ORDER: bool>(
        &self,
        at: &mut ScanOrigin,
        poly: &Polygon,
        id: PolygonId,
        padded: Option<&[DVec3; 4]>,
        s: &mut ScanScratch,
        mut span: impl FnMut(Range<usize>),
    ) {
        let mut test = |s: &mut ScanScratch, terms: &OriginTerms, cells: Range<usize>| {
            span(cells.clone());
            s.hits.test_with::<ANY_ORDER>(poly, id, terms, cells);
        };
        let terms = poly.terms_at(at.o);
        // The grid's culling, ring by ring as it queries them: a polygon wholly
        // behind the plane by more than its reach is skipped in every ring whose
        // rays all leave the plane forwards. (It should have no hits there; skipping
        // exactly where the grid does keeps the bits the grid's even if it had.)
        if poly.wholly_behind(at.o64, at.own_n) {
            let np = self.n_phi();
            for ring in 0..self.n_theta() {
                if !s.hits.forward[ring] {
                    test(s, &terms, ring * np..(ring + 1) * np);
                }
            }
            return;
        }
        let num = terms.num;
        // t = num / (n·d) > 0: front hits (n·d < 0) need num < 0, back hits num > 0,
        // and num = 0 gives none.
        if num == 0.0 || num.is_nan() {
            return;
        }
        let own_corners;
        let padded = match padded {
            Some(p) => p,
            None => {
                own_corners = padded_corners(poly);
                &own_corners
            }
        };
        match region(poly, at.o64, num, at.frame, padded) {
            Region::None => {}
            Region::All => {
                // (The lowest cosθ of any cell's direction, for the test below.)
                let min_cos = *at.min_cos.get_or_insert_with(|| self.min_cell_cos());
                if cannot_hit_near_plane(poly, &terms, at.own_n, min_cos) {
                    s.stats.coplanar_skips += 1;
                    return;
                }
                s.stats.full += 1;
                test(s, &terms, 0..self.n_cells());
            }
            Region::Box { theta, phi } => {
                let np = self.n_phi();
                let spans = phi.and_then(|(lo, hi)| self.phi_spans(lo, hi));
                for i in self.rings(theta.0, theta.1) {
                    let ring = i * np;
                    match spans {
                        None => test(s, &terms, ring..ring + np),
                        Some(spans) => {
                            for (a, b) in spans {
                                if b > a {
                                    test(s, &terms, ring + a..ring + b);
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// The rings whose θ bands meet [`lo`, `hi`] (θ ≥ 0).
    pub(crate) fn rings(&self, lo: f64, hi: f64) -> std::ops::RangeInclusive<usize> {
        let (nt, d_theta) = (self.n_theta(), self.d_theta());
        let i0 = (lo / d_theta).floor().max(0.0) as usize;
        let i1 = ((hi / d_theta).floor().max(0.0) as usize).min(nt - 1);
        i0..=i1
    }

    /// The sectors of a ring whose φ bands meet [`lo`, `hi`] (unwrapped), as up to two
    /// runs `[a, b)` (the second empty unless the range wraps), or None for all.
    pub(crate) fn phi_spans(&self, lo: f64, hi: f64) -> Option<[(usize, usize); 2]> {
        let (np, d_phi) = (self.n_phi(), self.d_phi());
        let shift = self.config().phi_shift;
        let j0 = (lo / d_phi - shift - 0.5).floor() as i64;
        let j1 = (hi / d_phi - shift - 0.5).ceil() as i64;
        let count = j1 - j0 + 1;
        (count < np as i64).then(|| {
            let a = j0.rem_euclid(np as i64) as usize;
            let count = count as usize;
            if a + count <= np {
                [(a, a + count), (0, 0)]
            } else {
                [(a, np), (0, a + count - np)]
            }
        })
    }

    /// Writes the item buffer of the hits found (see [`NearestHits::items`]).
    pub(crate) fn scan_finish(
        &self,
        scene: &Scene,
        at: &ScanOrigin,
        hits: &NearestHits,
        buf: &mut ItemBuffer,
    ) {
        let n_cells = self.n_cells();
        buf.patch.clear();
        buf.dist.clear();
        buf.patch.reserve(n_cells);
        buf.dist.reserve(n_cells);
        buf.patch.resize(n_cells, 0);
        buf.dist.resize(n_cells, 0.0);
        // Front hits need a negative plane term (see above).
        let (o, seen) = (at.o, scene.seen_terms());
        let front = |p: PolygonId| seen[p as usize].plane_num(o) < 0.0;
        hits.items(scene, front, &mut buf.patch, &mut buf.dist, |_, p, ids| {
            ids.fill(if p == NO_POLYGON { ESCAPED } else { BACK })
        });
    }
}

impl NearestHits {
    /// Starts a hemisphere of `hemi` on polygon `own` of `scene`: no hits yet; the cells'
    /// world directions are made for `own`'s frame (kept while the frame stays the same).
    pub fn begin(&mut self, hemi: &Hemisphere, scene: &Scene, own: PolygonId) {
        hemi.prepare_dirs(&scene.polygons()[own as usize], self);
        let n_cells = hemi.n_cells();
        self.best_t.clear();
        self.best_t.resize(n_cells, f32::INFINITY);
        self.best_p.clear();
        self.best_p.resize(n_cells, NO_POLYGON);
        self.best_u.resize(n_cells, 0.0);
        self.best_v.resize(n_cells, 0.0);
    }

    /// Tests polygon `id` (= `poly`), with its terms for the hemisphere's origin
    /// ([`rad_geometry::PolygonTerms::at`]), on `cells`, keeping the nearer hit
    /// (strictly: a tie keeps the polygon tested first), by the shared hit test
    /// ([`rad_geometry::OriginTerms`], [`Polygon::accepts`]), as the grid does.
    pub fn test(
        &mut self,
        poly: &Polygon,
        id: PolygonId,
        terms: &OriginTerms,
        cells: Range<usize>,
    ) {
        test_span::<false>(poly, id, terms, self, cells.start, cells.end);
    }

    /// [`NearestHits::test`] with ties in t going to the lower polygon id whatever the
    /// order of the calls.
    #[inline]
    pub fn test_any_order(
        &mut self,
        poly: &Polygon,
        id: PolygonId,
        terms: &OriginTerms,
        cells: Range<usize>,
    ) {
        self.test_with::<true>(poly, id, terms, cells);
    }

    /// Offers cell `c` a hit found by other means (polygon `id` at distance `t`, with
    /// its (u, v): any, for a polygon of one patch, whose patch they do not choose),
    /// kept by the rule of [`NearestHits::test_cell`]: nearer, or as near with a lower
    /// id.
    #[inline]
    pub fn offer(&mut self, c: usize, id: PolygonId, t: f32, u: f32, v: f32) {
        let (bt, bp) = (self.best_t[c], self.best_p[c]);
        if (t > 0.0) & ((t < bt) | ((t == bt) & (id < bp) & (t < f32::INFINITY))) {
            (self.best_t[c], self.best_p[c]) = (t, id);
            (self.best_u[c], self.best_v[c]) = (u, v);
        }
    }

    /// [`NearestHits::test`] on the one cell `c`, with ties in t going to the lower
    /// polygon id whatever the order of the calls: the same arithmetic, scalar (for
    /// cells tested one by one).
    #[inline]
    pub fn test_cell(&mut self, poly: &Polygon, id: PolygonId, h: &OriginTerms, c: usize) {
        let (denom, t, u, v, kept) = self.cell_terms(id, h, c);
        if kept && poly.accepts(denom, false, u, v) {
            (self.best_t[c], self.best_p[c]) = (t, id);
            (self.best_u[c], self.best_v[c]) = (u, v);
        }
    }

    /// What [`NearestHits::test_cell`] computes before the inside test: cell `c`'s ray's
    /// (denom, t, u, v) against the polygon `id` of terms `h`, and whether the hit would
    /// be kept were (u, v) inside (in front, nearer by the tie rule, within the bounds).
    #[inline(always)]
    fn cell_terms(
        &mut self,
        id: PolygonId,
        h: &OriginTerms,
        c: usize,
    ) -> (f32, f32, f32, f32, bool) {
        self.tests += 1;
        let (x, y, z) = (self.dx[c], self.dy[c], self.dz[c]);
        let denom = h.denom(x, y, z);
        let t = h.num / denom;
        let (u, v) = h.uv(t, x, y, z);
        let (bt, bp) = (self.best_t[c], self.best_p[c]);
        let nearer = (t < bt) | ((t == bt) & (id < bp) & (t < f32::INFINITY));
        (denom, t, u, v, (t > 0.0) & nearer & h.in_bounds(u, v))
    }

    /// [`NearestHits::test_cell`] with the inside test decided by the polygon's
    /// [`Shape`] (reading `poly` only where the shape does not decide, as
    /// [`Shape::hit_from`] does): the same arithmetic, so the same answer to the bit.
    #[inline]
    pub fn test_cell_shaped<'p>(
        &mut self,
        shape: &Shape,
        poly: impl FnOnce() -> &'p Polygon,
        id: PolygonId,
        h: &OriginTerms,
        c: usize,
    ) {
        let (denom, t, u, v, kept) = self.cell_terms(id, h, c);
        // (Within the bounds, a parallelogram's in_bounds again is true: the same.)
        if kept && shape.accepts(poly, h, denom, u, v) {
            (self.best_t[c], self.best_p[c]) = (t, id);
            (self.best_u[c], self.best_v[c]) = (u, v);
        }
    }

    /// [`NearestHits::test`], or with `ANY_ORDER` the same with ties in t going to the
    /// lower polygon id whatever the order of the calls (so that polygons may come in
    /// any order and the nearest hits are still the grid's).
    #[inline]
    pub(crate) fn test_with<const ANY_ORDER: bool>(
        &mut self,
        poly: &Polygon,
        id: PolygonId,
        terms: &OriginTerms,
        cells: Range<usize>,
    ) {
        test_span::<ANY_ORDER>(poly, id, terms, self, cells.start, cells.end);
    }

    /// [`NearestHits::test_with`] (in any order) on several runs of cells (`shape`:
    /// the polygon's, [`Shape::of`]).
    #[inline]
    pub(crate) fn test_runs(
        &mut self,
        poly: &Polygon,
        id: PolygonId,
        terms: &OriginTerms,
        shape: &Shape,
        runs: &[Range<usize>],
    ) {
        test_runs(poly, id, terms, shape, self, runs);
    }

    /// Every cell's nearest distance so far (∞ where nothing was hit).
    #[inline]
    pub fn best_t(&self) -> &[f32] {
        &self.best_t
    }

    /// Writes the item buffer of the hits so far: every cell's distance (∞ where nothing
    /// was hit), and the patch of each run of cells whose nearest hit is on one polygon
    /// `p` with `front(p)` (looked up together, `Polygon::patches_at`); the other runs
    /// (no hit: `p` is [`NO_POLYGON`]; or a back face) go to `other(cells, p, their ids)`.
    pub fn items(
        &self,
        scene: &Scene,
        front: impl Fn(PolygonId) -> bool,
        patch: &mut [PatchId],
        dist: &mut [f32],
        mut other: impl FnMut(Range<usize>, PolygonId, &mut [PatchId]),
    ) {
        let n = self.best_p.len();
        assert!(patch.len() == n && dist.len() == n, "one entry per cell");
        dist.copy_from_slice(&self.best_t);
        let (polygons, seen) = (scene.polygons(), scene.seen_terms());
        // (The polygon seen 16 cells past a run's start is fetched early: a mesh's are
        // scattered.)
        const AHEAD: usize = 16;
        let mut k = 0;
        while k < n {
            if let Some(&q) = self.best_p.get(k + AHEAD) {
                if let Some(terms) = seen.get(q as usize) {
                    rad_core::prefetch(terms);
                }
            }
            let p = self.best_p[k];
            let mut end = k + 1;
            while end < n && self.best_p[end] == p {
                end += 1;
            }
            if p != NO_POLYGON && front(p) {
                let one = seen[p as usize].patch;
                if one != SEVERAL {
                    patch[k..end].fill(one);
                    k = end;
                    continue;
                }
                polygons[p as usize].patches_at(
                    &self.best_u[k..end],
                    &self.best_v[k..end],
                    &mut patch[k..end],
                );
            } else {
                other(k..end, p, &mut patch[k..end]);
            }
            k = end;
        }
    }

    /// Starts a set of rays with directions `dirs` (cell k is ray k), no hits yet.
    pub fn begin_rays(&mut self, dirs: &[Vec3]) {
        self.dirs_for = None;
        let n = dirs.len();
        for v in [&mut self.dx, &mut self.dy, &mut self.dz] {
            v.clear();
        }
        self.dx.extend(dirs.iter().map(|d| d.x));
        self.dy.extend(dirs.iter().map(|d| d.y));
        self.dz.extend(dirs.iter().map(|d| d.z));
        self.best_t.clear();
        self.best_t.resize(n, f32::INFINITY);
        self.best_p.clear();
        self.best_p.resize(n, NO_POLYGON);
        self.best_u.resize(n, 0.0);
        self.best_v.resize(n, 0.0);
    }

    /// The nearest hits of the rays of [`NearestHits::begin_rays`] (`dirs` their
    /// directions), as [`rad_core::RayCast::closest_hits_from`] answers, into `out`.
    pub(crate) fn hits_into(
        &self,
        polygons: &[Polygon],
        dirs: &[Vec3],
        out: &mut Vec<Option<Hit>>,
    ) {
        out.extend((0..dirs.len()).map(|k| {
            let (polygon, t, u, v) = self.nearest(k);
            (polygon != NO_POLYGON).then(|| Hit {
                polygon,
                u,
                v,
                t,
                front: polygons[polygon as usize].normal().dot(dirs[k]) < 0.0,
            })
        }));
    }

    /// Cell `c`'s nearest hit so far: (polygon or [`NO_POLYGON`], t, u, v).
    #[inline]
    pub fn nearest(&self, c: usize) -> (PolygonId, f32, f32, f32) {
        (
            self.best_p[c],
            self.best_t[c],
            self.best_u[c],
            self.best_v[c],
        )
    }

    /// The world directions of cells `cells`' rays, by component.
    #[inline]
    pub fn directions_of(&self, cells: Range<usize>) -> [&[f32]; 3] {
        [
            &self.dx[cells.clone()],
            &self.dy[cells.clone()],
            &self.dz[cells],
        ]
    }

    /// The world direction of cell `c`'s ray (as [`rad_core::Frame::world_from_local`]
    /// gives it).
    #[inline]
    pub fn direction(&self, c: usize) -> Vec3 {
        Vec3::new(self.dx[c], self.dy[c], self.dz[c])
    }
}

impl Hemisphere {
    /// World directions of the cells for `poly`'s frame, unless already there.
    fn prepare_dirs(&self, poly: &Polygon, s: &mut NearestHits) {
        let f = poly.frame();
        let mut frame = [0u32; 12];
        for (k, v) in [f.t, f.b, f.n, poly.normal()].iter().enumerate() {
            frame[3 * k..3 * k + 3].copy_from_slice(&v.to_array().map(f32::to_bits));
        }
        let key = (
            frame,
            self.n_theta(),
            self.n_phi(),
            self.config().phi_shift.to_bits(),
        );
        if s.dirs_for == Some(key) {
            return;
        }
        if s.dirs_for.map(|k| (k.1, k.2, k.3)) != Some((key.1, key.2, key.3)) {
            s.lx = self.directions().iter().map(|d| d.x).collect();
            s.ly = self.directions().iter().map(|d| d.y).collect();
            s.lz = self.directions().iter().map(|d| d.z).collect();
        }
        let n_cells = self.n_cells();
        for v in [&mut s.dx, &mut s.dy, &mut s.dz] {
            v.resize(n_cells, 0.0);
        }
        s.forward.clear();
        let n_phi = self.n_phi();
        for ring in 0..self.n_theta() {
            let cells = ring * n_phi..(ring + 1) * n_phi;
            let forward = with_isa!(Isa::detect(), |ISA| fn(
                poly: &Polygon = poly,
                s: &mut NearestHits = s,
                cells: Range<usize> = cells,
            ) -> bool {
                world_dirs(poly, s, cells)
            });
            s.forward.push(forward);
        }
        s.dirs_for = Some(key);
    }
}

/// `Frame::world_from_local` of the cells' directions, component by component (the
/// same sums in the same order, so the same bits); true if all leave the plane forwards.
#[inline(always)]
fn world_dirs(poly: &Polygon, s: &mut NearestHits, cells: Range<usize>) -> bool {
    let f = poly.frame();
    let n = poly.normal();
    let (lx, ly, lz) = (
        &s.lx[cells.clone()],
        &s.ly[cells.clone()],
        &s.lz[cells.clone()],
    );
    let len = lx.len();
    let (ly, lz) = (&ly[..len], &lz[..len]);
    let (dx, dy, dz) = (
        &mut s.dx[cells.clone()],
        &mut s.dy[cells.clone()],
        &mut s.dz[cells],
    );
    let (dx, dy, dz) = (&mut dx[..len], &mut dy[..len], &mut dz[..len]);
    let mut forward = true;
    for k in 0..len {
        let (x, y, z) = (lx[k], ly[k], lz[k]);
        let w = Vec3::new(
            f.t.x * x + f.b.x * y + f.n.x * z,
            f.t.y * x + f.b.y * y + f.n.y * z,
            f.t.z * x + f.b.z * y + f.n.z * z,
        );
        dx[k] = w.x;
        dy[k] = w.y;
        dz[k] = w.z;
        forward &= (w.x * n.x + w.y * n.y) + w.z * n.z > 0.0;
    }
    forward
}

/// Tests cells `a..b` against one polygon, keeping the nearer hit (ties keep the earlier,
/// lower polygon id; with `ANY_ORDER`, the lower id whatever the order).
fn test_span<const ANY_ORDER: bool>(
    poly: &Polygon,
    id: PolygonId,
    h: &OriginTerms,
    s: &mut NearestHits,
    a: usize,
    b: usize,
) {
    s.tests += (b - a) as u64;
    // A front-facing parallelogram is inside its (u, v) bounds alone: every lane runs
    // the same code and writes its hit. Other polygons take the bounds as a first cut,
    // then their own inside test cell by cell.
    let simple = h.num < 0.0 && poly.is_parallelogram();
    let (dx, dy, dz) = (&s.dx[a..b], &s.dy[a..b], &s.dz[a..b]);
    let (bt, bp) = (&mut s.best_t[a..b], &mut s.best_p[a..b]);
    let (bu, bv) = (&mut s.best_u[a..b], &mut s.best_v[a..b]);
    s.mask.resize(b - a, 0);
    let mask = &mut s.mask[..b - a];
    with_isa!(Isa::detect(), |ISA| fn(
        h: &OriginTerms = h,
        id: PolygonId = id,
        simple: bool = simple,
        any_order: bool = ANY_ORDER,
        dx: &[f32] = dx,
        dy: &[f32] = dy,
        dz: &[f32] = dz,
        bt: &mut [f32] = bt,
        bp: &mut [u32] = bp,
        bu: &mut [f32] = bu,
        bv: &mut [f32] = bv,
        mask: &mut [u8] = mask,
    ) {
        match (simple, any_order) {
            (true, false) => span::<true, false>(h, id, dx, dy, dz, bt, bp, bu, bv, mask),
            (false, false) => span::<false, false>(h, id, dx, dy, dz, bt, bp, bu, bv, mask),
            (true, true) => span::<true, true>(h, id, dx, dy, dz, bt, bp, bu, bv, mask),
            (false, true) => span::<false, true>(h, id, dx, dy, dz, bt, bp, bu, bv, mask),
        }
    });
    if simple || !mask.contains(&1) {
        return;
    }
    accept_masked(poly, id, h, [dx, dy, dz], [bt, bu, bv], bp, mask);
}

/// The scalar rest of a masked span: each cell `mask` marks takes the hit if the
/// polygon's own inside test accepts it (the same f32 terms as the vectorised part).
#[inline(always)]
fn accept_masked(
    poly: &Polygon,
    id: PolygonId,
    h: &OriginTerms,
    [dx, dy, dz]: [&[f32]; 3],
    [bt, bu, bv]: [&mut [f32]; 3],
    bp: &mut [u32],
    mask: &[u8],
) {
    for k in 0..mask.len() {
        if mask[k] == 0 {
            continue;
        }
        let (x, y, z) = (dx[k], dy[k], dz[k]);
        let denom = h.denom(x, y, z);
        let t = h.num / denom;
        let (u, v) = h.uv(t, x, y, z);
        if poly.accepts(denom, false, u, v) {
            (bt[k], bp[k], bu[k], bv[k]) = (t, id, u, v);
        }
    }
}

/// [`test_span`] with `ANY_ORDER` on several runs of cells at once (one dispatch), a
/// triangle's inside test vectorised.
fn test_runs(
    poly: &Polygon,
    id: PolygonId,
    h: &OriginTerms,
    shape: &Shape,
    s: &mut NearestHits,
    runs: &[Range<usize>],
) {
    let simple = h.num < 0.0 && matches!(shape, Shape::Parallelogram);
    let triangle = match shape {
        Shape::Triangle(t) => Some(*t),
        _ => None,
    };
    let longest = runs.iter().map(|r| r.len()).max().unwrap_or(0);
    s.tests += runs.iter().map(|r| r.len() as u64).sum::<u64>();
    s.mask.resize(longest.max(s.mask.len()), 0);
    let NearestHits {
        dx,
        dy,
        dz,
        best_t,
        best_p,
        best_u,
        best_v,
        mask,
        ..
    } = s;
    with_isa!(Isa::detect(), |ISA| fn(
        poly: &Polygon = poly,
        h: &OriginTerms = h,
        id: PolygonId = id,
        simple: bool = simple,
        triangle: Option<Triangle> = triangle,
        runs: &[Range<usize>] = runs,
        dx: &[f32] = dx,
        dy: &[f32] = dy,
        dz: &[f32] = dz,
        bt: &mut [f32] = best_t,
        bp: &mut [u32] = best_p,
        bu: &mut [f32] = best_u,
        bv: &mut [f32] = best_v,
        mask: &mut [u8] = mask,
    ) {
        for r in runs {
            let (dx, dy, dz) = (&dx[r.clone()], &dy[r.clone()], &dz[r.clone()]);
            let (bt, bp) = (&mut bt[r.clone()], &mut bp[r.clone()]);
            let (bu, bv) = (&mut bu[r.clone()], &mut bv[r.clone()]);
            if simple {
                let mask = &mut mask[..r.len()];
                span::<true, true>(h, id, dx, dy, dz, bt, bp, bu, bv, mask);
                continue;
            }
            if let Some(tri) = &triangle {
                span_triangle(h, id, tri, dx, dy, dz, bt, bp, bu, bv);
                continue;
            }
            let mask = &mut mask[..r.len()];
            span::<false, true>(h, id, dx, dy, dz, bt, bp, bu, bv, mask);
            accept_masked(poly, id, h, [dx, dy, dz], [bt, bu, bv], bp, mask);
        }
    });
}

/// [`span`] for a triangle in any order, its inside test vectorised: a front hit
/// (`denom < 0`) needs every edge function at least −eps, a back hit at least eps, as
/// [`Polygon::accepts`] has it; hits are written.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn span_triangle(
    h: &OriginTerms,
    id: PolygonId,
    tri: &Triangle,
    dx: &[f32],
    dy: &[f32],
    dz: &[f32],
    bt: &mut [f32],
    bp: &mut [u32],
    bu: &mut [f32],
    bv: &mut [f32],
) {
    let n = dx.len();
    let (dy, dz, bt, bp, bu, bv) = (
        &dy[..n],
        &dz[..n],
        &mut bt[..n],
        &mut bp[..n],
        &mut bu[..n],
        &mut bv[..n],
    );
    let [e0, e1, e2] = tri.edges;
    for k in 0..n {
        let (x, y, z) = (dx[k], dy[k], dz[k]);
        let denom = h.denom(x, y, z);
        let t = h.num / denom;
        let (u, v) = h.uv(t, x, y, z);
        let nearer = (t < bt[k]) | ((t == bt[k]) & (id < bp[k]) & (t < f32::INFINITY));
        let limit = if denom < 0.0 { -tri.eps } else { tri.eps };
        let inside = (e0[0] * u + e0[1] * v + e0[2] >= limit)
            & (e1[0] * u + e1[1] * v + e1[2] >= limit)
            & (e2[0] * u + e2[1] * v + e2[2] >= limit);
        let hit = (t > 0.0) & nearer & inside;
        bt[k] = if hit { t } else { bt[k] };
        bp[k] = if hit { id } else { bp[k] };
        bu[k] = if hit { u } else { bu[k] };
        bv[k] = if hit { v } else { bv[k] };
    }
}

/// The grid's ray–polygon test on a span of cells, branch-free (vectorised): with
/// `simple`, hits are written; otherwise `mask` marks the cells that pass the (u, v)
/// bounds and are nearer than the best so far (with `ANY_ORDER`, nearer or as near
/// with a lower id).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn span<const SIMPLE: bool, const ANY_ORDER: bool>(
    h: &OriginTerms,
    id: PolygonId,
    dx: &[f32],
    dy: &[f32],
    dz: &[f32],
    bt: &mut [f32],
    bp: &mut [u32],
    bu: &mut [f32],
    bv: &mut [f32],
    mask: &mut [u8],
) {
    let n = dx.len();
    let (dy, dz, bt, bp, bu, bv, mask) = (
        &dy[..n],
        &dz[..n],
        &mut bt[..n],
        &mut bp[..n],
        &mut bu[..n],
        &mut bv[..n],
        &mut mask[..n],
    );
    for k in 0..n {
        let (x, y, z) = (dx[k], dy[k], dz[k]);
        // The shared hit test (the grid's arithmetic, so the grid's bits).
        let t = h.num / h.denom(x, y, z);
        let (u, v) = h.uv(t, x, y, z);
        let nearer = if ANY_ORDER {
            // (t < ∞: an infinite t never counts, as with the strict rule.)
            (t < bt[k]) | ((t == bt[k]) & (id < bp[k]) & (t < f32::INFINITY))
        } else {
            t < bt[k]
        };
        let hit = (t > 0.0) & nearer & h.in_bounds(u, v);
        if SIMPLE {
            bt[k] = if hit { t } else { bt[k] };
            bp[k] = if hit { id } else { bp[k] };
            bu[k] = if hit { u } else { bu[k] };
            bv[k] = if hit { v } else { bv[k] };
        } else {
            mask[k] = hit as u8;
        }
    }
}

/// The corners, in world space, of the (u, v) box within which every hit the grid
/// accepts on `poly` lies: the polygon's (u, v) bounds, grown past its edge tolerance
/// (the tolerance reaches farthest at its sharpest corner, eps / sin(α/2)), on its
/// plane.
pub(crate) fn padded_corners(poly: &Polygon) -> [DVec3; 4] {
    let (lo, hi) = padded_uv_box(poly);
    // The grid's hits lie on the plane n·p = d, with (u, v) from the dual basis (du,
    // dv ⊥ n): the point of parameters (u, v) there is o' + u e_u' + v e_v', with the
    // edges projected onto the plane and o' the origin moved onto it (a vertex may lie
    // off the plane within the planarity tolerance).
    let n = poly.normal().as_dvec3();
    let (eu, ev) = (poly.e_u().as_dvec3(), poly.e_v().as_dvec3());
    let (eu, ev) = (eu - n * eu.dot(n), ev - n * ev.dot(n));
    let origin = padded_origin(poly);
    [
        (lo[0], lo[1]),
        (hi[0], lo[1]),
        (hi[0], hi[1]),
        (lo[0], hi[1]),
    ]
    .map(|(u, v)| origin + eu * u + ev * v)
}

/// The polygon's (u, v) origin (vertex 0, or its bounding rectangle's corner) moved
/// onto its plane.
fn padded_origin(poly: &Polygon) -> DVec3 {
    let (n, origin) = (poly.normal().as_dvec3(), poly.origin().as_dvec3());
    origin + n * (poly.plane_offset() as f64 - n.dot(origin))
}

/// The cells whose rays from `o` may meet `poly`, in the local frame `[t, b, n]` of the
/// patch; `num` is the grid's f32 plane term (`d − n·o`); `padded` its
/// [`padded_corners`].
fn region(poly: &Polygon, o: DVec3, num: f32, frame: [DVec3; 3], padded: &[DVec3; 4]) -> Region {
    let gap = (poly.normal().as_dvec3().dot(o) - poly.plane_offset() as f64).abs();
    region_of(padded, padded_origin(poly), gap, o, num, frame, 0.0)
}

/// [`region`] of any convex quadrilateral `padded` (world corners, in order) on a plane
/// `gap` from `o` (whose f32 term is `num`), `origin` a point of it, with `extra` added
/// to the rounding slack (a distance: how far the points it bounds may lie off it).
pub(crate) fn region_of(
    padded: &[DVec3; 4],
    origin: DVec3,
    gap: f64,
    o: DVec3,
    num: f32,
    frame: [DVec3; 3],
    extra: f64,
) -> Region {
    let corners = padded.map(|p| {
        let w = p - o;
        DVec3::new(frame[0].dot(w), frame[1].dot(w), frame[2].dot(w))
    });
    // f32 rounding of the grid's terms, as a distance: a few hundred ulps of the
    // coordinates involved, hit distances included.
    let scale = corners.iter().map(|c| c.length()).fold(0.0, f64::max)
        + o.abs().max_element()
        + origin.abs().max_element();
    let slack = 1e-5 * scale + extra;
    // The plane passes within rounding of the origin: no box is reliable.
    let plane = (num as f64).abs().min(gap);
    if plane <= NEAR_PLANE * slack {
        return Region::All;
    }
    // Angular margin: the rounding seen from the nearest the plane can be.
    let margin = 1e-6 + 4.0 * slack / plane;
    // Clip to z ≥ −slack (cells all have z > 0).
    let clipped = clip_below(&corners, -slack);
    if clipped.len() < 3 {
        return if clipped.is_empty() {
            Region::None
        } else {
            Region::All
        };
    }
    let dirs: Vec<DVec3> = clipped.iter().map(|c| c.normalize_or_zero()).collect();
    if dirs.contains(&DVec3::ZERO) {
        return Region::All;
    }
    let theta_of = |d: DVec3| d.x.hypot(d.y).atan2(d.z);
    let theta_hi = dirs.iter().map(|&d| theta_of(d)).fold(0.0, f64::max) + margin;
    // Pole inside (or on an edge or vertex): winding of the φ angles.
    let mut pole = dirs.iter().any(|d| d.x.hypot(d.y) < 1e-12);
    let mut winding = 0.0;
    let mut phi = Vec::with_capacity(dirs.len());
    let phi0 = dirs[0].y.atan2(dirs[0].x);
    let mut acc = phi0;
    phi.push(acc);
    for k in 0..dirs.len() {
        let (a, b) = (dirs[k], dirs[(k + 1) % dirs.len()]);
        let step = wrap(b.y.atan2(b.x) - a.y.atan2(a.x));
        if step.abs() > PI - 1e-9 {
            pole = true;
        }
        winding += step;
        if k + 1 < dirs.len() {
            acc += step;
            phi.push(acc);
        }
    }
    if pole || winding.abs() > PI {
        return Region::Box {
            theta: (0.0, theta_hi),
            phi: None,
        };
    }
    // θ is least at a vertex or where an edge's great circle comes nearest the pole.
    let mut theta_lo = dirs.iter().map(|&d| theta_of(d)).fold(PI, f64::min);
    for k in 0..dirs.len() {
        if let PoleDip::At(q) = pole_dip(dirs[k], dirs[(k + 1) % dirs.len()]) {
            theta_lo = theta_lo.min(theta_of(q));
        }
    }
    let theta_lo = theta_lo - margin;
    if theta_lo <= 0.0 {
        return Region::Box {
            theta: (0.0, theta_hi),
            phi: None,
        };
    }
    let phi_margin = {
        let s = margin.sin() / theta_lo.min(FRAC_PI_2).sin();
        if s >= 1.0 {
            return Region::Box {
                theta: (theta_lo, theta_hi),
                phi: None,
            };
        }
        s.asin() + 1e-9
    };
    let lo = phi.iter().copied().fold(f64::INFINITY, f64::min) - phi_margin;
    let hi = phi.iter().copied().fold(f64::NEG_INFINITY, f64::max) + phi_margin;
    Region::Box {
        theta: (theta_lo, theta_hi),
        phi: (hi - lo < TAU).then_some((lo, hi)),
    }
}

impl ScanOrigin {
    /// The lowest cosθ of any cell's direction of `hemi` (made once).
    pub(crate) fn min_cos(&mut self, hemi: &Hemisphere) -> f64 {
        *self.min_cos.get_or_insert_with(|| hemi.min_cell_cos())
    }
}

impl Hemisphere {
    /// The lowest cosθ of any cell's direction (its last ring's).
    fn min_cell_cos(&self) -> f64 {
        self.directions()
            .iter()
            .map(|d| d.z as f64)
            .fold(1.0, f64::min)
    }
}

/// True when no cell's ray can hit `poly` (whose plane passes within rounding of the
/// origin: a coplanar neighbour, say), proved from bounds on the grid's own f32 terms:
/// when `poly`'s normal makes an angle γ with the patch's `own_n` such that every
/// cell's direction meets `poly`'s plane at the same side (`n·d` of one sign, at least
/// `d_min` in size: the cells' directions lie within θ_max = acos `min_cos` of
/// `own_n`, so |n·d| ≥ cos(γ + θ_max)), then `t = num / n·d` has one sign: if it is
/// negative there is no hit; if positive, `t ≤ |num| / d_min`, and every hit point,
/// within `t_max` of the origin, projects onto the plane within `t_max` of the origin's
/// own projection (u0, v0): a polygon whose edges leave that point farther outside
/// than `t_max` plus its inside tolerance (and margins for f32 rounding) is never hit
/// either. Skipping such a polygon changes no cell: the grid's test on it would fail
/// on every cell.
pub(crate) fn cannot_hit_near_plane(
    poly: &Polygon,
    h: &OriginTerms,
    own_n: DVec3,
    min_cos: f64,
) -> bool {
    // The normals are f32 unit vectors, each 1 only within a few 1e-8: normalise in
    // f64, and take cos(γ + θ_max) = cos γ cos θ_max − sin γ sin θ_max without acos,
    // which would magnify their rounding by 1 / sin γ.
    let (n, own) = (poly.normal().as_dvec3().normalize(), own_n.normalize());
    let cos_gamma = n.dot(own);
    let sin_gamma = n.cross(own).length();
    let min_cos = min_cos.clamp(0.0, 1.0);
    let sin_theta = (1.0 - min_cos * min_cos).sqrt();
    // f32 directions and dot products: a few 1e-7 off; keep well clear.
    let d_min = cos_gamma.abs() * min_cos - sin_gamma * sin_theta - 1e-5;
    if d_min <= 1e-5 {
        return false;
    }
    let num = h.num as f64;
    // n·d has the sign of cos γ for every cell; t > 0 needs num of that sign.
    if num == 0.0 || (num > 0.0) != (cos_gamma > 0.0) {
        return true;
    }
    let t_max = num.abs() / d_min;
    let (u0, v0) = (h.u0 as f64, h.v0 as f64);
    // How far outside the polygon (u0, v0) lies, in world units, and the size of the
    // terms its f32 inside test sums (for the rounding margin).
    // (The hit's u is u0 + t du·d, rounded: in edge-function units up to a few 1e-7
    // of t (|a| |du| + |b| |dv|), large for a skewed polygon.)
    let (du, dv) = (h.du.as_dvec3().length(), h.dv.as_dvec3().length());
    let (mut outside, mut scale) = (f64::NEG_INFINITY, 0.0f64);
    for e in poly.edge_functions() {
        let (a, b, c) = (e[0] as f64, e[1] as f64, e[2] as f64);
        outside = outside.max(-(a * u0 + b * v0 + c));
        let skew = t_max * (a.abs() * du + b.abs() * dv);
        scale = scale.max((a * u0).abs() + (b * v0).abs() + c.abs() + skew);
    }
    outside > 1.01 * t_max + 2.0 * poly.reach() as f64 + 1e-5 * (1.0 + scale)
}

/// How far past its edges (world units) the inside tests of `poly`, whose corners in
/// order are `corners`, reach: twice its reach over the sine of its sharpest half-angle.
pub(crate) fn edge_reach(poly: &Polygon, corners: &[DVec3]) -> f64 {
    rad_geometry::reach_past_corners(poly.reach(), corners)
}

/// Where the great-circle arc from unit direction `a` to `b` comes nearest the pole
/// (+z), if that is inside the arc: [`PoleDip::At`] the direction there,
/// [`PoleDip::Ends`] if the ends are nearest, [`PoleDip::Unknown`] if the arc's circle
/// passes through the pole (no single nearest point).
pub(crate) fn pole_dip(a: DVec3, b: DVec3) -> PoleDip {
    let m = a.cross(b);
    let ml = m.length();
    if ml < 1e-12 {
        return PoleDip::Ends;
    }
    let m = m / ml;
    let q = DVec3::Z - m * m.z;
    let ql = q.length();
    if ql < 1e-12 {
        return PoleDip::Unknown;
    }
    let q = q / ql;
    if a.cross(q).dot(m) >= 0.0 && q.cross(b).dot(m) >= 0.0 {
        PoleDip::At(q)
    } else {
        PoleDip::Ends
    }
}

/// See [`pole_dip`].
pub(crate) enum PoleDip {
    Ends,
    At(DVec3),
    Unknown,
}

/// `x` wrapped into (−π, π].
pub(crate) fn wrap(x: f64) -> f64 {
    let y = x.rem_euclid(TAU);
    if y > PI {
        y - TAU
    } else {
        y
    }
}

/// The polygon's (u, v) bounding box, grown past everything its inside tests accept.
fn padded_uv_box(poly: &Polygon) -> ([f64; 2], [f64; 2]) {
    let uv = poly.uv_vertices();
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in uv {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // World distance the inside tests reach past an edge, at the sharpest corner.
    let world: Vec<DVec3> = uv
        .iter()
        .map(|p| poly.point(p[0] as f32, p[1] as f32).as_dvec3())
        .collect();
    let reach = edge_reach(poly, &world);
    let (du, dv) = poly.dual_basis();
    let pad = [
        reach * du.as_dvec3().length(),
        reach * dv.as_dvec3().length(),
    ];
    // The grid's own bounds for parallelograms, and a relative margin for rounding.
    let b = poly.uv_bounds();
    for k in 0..2 {
        let extra = pad[k] + 1e-5 * (hi[k] - lo[k]).abs();
        lo[k] = (lo[k] - extra).min(if b[2 * k].is_finite() {
            b[2 * k] as f64
        } else {
            f64::INFINITY
        });
        hi[k] = (hi[k] + extra).max(if b[2 * k + 1].is_finite() {
            b[2 * k + 1] as f64
        } else {
            f64::NEG_INFINITY
        });
    }
    (lo, hi)
}

/// Sutherland–Hodgman clip of a convex polygon to `z ≥ z0`.
fn clip_below(poly: &[DVec3], z0: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        let (ia, ib) = (a.z >= z0, b.z >= z0);
        if ia {
            out.push(a);
        }
        if ia != ib {
            let s = (z0 - a.z) / (b.z - a.z);
            out.push(a + (b - a) * s);
        }
    }
    out
}
