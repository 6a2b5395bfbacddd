//! Facets: a mesh's flat pieces. Polygons of one plane that share edges, each of one
//! patch and of at most four vertices (a mesh's triangles and quads), make one facet,
//! with a grid over its plane that turns a point of it into the few polygons that may
//! hold it (as a polygon's patch texture turns a point into its patch). Estimation
//! guesses facets rather than triangles, so that a tessellated wall is guessed as the
//! one polygon it was before it was cut.

use crate::{EdgeNeighbours, Polygon};
use glam::{DVec2, DVec3, Vec3};
use rad_core::{prefetch, PolygonId, NO_POLYGON};

/// The largest angle (radians) between the normals of two polygons of one facet, and
/// the farthest (relative to the facet's first polygon's size) a vertex may lie from its
/// plane.
pub const FACET_TILT: f64 = 1e-5;

/// A scene's facets (see the module's text): every polygon belongs to one; a polygon
/// with a patch grid of its own, of more than four vertices, or with no coplanar
/// neighbour across an edge, is a facet alone.
#[derive(Clone, Debug, Default)]
pub struct Facets {
    /// By polygon: its facet.
    facet_of: Vec<u32>,
    facets: Vec<Facet>,
    /// Each facet's polygons, lowest id first: `members[facet.members]`.
    members: Vec<PolygonId>,
    /// The edges of the polygons of facets of several, one cache line each.
    edges: Vec<Outline>,
    /// By polygon: its slot in `edges` (`EMPTY` for a facet of one).
    slot_of: Vec<u32>,
    /// The grids' cells, each facet's from its `first_cell`: up to four indices into
    /// `edges` (`EMPTY` for none); a cell of more has `OVERFLOW | k` last, its others
    /// in `overflow[overflow_start[k]..overflow_start[k + 1]]`.
    cells: Vec<[u32; 4]>,
    overflow_start: Vec<u32>,
    overflow: Vec<u32>,
}

/// A polygon's edges in its facet's plane coordinates: lines (a, b, c) with
/// a² + b² = 1 and a x + b y + c ≥ 0 inside, `n` of them (3 or 4; a triangle's fourth
/// holds every point), and its id.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Outline {
    lines: [[f32; 3]; 4],
    n: u32,
    polygon: PolygonId,
}

impl Outline {
    /// Polygon `p`'s outline from its vertices `vs` (at most four) in the plane's
    /// coordinates, with its lines in f64.
    fn of(p: PolygonId, vs: &[DVec2]) -> (Outline, [[f64; 3]; 4]) {
        // (A triangle's fourth line holds every point: 0 x + 0 y + ∞.)
        let mut outline = Outline {
            lines: [[0.0, 0.0, f32::INFINITY]; 4],
            n: vs.len() as u32,
            polygon: p,
        };
        let mut lines = [[0.0f64; 3]; 4];
        for k in 0..vs.len() {
            let (a, b) = (vs[k], vs[(k + 1) % vs.len()]);
            let e = (b - a) / (b - a).length();
            // Inside (counter-clockwise about the normal, so in (t, b)) is left.
            let (na, nb) = (-e.y, e.x);
            lines[k] = [na, nb, -(na * a.x + nb * a.y)];
            outline.lines[k] = lines[k].map(|x| x as f32);
        }
        (outline, lines)
    }
}

const EMPTY: u32 = u32::MAX;
const OVERFLOW: u32 = 1 << 31;

/// One facet: its plane (its first polygon's) and grid.
#[derive(Clone, Debug)]
struct Facet {
    members: std::ops::Range<u32>,
    /// The plane n·p = d, and the in-plane axes of the grid (f32, as the hit test).
    n: Vec3,
    d: f32,
    axes: [Vec3; 2],
    /// The grid: its lower corner in the axes' coordinates, the inverse of its cell
    /// size, its cells along each axis, and its first cell in `cells`.
    lo: [f32; 2],
    inv_cell: f32,
    dims: [u32; 2],
    first_cell: u32,
    /// How far outside its edges a point may lie and still count as a polygon's: a
    /// hundredth of a grid cell, plus twice the members' own tests' reach and the f32
    /// rounding of points and coordinates (the margin).
    margin: f32,
}

/// Where a ray meets a facet ([`Facets::locate_span`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Located {
    /// Well inside this polygon, at this distance along the ray.
    Clear(PolygonId, f32),
    /// By an edge: the candidates' own tests decide ([`Facets::for_each_holding`]).
    Near,
    /// In none of the facet's polygons, or not met ahead.
    Outside,
}

impl Facets {
    /// The facets of `polygons`, whose patch counts are `patch_count` and whose
    /// neighbours across edges are `edges` (a scene's: [`Facets::of`], [`Facets::exact`]);
    /// `exact`: the margins of exact casting.
    pub(crate) fn made(
        polygons: &[Polygon],
        patch_count: &[u32],
        edges: &EdgeNeighbours,
        exact: bool,
    ) -> Facets {
        let n = polygons.len();
        // Polygons of one patch (their patch grids are 1 × 1 and not empty) and of at
        // most four vertices may join others.
        let joins = |p: usize| patch_count[p] == 1 && polygons[p].vertices().len() <= 4;
        let mut facet_of = vec![u32::MAX; n];
        let mut out = Facets::default();
        out.overflow_start.push(0);
        let mut queue = Vec::new();
        for seed in 0..n {
            if facet_of[seed] != u32::MAX {
                continue;
            }
            let k = out.facets.len() as u32;
            facet_of[seed] = k;
            let first = out.members.len();
            out.members.push(seed as PolygonId);
            if joins(seed) {
                // Across edges (depth first; the members are sorted after), within the
                // seed's plane.
                let plane = Plane::of(&polygons[seed]);
                queue.clear();
                queue.push(seed);
                while let Some(p) = queue.pop() {
                    for &q in edges.across(p as PolygonId) {
                        let q = q as usize;
                        if q != NO_POLYGON as usize
                            && facet_of[q] == u32::MAX
                            && joins(q)
                            && plane.holds(&polygons[q])
                        {
                            facet_of[q] = k;
                            out.members.push(q as PolygonId);
                            queue.push(q);
                        }
                    }
                }
            }
            out.members[first..].sort_unstable();
            let members = first as u32..out.members.len() as u32;
            let facet = out.grid(polygons, members, exact);
            out.facets.push(facet);
        }
        out.facet_of = facet_of;
        out.slot_of = vec![EMPTY; n];
        for (slot, o) in out.edges.iter().enumerate() {
            out.slot_of[o.polygon as usize] = slot as u32;
        }
        out
    }

    /// Facet `members`' plane and, for several, its grid (cells of about half a polygon
    /// across) and their outlines, appended.
    fn grid(&mut self, polygons: &[Polygon], members: std::ops::Range<u32>, exact: bool) -> Facet {
        let ids = &self.members[members.start as usize..members.end as usize];
        let first = &polygons[ids[0] as usize];
        let frame = first.frame();
        let mut facet = Facet {
            members: members.clone(),
            n: first.normal(),
            d: first.normal().dot(first.vertices()[0]),
            axes: [frame.t, frame.b],
            lo: [0.0; 2],
            inv_cell: 0.0,
            dims: [0; 2],
            first_cell: self.cells.len() as u32,
            margin: 0.0,
        };
        if ids.len() == 1 {
            return facet;
        }
        let (a0, a1) = (frame.t.as_dvec3(), frame.b.as_dvec3());
        let at = |v: Vec3| DVec2::new(v.as_dvec3().dot(a0), v.as_dvec3().dot(a1));
        let shapes: Vec<Vec<DVec2>> = ids
            .iter()
            .map(|&p| {
                polygons[p as usize]
                    .vertices()
                    .iter()
                    .map(|&v| at(v))
                    .collect()
            })
            .collect();
        let (lo, hi) = shapes.iter().flatten().fold(
            (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
            |(lo, hi), &v| (lo.min(v), hi.max(v)),
        );
        // How far a point may stray and still be a polygon's: past its edges by its own
        // test's reach, and by the f32 rounding of the hit point and its coordinates
        // (a few millionths of the largest coordinate; rays at grazing angles stray
        // from the f64 plane too).
        let reach = ids
            .iter()
            .zip(&shapes)
            .map(|(&p, vs)| {
                let reach = 2.0 * f64::from(polygons[p as usize].reach());
                if exact {
                    reach / sharpest_sin_half(vs).max(1e-6)
                } else {
                    reach
                }
            })
            .fold(0.0, f64::max);
        let magnitude = lo.abs().max(hi.abs()).max_element();
        let slack = reach + 4e-6 * magnitude + 1e-6 * (hi - lo).max_element() + 1e-12;
        let area: f64 = ids.iter().map(|&p| polygons[p as usize].area()).sum();
        let box_area = (hi - lo).x.max(slack) * (hi - lo).y.max(slack);
        // Cells of half a polygon's size across, at most 16 a polygon (a long, thin or
        // ring-shaped facet's box holds far more than its polygons' area), at most
        // 8192 along a side.
        let cell = (0.5 * (area / ids.len() as f64).sqrt())
            .max((box_area / (16.0 * ids.len() as f64)).sqrt())
            .max((hi - lo).max_element() / 8000.0);
        let margin = slack + if exact { 0.03 } else { 0.01 } * cell;
        // The box padded by the margin (a hit just outside the facet's border is still
        // its border polygon's candidate).
        let (lo, hi) = (lo - margin, hi + margin);
        let size = hi - lo;
        let dims = [
            ((size.x / cell).ceil() as u32).clamp(1, 8192),
            ((size.y / cell).ceil() as u32).clamp(1, 8192),
        ];
        let index = |x: f64, d: u32| ((x / cell).floor().max(0.0) as u32).min(d - 1);
        // Each polygon in the cells it meets, grown by the margin.
        let grow = margin;
        let mut lists: Vec<Vec<(u32, u32)>> = vec![Vec::new(); (dims[0] * dims[1]) as usize];
        for (&p, vs) in ids.iter().zip(&shapes) {
            let slot = self.edges.len() as u32;
            let (outline, lines) = Outline::of(p, vs);
            self.edges.push(outline);
            let (bl, bh) = vs.iter().fold(
                (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
                |(l, h), &v| (l.min(v), h.max(v)),
            );
            let (l, h) = (bl - grow - lo, bh + grow - lo);
            for j in index(l.y, dims[1])..=index(h.y, dims[1]) {
                for i in index(l.x, dims[0])..=index(h.x, dims[0]) {
                    // The cell meets the polygon unless one edge has all its corners
                    // outside (beyond the growth).
                    let (x0, y0) = (lo.x + i as f64 * cell, lo.y + j as f64 * cell);
                    let outside = lines[..vs.len()].iter().any(|&[a, b, c]| {
                        let best = a * if a > 0.0 { x0 + cell } else { x0 }
                            + b * if b > 0.0 { y0 + cell } else { y0 }
                            + c;
                        best < -grow
                    });
                    if !outside {
                        let covers = coverage(&lines[..vs.len()], x0, y0, cell);
                        lists[(j * dims[0] + i) as usize].push((covers, slot));
                    }
                }
            }
        }
        for l in lists {
            self.push_cell(l);
        }
        facet.lo = [lo.x as f32, lo.y as f32];
        facet.inv_cell = (1.0 / cell) as f32;
        facet.dims = dims;
        facet.margin = margin as f32;
        facet
    }

    /// Appends a grid cell holding the outline slots of `l` (each with how much of the
    /// cell it covers).
    fn push_cell(&mut self, mut l: Vec<(u32, u32)>) {
        // The polygon most of the cell lies in first: so the one holding a point is
        // found sooner (which one holds it does not depend on the order).
        l.sort_unstable_by_key(|&(covers, slot)| (std::cmp::Reverse(covers), slot));
        let l: Vec<u32> = l.into_iter().map(|(_, slot)| slot).collect();
        let mut c = [EMPTY; 4];
        if l.len() <= 4 {
            c[..l.len()].copy_from_slice(&l);
        } else {
            c[..3].copy_from_slice(&l[..3]);
            c[3] = OVERFLOW | (self.overflow_start.len() - 1) as u32;
            self.overflow.extend_from_slice(&l[3..]);
            self.overflow_start.push(self.overflow.len() as u32);
        }
        self.cells.push(c);
    }

    /// The number of facets.
    pub fn len(&self) -> usize {
        self.facets.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.facets.is_empty()
    }

    /// The facet of polygon `p`.
    #[inline]
    pub fn facet_of(&self, p: PolygonId) -> u32 {
        self.facet_of[p as usize]
    }

    /// Facet `f`'s polygons, lowest id first.
    pub fn polygons(&self, f: u32) -> &[PolygonId] {
        let r = &self.facets[f as usize].members;
        &self.members[r.start as usize..r.end as usize]
    }

    /// Whether facet `f` holds several polygons.
    #[inline]
    pub fn is_several(&self, f: u32) -> bool {
        self.facets[f as usize].members.len() > 1
    }

    /// Facet `f`'s plane n·p = d (its first polygon's, in f32 as its point tests take
    /// it).
    #[inline]
    pub fn plane(&self, f: u32) -> (Vec3, f32) {
        let facet = &self.facets[f as usize];
        (facet.n, facet.d)
    }

    /// How far outside a polygon's edges (world units, in the facet's plane) a point
    /// may lie and still be [`Located::Near`] it rather than `Outside`, and how far
    /// inside one it must lie to be [`Located::Clear`] (facets of several polygons).
    #[inline]
    pub fn margin(&self, f: u32) -> f32 {
        self.facets[f as usize].margin
    }

    /// `d − n·o` for facet `f`'s plane n·p = d (its first polygon's): negative where
    /// `o` is in front of it.
    #[inline]
    pub fn plane_num(&self, f: u32, o: Vec3) -> f32 {
        let facet = &self.facets[f as usize];
        facet.d - facet.n.dot(o)
    }

    /// Where the rays from `o` along `(dx[k], dy[k], dz[k])` meet facet `f` (of several
    /// polygons) in its plane, if no farther than `nearer[k]` (a hit found already),
    /// into `out` (cleared first), one per ray:
    /// [`Located::Clear`] with the polygon and the plane's t where a polygon holds the
    /// point by over the facet's margin (a hundredth of a grid cell, plus the members'
    /// own tests' reach and f32 rounding: the polygons of a facet do not overlap, so no
    /// other polygon's test holds it); [`Located::Outside`] where none comes within the
    /// margin of it (or the ray does not meet the plane ahead, or meets it beyond
    /// `nearer[k]`); [`Located::Near`] otherwise. Neighbouring rays
    /// often meet one polygon: the last one found is tried first; the grid cells are
    /// fetched a few rays ahead (the rays of a ring meet scattered cells of a large
    /// facet).
    pub fn locate_span(
        &self,
        f: u32,
        o: Vec3,
        dirs: [&[f32]; 3],
        nearer: &[f32],
        out: &mut Vec<Located>,
        scratch: &mut LocateScratch,
    ) {
        self.locate_span_steep(f, o, dirs, nearer, 0.0, out, scratch)
    }

    /// [`Facets::locate_span`] of the rays that meet the facet's plane at a cosine of
    /// `min_cos` or more (|n · dir|, n the plane's f32 normal, in the order x, y, z);
    /// the others are `Outside`.
    #[allow(clippy::too_many_arguments)]
    pub fn locate_span_steep(
        &self,
        f: u32,
        o: Vec3,
        [dx, dy, dz]: [&[f32]; 3],
        nearer: &[f32],
        min_cos: f32,
        out: &mut Vec<Located>,
        scratch: &mut LocateScratch,
    ) {
        let facet = &self.facets[f as usize];
        // (Compiled for the widest vector set: the same operations, so the same bits.)
        let n = rad_core::with_isa!(rad_core::Isa::detect(), |ISA| fn(
            facet: &Facet = facet,
            o: Vec3 = o,
            dx: &[f32] = dx,
            dy: &[f32] = dy,
            dz: &[f32] = dz,
            nearer: &[f32] = nearer,
            min_cos: f32 = min_cos,
            scratch: &mut LocateScratch = scratch,
        ) -> usize {
            Facets::points(facet, o, [dx, dy, dz], nearer, min_cos, scratch)
        });
        out.clear();
        let LocateScratch { x, y, t, cell } = scratch;
        // Grid cells are fetched `AHEAD` rays ahead, their first two outlines half as far.
        const AHEAD: usize = 16;
        let margin = facet.margin;
        let mut last = EMPTY;
        for &c in &cell[..n.min(AHEAD)] {
            if c != EMPTY {
                prefetch(&self.cells[c as usize]);
            }
        }
        for k in 0..n {
            if let Some(&c) = cell.get(k + AHEAD) {
                if c != EMPTY {
                    prefetch(&self.cells[c as usize]);
                }
            }
            if let Some(&c) = cell.get(k + AHEAD / 2) {
                if c != EMPTY {
                    let [s0, s1, ..] = self.cells[c as usize];
                    for s in [s0, s1] {
                        if s & OVERFLOW == 0 {
                            prefetch(&self.edges[s as usize]);
                        }
                    }
                }
            }
            let c = cell[k];
            if c == EMPTY {
                out.push(Located::Outside);
                continue;
            }
            let (xk, yk) = (x[k], y[k]);
            if last != EMPTY && self.inside_by(last, xk, yk) > margin {
                out.push(Located::Clear(self.edges[last as usize].polygon, t[k]));
                continue;
            }
            let mut near = false;
            let mut clear = EMPTY;
            self.for_each_in_cell(c, |slot| {
                if clear == EMPTY {
                    let d = self.inside_by(slot, xk, yk);
                    near |= d >= -margin;
                    if d > margin {
                        clear = slot;
                    }
                }
            });
            out.push(if clear != EMPTY {
                last = clear;
                Located::Clear(self.edges[clear as usize].polygon, t[k])
            } else if near {
                Located::Near
            } else {
                Located::Outside
            });
        }
    }

    /// The first pass of [`Facets::locate_span`]: each ray's point in the facet's
    /// plane coordinates, t and grid cell (`EMPTY` where it meets the plane behind, beyond
    /// `nearer`, or outside the grid), branch-free (vectorised); the number of rays.
    #[inline(always)]
    fn points(
        facet: &Facet,
        o: Vec3,
        [dx, dy, dz]: [&[f32]; 3],
        nearer: &[f32],
        min_cos: f32,
        scratch: &mut LocateScratch,
    ) -> usize {
        let n = dx.len().min(dy.len()).min(dz.len()).min(nearer.len());
        let LocateScratch { x, y, t, cell } = scratch;
        for v in [&mut *x, &mut *y, &mut *t] {
            v.clear();
            v.resize(n, 0.0);
        }
        cell.clear();
        cell.resize(n, EMPTY);
        let num = facet.d - facet.n.dot(o);
        let (nv, a0, a1) = (facet.n, facet.axes[0], facet.axes[1]);
        let (o0, o1) = (o.dot(a0) - facet.lo[0], o.dot(a1) - facet.lo[1]);
        let (dims_x, dims_y) = (facet.dims[0] as f32, facet.dims[1] as f32);
        for k in 0..n {
            let (u, v, w) = (dx[k], dy[k], dz[k]);
            let den = nv.x * u + nv.y * v + nv.z * w;
            let tk = num / den;
            let xk = o0 + tk * (a0.x * u + a0.y * v + a0.z * w);
            let yk = o1 + tk * (a1.x * u + a1.y * v + a1.z * w);
            let (gx, gy) = (xk * facet.inv_cell, yk * facet.inv_cell);
            // (NaN fails these.)
            let inside = (tk > 0.0)
                & (den.abs() >= min_cos)
                & (tk <= nearer[k])
                & (tk < f32::INFINITY)
                & (gx >= 0.0)
                & (gy >= 0.0)
                & (gx < dims_x)
                & (gy < dims_y);
            let (gx, gy) = (gx.max(0.0).min(dims_x - 1.0), gy.max(0.0).min(dims_y - 1.0));
            // SAFETY: clamped into [0, dims − 1] (`max` drops NaN), within u32's range.
            let (ix, iy) = unsafe { (gx.to_int_unchecked::<u32>(), gy.to_int_unchecked::<u32>()) };
            let c = facet.first_cell + iy * facet.dims[0] + ix;
            cell[k] = if inside { c } else { EMPTY };
            (x[k], y[k], t[k]) = (xk + facet.lo[0], yk + facet.lo[1], tk);
        }
        n
    }

    /// Calls `f` with each outline slot of grid cell `c`.
    #[inline(always)]
    fn for_each_in_cell(&self, c: u32, mut f: impl FnMut(u32)) {
        let cell = &self.cells[c as usize];
        for &slot in cell {
            if slot == EMPTY {
                return;
            }
            if slot & OVERFLOW != 0 {
                let k = (slot & !OVERFLOW) as usize;
                let r = self.overflow_start[k] as usize..self.overflow_start[k + 1] as usize;
                for &s in &self.overflow[r] {
                    f(s);
                }
                return;
            }
            f(slot);
        }
    }

    /// How far inside outline `slot`'s edges the point (x, y) lies: the least of its
    /// signed distances to them.
    #[inline(always)]
    fn inside_by(&self, slot: u32, x: f32, y: f32) -> f32 {
        let o = &self.edges[slot as usize];
        let mut d = f32::INFINITY;
        for &[a, b, c] in &o.lines {
            d = d.min(a * x + b * y + c);
        }
        d
    }

    /// Calls `f` with each polygon of facet `f` that holds, to within the facet's
    /// margin, the point where the ray `o + t·dir` (t > 0) meets the facet's plane
    /// (none where the ray does not meet the plane ahead, or meets it outside the
    /// facet's box); a facet of one polygon gives it whatever the ray. (Candidates for
    /// each polygon's own hit test, which decides.)
    pub fn for_each_holding(&self, f: u32, o: Vec3, dir: Vec3, call: impl FnMut(PolygonId)) {
        let facet = &self.facets[f as usize];
        let t = (facet.d - facet.n.dot(o)) / facet.n.dot(dir);
        self.for_each_holding_at(f, o, dir, t, None, call)
    }

    /// [`Facets::for_each_holding`] given the ray's t at the plane, computed as it does
    /// (`(d − n·o) / n·dir` of [`Facets::plane`]), and trying `likely` first: where that
    /// polygon (of facet `f`) holds the point by over the margin, it alone is called
    /// (the polygons of a facet do not overlap, and the margin covers how far past its
    /// edges any member's test reaches: see [`Located::Clear`]).
    #[inline]
    pub fn for_each_holding_at(
        &self,
        f: u32,
        o: Vec3,
        dir: Vec3,
        t: f32,
        likely: Option<PolygonId>,
        mut call: impl FnMut(PolygonId),
    ) {
        let facet = &self.facets[f as usize];
        if facet.members.len() == 1 {
            call(self.members[facet.members.start as usize]);
            return;
        }
        // (NaN fails this.)
        if !(t > 0.0 && t < f32::INFINITY) {
            return;
        }
        let p = o + dir * t;
        let (x, y) = (p.dot(facet.axes[0]), p.dot(facet.axes[1]));
        if let Some(q) = likely {
            let slot = self.slot_of[q as usize];
            if slot != EMPTY
                && self.facet_of[q as usize] == f
                && self.inside_by(slot, x, y) > facet.margin
            {
                call(q);
                return;
            }
        }
        let (gx, gy) = (
            (x - facet.lo[0]) * facet.inv_cell,
            (y - facet.lo[1]) * facet.inv_cell,
        );
        // (NaN fails these.)
        let inside =
            gx >= 0.0 && gy >= 0.0 && gx < facet.dims[0] as f32 && gy < facet.dims[1] as f32;
        if !inside {
            return;
        }
        let c = facet.first_cell + gy as u32 * facet.dims[0] + gx as u32;
        self.for_each_in_cell(c, |slot| {
            if self.inside_by(slot, x, y) >= -facet.margin {
                call(self.edges[slot as usize].polygon);
            }
        });
    }

    /// Calls `f` with each polygon of facet `f` (of several) whose outline comes within
    /// `r` of the point where the ray `o + t·dir` meets the facet's plane, computed as
    /// [`Facets::for_each_holding`] does (none where it does not meet the plane ahead);
    /// a polygon may be called more than once.
    pub fn for_each_within(&self, f: u32, o: Vec3, dir: Vec3, r: f32, call: impl FnMut(PolygonId)) {
        let facet = &self.facets[f as usize];
        let t = (facet.d - facet.n.dot(o)) / facet.n.dot(dir);
        if !(t > 0.0 && t < f32::INFINITY) {
            return;
        }
        let p = o + dir * t;
        self.for_each_near(f, p, r, call)
    }

    /// Calls `f` with each polygon of facet `f` (of several) whose outline comes within
    /// `r` of `p`'s projection on the facet's plane (a polygon may be called more than
    /// once).
    pub fn for_each_near(&self, f: u32, p: Vec3, r: f32, mut call: impl FnMut(PolygonId)) {
        let facet = &self.facets[f as usize];
        let (x, y) = (p.dot(facet.axes[0]), p.dot(facet.axes[1]));
        let (dims_x, dims_y) = (facet.dims[0] as f32, facet.dims[1] as f32);
        let lo = [
            (x - r - facet.lo[0]) * facet.inv_cell,
            (y - r - facet.lo[1]) * facet.inv_cell,
        ];
        let hi = [
            (x + r - facet.lo[0]) * facet.inv_cell,
            (y + r - facet.lo[1]) * facet.inv_cell,
        ];
        // (NaN fails these.)
        if !(hi[0] >= 0.0 && hi[1] >= 0.0 && lo[0] < dims_x && lo[1] < dims_y) {
            return;
        }
        let span = |a: f32, b: f32, d: f32| a.max(0.0) as u32..=b.min(d - 1.0) as u32;
        for j in span(lo[1], hi[1], dims_y) {
            for i in span(lo[0], hi[0], dims_x) {
                let c = facet.first_cell + j * facet.dims[0] + i;
                self.for_each_in_cell(c, |slot| {
                    if self.inside_by(slot, x, y) >= -r {
                        call(self.edges[slot as usize].polygon);
                    }
                });
            }
        }
    }

    /// The side of facet `f`'s grid cells (world units; 0 for a facet of one).
    pub fn cell_size(&self, f: u32) -> f32 {
        let inv = self.facets[f as usize].inv_cell;
        if inv > 0.0 {
            1.0 / inv
        } else {
            0.0
        }
    }
}

/// Of 4 × 4 points spread over the grid cell of side `cell` at (x0, y0), how many lie
/// inside the polygon of edges `lines`.
fn coverage(lines: &[[f64; 3]], x0: f64, y0: f64, cell: f64) -> u32 {
    let mut n = 0;
    for a in 0..4 {
        for b in 0..4 {
            let (x, y) = (
                x0 + (a as f64 + 0.5) * 0.25 * cell,
                y0 + (b as f64 + 0.5) * 0.25 * cell,
            );
            n += u32::from(
                lines
                    .iter()
                    .all(|&[la, lb, lc]| la * x + lb * y + lc >= 0.0),
            );
        }
    }
    n
}

/// The sine of half the sharpest angle of the polygon of corners `vs` (in order).
fn sharpest_sin_half(vs: &[DVec2]) -> f64 {
    let n = vs.len();
    (0..n)
        .map(|k| {
            let (a, b, c) = (vs[(k + n - 1) % n], vs[k], vs[(k + 1) % n]);
            let (e0, e1) = ((a - b).normalize_or_zero(), (c - b).normalize_or_zero());
            (0.5 * e0.dot(e1).clamp(-1.0, 1.0).acos()).sin()
        })
        .fold(1.0, f64::min)
}

/// Working memory of [`Facets::locate_span`].
#[derive(Clone, Debug, Default)]
pub struct LocateScratch {
    x: Vec<f32>,
    y: Vec<f32>,
    t: Vec<f32>,
    cell: Vec<u32>,
}

/// A polygon's plane, in f64, with the tolerances of [`FACET_TILT`].
struct Plane {
    n: DVec3,
    d: f64,
    reach: f64,
}

impl Plane {
    fn of(p: &Polygon) -> Plane {
        let n = p.normal().as_dvec3();
        let v0 = p.vertices()[0].as_dvec3();
        let reach = p
            .vertices()
            .iter()
            .map(|v| (v.as_dvec3() - v0).length())
            .fold(0.0, f64::max);
        Plane {
            n,
            d: n.dot(v0),
            reach,
        }
    }

    /// Whether `q` lies in this plane, facing its way: normals within [`FACET_TILT`],
    /// every vertex within `FACET_TILT` times the plane's polygon's size of it.
    fn holds(&self, q: &Polygon) -> bool {
        let nq = q.normal().as_dvec3();
        self.n.dot(nq) > 0.0
            && self.n.cross(nq).length() <= FACET_TILT
            && q.vertices()
                .iter()
                .all(|v| (self.n.dot(v.as_dvec3()) - self.d).abs() <= FACET_TILT * self.reach)
    }
}
