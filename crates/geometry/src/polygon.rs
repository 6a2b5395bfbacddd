//! Planar convex polygons with their patch textures: validation, ray intersection, and
//! the O(1) map from a hit's (u, v) to a patch id.

use crate::clip::{clip_convex, polygon_area_centroid};
use crate::error::PolygonProblem;
use glam::{DVec3, Vec3};
use rad_core::{Frame, PatchId};

/// Largest deviation from planarity accepted, as a fraction of the polygon's diameter.
pub const PLANARITY_TOLERANCE: f64 = 1e-4;
/// Largest patch grid accepted on one polygon (cells, nu · nv).
pub const MAX_CELLS_PER_POLYGON: u64 = 1 << 24;

/// The largest coordinate magnitude a vertex may have: the f32 ray tests square
/// distances and multiply coordinates, which overflow f32 (3.4e38) not far above
/// (1e18)² with the margins of the sums.
pub const MAX_COORDINATE: f64 = 1e18;

/// The smallest a polygon may be, as a diameter, absolutely (below it, squared
/// distances and the inside tolerance fall into f32's subnormal range and lose their
/// precision)...
pub const MIN_POLYGON_SIZE: f64 = 1e-12;

/// ...and relative to its largest coordinate magnitude: the inside tests grow every
/// polygon by 4e-6 of its coordinates (so that shared edges leave no crack), so a
/// polygon smaller than that is narrower than its own tolerance, its shape lost. (A
/// 30 m building in millimetres may have details down to 0.12 mm.)
pub const MIN_POLYGON_SIZE_RELATIVE: f64 = 4e-6;

/// A clipped cell smaller than this fraction of a whole cell is no patch.
const MIN_CELL_FRACTION: f64 = 1e-9;

/// A polygon's (u, v) parametrisation: `p = origin + u·e_u + v·e_v`.
///
/// For a triangle or a parallelogram u runs along the edge from vertex 0 to vertex 1, v
/// along the edge from vertex 0 to the last vertex; for any other polygon (u, v) span its
/// smallest bounding rectangle (see [`texture_axes`]). The normal is `e_u × e_v`
/// normalised, and the vertices turn counter-clockwise seen from the side it points to.
#[derive(Clone, Debug)]
pub struct Polygon {
    // Hot fields first: they are all an intersection reads.
    normal: Vec3,
    plane_d: f32,
    origin: Vec3,
    du: Vec3,
    dv: Vec3,
    eps_u: f32,
    eps_v: f32,
    eps: f32,
    /// Largest distance a vertex may lie off the plane (the planarity tolerance).
    off_plane: f32,
    parallelogram: bool,
    /// Seen only from its front (a side of a two-sided polygon): see
    /// [`Polygon::front_only`].
    front_only: bool,
    /// Inward edge functions in (u, v): `a·u + b·v + c` is the distance (world units)
    /// inside the edge's line.
    edges: Vec<[f32; 3]>,
    nu: u32,
    nv: u32,
    /// Cell of (u, v): `i = ⌊(u − grid_map[0])·grid_map[1]⌋`, `j` likewise with [2], [3].
    grid_map: [f32; 4],
    first_patch: PatchId,
    /// Patch of each cell (`j·nu + i`); a cell with no area holds its nearest patch of
    /// the same row (or of the nearest non-empty row), so lookups are total.
    cell_patch: Vec<PatchId>,
    // Cold fields.
    name: String,
    vertices: Vec<Vec3>,
    uv_vertices: Vec<[f64; 2]>,
    e_u: Vec3,
    e_v: Vec3,
    frame: Frame,
    material: u32,
    area: f64,
    /// The patch texture in f64: the (u, v) box the grid spans, the cell sizes, and the
    /// frame (origin, e_u, e_v) its patches' corners and centres were placed with.
    uv_box: [f64; 4],
    cell_size: [f64; 2],
    frame64: [DVec3; 3],
}

/// One patch: a (clipped) cell of a polygon's patch texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    pub polygon: u32,
    /// Cell (i, j) in the polygon's patch texture, i along u.
    pub cell: [u32; 2],
    /// Centroid of the clipped cell.
    pub center: Vec3,
    pub normal: Vec3,
    /// The clipped cell's corners, counter-clockwise seen from the normal's side.
    pub corners: Vec<Vec3>,
    pub area: f64,
    /// True when the cell touches the polygon's boundary (clipped, or a grid edge).
    pub on_boundary: bool,
}

/// A polygon's patches, as built with it.
pub(crate) struct Built {
    pub polygon: Polygon,
    pub patches: Vec<Patch>,
}

impl Polygon {
    /// Validates `vertices` and builds the polygon with an `nu × nv` patch texture whose
    /// patches are numbered from `first_patch`.
    pub(crate) fn build(
        name: String,
        vertices: Vec<Vec3>,
        material: u32,
        nu: u64,
        nv: u64,
        first_patch: PatchId,
    ) -> Result<Built, PolygonProblem> {
        let n_vertices = vertices.len();
        let (pts, normal, diameter, area) = validated(&vertices, nu, nv)?;
        let (origin, e_u, e_v, parallelogram) =
            texture_axes(&pts, normal, diameter).ok_or(PolygonProblem::Degenerate { area })?;
        let cross = e_u.cross(e_v);
        let par_area = cross.dot(normal);
        // Dual basis: u = (p − o)·du, v = (p − o)·dv.
        let du = e_v.cross(normal) / e_v.cross(normal).dot(e_u);
        let dv = normal.cross(e_u) / normal.cross(e_u).dot(e_v);
        let uv_vertices: Vec<[f64; 2]> = pts
            .iter()
            .map(|p| [(*p - origin).dot(du), (*p - origin).dot(dv)])
            .collect();
        // Inward edge functions, scaled to world distance.
        let edges: Vec<[f32; 3]> = (0..n_vertices)
            .map(|k| {
                let a = pts[k];
                let b = pts[(k + 1) % n_vertices];
                let m = normal.cross((b - a).normalize());
                [
                    m.dot(e_u) as f32,
                    m.dot(e_v) as f32,
                    m.dot(origin - a) as f32,
                ]
            })
            .collect();
        let max_coord = pts
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        let eps = (4e-6 * (max_coord + diameter)) as f32;
        let off_plane = (PLANARITY_TOLERANCE * diameter) as f32;

        // Patch texture.
        let (nu32, nv32) = (nu as u32, nv as u32);
        let frame = TextureFrame {
            origin,
            e_u,
            e_v,
            par_area,
            normal,
        };
        let (cell_patch, patches, uv_box, cu, cv) =
            patch_texture(&frame, &uv_vertices, parallelogram, nu32, nv32, first_patch);
        if patches.is_empty() {
            // Only an outline at the edge of the tolerances (a sliver whose slight
            // concavity the convexity test forgives at its scale) leaves no cell with area.
            return Err(PolygonProblem::EmptyTexture { nu, nv });
        }
        let normal_f = normal.as_vec3();

        let e_u_f = e_u.as_vec3();
        let polygon = Polygon {
            normal: normal_f,
            plane_d: normal.dot(origin) as f32,
            origin: origin.as_vec3(),
            du: du.as_vec3(),
            dv: dv.as_vec3(),
            eps_u: (eps as f64 * du.length()) as f32,
            eps_v: (eps as f64 * dv.length()) as f32,
            eps,
            off_plane,
            parallelogram,
            edges,
            front_only: false,
            nu: nu32,
            nv: nv32,
            grid_map: [
                uv_box[0] as f32,
                (1.0 / cu) as f32,
                uv_box[2] as f32,
                (1.0 / cv) as f32,
            ],
            first_patch,
            cell_patch,
            name,
            vertices,
            uv_vertices,
            e_u: e_u_f,
            e_v: e_v.as_vec3(),
            frame: Frame::from_normal_edge(normal_f, e_u_f),
            material,
            area,
            uv_box,
            cell_size: [cu, cv],
            frame64: [origin, e_u, e_v],
        };
        Ok(Built { polygon, patches })
    }

    /// Whether it is seen only from its front: a side of a two-sided polygon, whose
    /// other side is its reverse, coplanar, back to back. No ray meets it from behind,
    /// nor from an origin within its reach of its plane (so neither side is ever met
    /// from the other's patches, and a ray meeting the pair takes the side it faces,
    /// whatever the ids); from in front it is tested as any polygon.
    #[inline]
    pub fn front_only(&self) -> bool {
        self.front_only
    }

    pub(crate) fn set_front_only(&mut self, front_only: bool) {
        self.front_only = front_only;
    }

    /// `d − n·o` for the plane `n·p = d`: [`crate::OriginTerms::num`] at `o`, negative
    /// where `o` is in front of the plane.
    #[inline]
    pub fn plane_num(&self, o: Vec3) -> f32 {
        self.plane_d - self.normal.dot(o)
    }

    /// Its one patch, for a polygon of one ([`Polygon::patches_at`] needs no lookup);
    /// else None.
    pub fn one_patch(&self) -> Option<PatchId> {
        (self.nu == 1 && self.nv == 1).then_some(self.first_patch)
    }

    /// [`Polygon::patch_at`] of many parameters at once: `out[k] = patch_at(u[k], v[k])`,
    /// the same arithmetic in a branch-free loop that vectorises (compiled for AVX2 and
    /// AVX-512 too, chosen at run time, with gathers for the patch texture).
    ///
    /// # Panics
    /// If the three slices differ in length.
    #[inline]
    pub fn patches_at(&self, u: &[f32], v: &[f32], out: &mut [PatchId]) {
        assert!(
            u.len() == out.len() && v.len() == out.len(),
            "one patch per (u, v)"
        );
        if self.nu == 1 && self.nv == 1 {
            // One cell, the polygon's one patch (a mesh's usual case): no lookup.
            debug_assert_eq!(self.cell_patch, [self.first_patch]);
            out.fill(self.first_patch);
            return;
        }
        self.patches_at_dispatch(u, v, out);
    }

    /// [`Polygon::patches_at`] of a polygon of several cells, compiled for the CPU.
    fn patches_at_dispatch(&self, u: &[f32], v: &[f32], out: &mut [PatchId]) {
        rad_core::with_isa!(rad_core::Isa::detect(), |ISA| fn(
            poly: &Polygon = self,
            u: &[f32] = u,
            v: &[f32] = v,
            out: &mut [PatchId] = out,
        ) {
            poly.patches_at_body(u, v, out)
        })
    }

    #[inline(always)]
    fn patches_at_body(&self, u: &[f32], v: &[f32], out: &mut [PatchId]) {
        let [u0, su, v0, sv] = self.grid_map;
        let (nu1, nv1) = ((self.nu - 1) as f32, (self.nv - 1) as f32);
        let n = out.len();
        let (u, v) = (&u[..n], &v[..n]);
        let table = &self.cell_patch[..];
        debug_assert!(table.len() == (self.nu * self.nv) as usize);
        for k in 0..n {
            // As in `cell_at`.
            let fi = ((u[k] - u0) * su).max(0.0).min(nu1);
            let fj = ((v[k] - v0) * sv).max(0.0).min(nv1);
            // SAFETY: fi and fj are finite and in [0, n − 1] (`max` drops a NaN), so
            // j·nu + i indexes the nu × nv texture.
            out[k] = unsafe {
                let (i, j) = (fi.to_int_unchecked::<u32>(), fj.to_int_unchecked::<u32>());
                *table.get_unchecked((j * self.nu + i) as usize)
            };
        }
    }

    /// The inside test for hits on the back side: the polygon shrunk by the tolerance
    /// that [`Polygon::contains_uv`] grows it by. Front faces grow so that polygons
    /// sharing an edge leave no crack; back faces shrink so that a ray meeting a box's
    /// edge from outside (or grazing it) takes the front face there, never the back of
    /// the face beyond it.
    #[inline]
    pub fn contains_uv_back(&self, u: f32, v: f32) -> bool {
        if self.parallelogram {
            u >= self.eps_u && v >= self.eps_v && u <= 1.0 - self.eps_u && v <= 1.0 - self.eps_v
        } else {
            self.edges
                .iter()
                .all(|e| e[0] * u + e[1] * v + e[2] >= self.eps)
        }
    }

    /// True when parameters (u, v) lie inside the polygon, or within a few ulps of the
    /// scene's scale outside it (so that polygons sharing an edge leave no crack).
    #[inline]
    pub fn contains_uv(&self, u: f32, v: f32) -> bool {
        if self.parallelogram {
            u >= -self.eps_u && v >= -self.eps_v && u <= 1.0 + self.eps_u && v <= 1.0 + self.eps_v
        } else {
            self.edges
                .iter()
                .all(|e| e[0] * u + e[1] * v + e[2] >= -self.eps)
        }
    }

    /// Dual basis of (e_u, e_v) in the plane: `u = (p − origin)·du`, `v = (p − origin)·dv`.
    pub fn dual_basis(&self) -> (Vec3, Vec3) {
        (self.du, self.dv)
    }

    /// Bounds `[u_lo, u_hi, v_lo, v_hi]` of a parallelogram in (u, v), widened by the
    /// tolerance of [`Polygon::contains_uv`] (being inside them is being inside it);
    /// unbounded for other polygons, whose edge functions decide.
    pub fn uv_bounds(&self) -> [f32; 4] {
        if self.parallelogram {
            // The very f32 sums of `contains_uv`, so that both agree to the bit.
            [-self.eps_u, 1.0 + self.eps_u, -self.eps_v, 1.0 + self.eps_v]
        } else {
            // Near an acute corner the edge tolerance reaches past any (u, v) box grown
            // by eps_u, eps_v: leave the test to the edge functions.
            [
                f32::NEG_INFINITY,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::INFINITY,
            ]
        }
    }

    /// How far outside its edges a front-face hit is still accepted, and how far inside
    /// them a back-face hit must be, in the units of [`Polygon::edge_functions`]
    /// (what [`Polygon::contains_uv`] and [`Polygon::contains_uv_back`] compare with).
    pub fn edge_tolerance(&self) -> f32 {
        self.eps
    }

    /// How far outside its edges a front-face hit is still accepted, plus how far a
    /// vertex may lie off the polygon's plane: no hit on this polygon lies farther than
    /// this from the convex hull of its vertices.
    pub fn reach(&self) -> f32 {
        self.eps + self.off_plane
    }

    /// How far from the convex hull of its vertices a front hit this polygon's test
    /// accepts may lie: its [`Polygon::reach`] grows, at an acute corner, to twice that
    /// over the sine of half the corner's angle (a sliver's tolerance reaches far along
    /// it). What an accelerator pads a polygon's box by.
    pub fn hull_reach(&self) -> f64 {
        let vs: Vec<glam::DVec3> = self.vertices.iter().map(|v| v.as_dvec3()).collect();
        reach_past_corners(self.reach(), &vs)
    }

    /// Its box for a ray tree: its vertices' grown by `grow` and four times its test's
    /// reach, or farther at an acute corner ([`Polygon::hull_reach`]): every point its
    /// hit test accepts lies well inside.
    pub fn tree_box(&self, grow: f32) -> (Vec3, Vec3) {
        let (lo, hi) = self
            .vertices
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        let reach = (self.reach() * 4.0).max(2.0 * self.hull_reach() as f32);
        (lo - grow - reach, hi + grow + reach)
    }

    /// True when every vertex lies behind the plane through `o` with normal `n` by more
    /// than [`Polygon::reach`]: rays leaving that plane forwards from `o` cannot hit it.
    /// The voxel grid culls such polygons for a hemisphere's rays, and the polygon scan
    /// skips exactly the same ones.
    pub fn wholly_behind(&self, o: glam::DVec3, n: glam::DVec3) -> bool {
        let reach = self.reach() as f64;
        self.vertices
            .iter()
            .all(|v| (v.as_dvec3() - o).dot(n) < -reach)
    }

    /// Plane offset `d` with the plane `normal · p = d`.
    pub fn plane_offset(&self) -> f32 {
        self.plane_d
    }

    /// The patch containing parameters (u, v): O(1), through the patch texture, whose
    /// `nu × nv` cells span the polygon's (u, v) bounding box. Points slightly outside
    /// are clamped to the nearest cell.
    #[inline]
    pub fn patch_at(&self, u: f32, v: f32) -> PatchId {
        let (i, j) = self.cell_at(u, v);
        self.cell_patch[(j * self.nu + i) as usize]
    }

    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn vertices(&self) -> &[Vec3] {
        &self.vertices
    }
    /// Vertices in (u, v) coordinates (in the edge frame of a triangle or parallelogram,
    /// vertex 0 is (0, 0), vertex 1 is (1, 0), the last (0, 1); in a bounding rectangle's
    /// frame they lie in [0, 1]²).
    pub fn uv_vertices(&self) -> &[[f64; 2]] {
        &self.uv_vertices
    }
    pub fn normal(&self) -> Vec3 {
        self.normal
    }
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
    pub fn e_u(&self) -> Vec3 {
        self.e_u
    }
    pub fn e_v(&self) -> Vec3 {
        self.e_v
    }
    /// Hemisphere frame of the polygon's patches: t along e_u, n the normal.
    pub fn frame(&self) -> Frame {
        self.frame
    }
    pub fn material(&self) -> u32 {
        self.material
    }
    pub fn area(&self) -> f64 {
        self.area
    }
    /// Patch-texture size (nu, nv).
    pub fn grid(&self) -> (u32, u32) {
        (self.nu, self.nv)
    }
    /// The patch of cell (i, j); a cell with no area gives its nearest patch.
    ///
    /// # Panics
    /// If the cell is outside the grid.
    pub fn cell_patch(&self, i: u32, j: u32) -> PatchId {
        assert!(
            i < self.nu && j < self.nv,
            "cell ({i}, {j}) outside the patch grid"
        );
        self.cell_patch[(j * self.nu + i) as usize]
    }

    /// Continuous cell coordinates of (u, v), not clamped: cell (i, j) spans
    /// `[i, i + 1) × [j, j + 1)`.
    pub fn cell_coords(&self, u: f32, v: f32) -> (f32, f32) {
        let [u0, su, v0, sv] = self.grid_map;
        ((u - u0) * su, (v - v0) * sv)
    }

    /// Cell (i, j) of parameters (u, v), clamped to the grid.
    pub fn cell_at(&self, u: f32, v: f32) -> (u32, u32) {
        let [u0, su, v0, sv] = self.grid_map;
        // Clamped in f32 first: `max` drops a NaN (to 0), and (n − 1) is exact in f32
        // (n ≤ 2^24), so the truncation below is in range; the same cells as truncating
        // to an integer and clamping that.
        let fi = ((u - u0) * su).max(0.0).min((self.nu - 1) as f32);
        let fj = ((v - v0) * sv).max(0.0).min((self.nv - 1) as f32);
        debug_assert!((0.0..=(MAX_CELLS_PER_POLYGON as f32)).contains(&fi));
        // SAFETY: fi and fj are finite and in [0, n − 1] ⊂ u32's range.
        unsafe { (fi.to_int_unchecked::<u32>(), fj.to_int_unchecked::<u32>()) }
    }
    pub fn first_patch(&self) -> PatchId {
        self.first_patch
    }
    pub fn is_parallelogram(&self) -> bool {
        self.parallelogram
    }
    /// Inward edge functions in (u, v): `a·u + b·v + c` is the world distance inside
    /// each edge's line (what [`Polygon::contains_uv`] tests, within its tolerance).
    pub fn edge_functions(&self) -> &[[f32; 3]] {
        &self.edges
    }
    /// `n × n` points spread over the patch of cell `cell`, each with its share of the
    /// patch's area: the centroids of the cell's `n × n` equal sub-cells clipped to the
    /// polygon (those with no area left out), their areas over their sum (so the
    /// shares add up to 1). Averaging a quantity over them is the midpoint rule over
    /// the patch. With `n = 1`, the one point is the patch's centre.
    pub fn patch_origins(&self, cell: [u32; 2], n: u32) -> Vec<(Vec3, f64)> {
        let [o, e_u, e_v] = self.frame64;
        let [cu, cv] = self.cell_size;
        // Sub-cell edges k = 0..=n along each axis; the first and last are the cell's
        // own edges, computed as the patch texture computes them.
        let edge = |k: u32, i: u32, lo: f64, size: f64| {
            if k == n {
                lo + f64::from(i + 1) * size
            } else {
                let base = lo + f64::from(i) * size;
                base + size * f64::from(k) / f64::from(n)
            }
        };
        let u_at = |k| edge(k, cell[0], self.uv_box[0], cu);
        let v_at = |k| edge(k, cell[1], self.uv_box[2], cv);
        let mut out = Vec::with_capacity((n * n) as usize);
        let mut total = 0.0;
        for b in 0..n {
            let (v0, v1) = (v_at(b), v_at(b + 1));
            for a in 0..n {
                let (u0, u1) = (u_at(a), u_at(a + 1));
                let square = vec![[u0, v0], [u1, v0], [u1, v1], [u0, v1]];
                let piece = if self.parallelogram {
                    square
                } else {
                    clip_convex(&square, &self.uv_vertices)
                };
                let (area, c) = polygon_area_centroid(&piece);
                if area > MIN_CELL_FRACTION * cu * cv / f64::from(n * n) {
                    total += area;
                    out.push(((o + e_u * c[0] + e_v * c[1]).as_vec3(), area));
                }
            }
        }
        if out.is_empty() && n > 1 {
            // A sliver patch whose sub-cells all fall under the size limit: its centre.
            return self.patch_origins(cell, 1);
        }
        for p in &mut out {
            p.1 /= total;
        }
        out
    }

    /// Position of parameters (u, v).
    pub fn point(&self, u: f32, v: f32) -> Vec3 {
        self.origin + self.e_u * u + self.e_v * v
    }
    /// Parameters of point `p` (projected onto the plane).
    pub fn uv(&self, p: Vec3) -> (f32, f32) {
        let r = p - self.origin;
        (r.dot(self.du), r.dot(self.dv))
    }
}

/// The (u, v) frame of a valid polygon: `(origin, e_u, e_v, parallelogram)`, with
/// `e_u × e_v` along `normal`.
///
/// A triangle or a parallelogram keeps its edge frame (origin at vertex 0, e_u to vertex
/// 1, e_v to the last vertex: its cells are the polygon's own shape, cut evenly). Any
/// other polygon gets its smallest-area bounding rectangle in its plane (one side along
/// one of its edges, the first edge on ties; origin at the rectangle's corner in the
/// plane of vertex 0; e_u and e_v its sides), so that a many-sided polygon, whose first
/// and last edges may be short and nearly opposite, still gets cells of the requested
/// size and shape. `None` when a triangle's edges from vertex 0 span no area.
pub(crate) fn texture_axes(
    pts: &[DVec3],
    normal: DVec3,
    diameter: f64,
) -> Option<(DVec3, DVec3, DVec3, bool)> {
    let n = pts.len();
    let origin = pts[0];
    let e_u = pts[1] - origin;
    let e_v = pts[n - 1] - origin;
    let cross = e_u.cross(e_v).dot(normal);
    // A valid triangle (area over 1e-12 d², checked) always has its edge frame.
    if n == 3 {
        return (cross > 0.0).then_some((origin, e_u, e_v, false));
    }
    if cross > 1e-9 * diameter * diameter {
        if n == 4 {
            let du = e_v.cross(normal) / e_v.cross(normal).dot(e_u);
            let dv = normal.cross(e_u) / normal.cross(e_u).dot(e_v);
            let (u2, v2) = ((pts[2] - origin).dot(du), (pts[2] - origin).dot(dv));
            if (u2 - 1.0).abs() < 1e-6 && (v2 - 1.0).abs() < 1e-6 {
                return Some((origin, e_u, e_v, true));
            }
        }
    }
    let mut best: Option<(f64, DVec3, DVec3, [f64; 4])> = None;
    for k in 0..n {
        let edge = pts[(k + 1) % n] - pts[k];
        let a = edge - normal * edge.dot(normal);
        if !(a.length() > 1e-9 * diameter) {
            continue;
        }
        let a = a.normalize();
        let b = normal.cross(a);
        let mut ext = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for p in pts {
            let (s, t) = ((*p - origin).dot(a), (*p - origin).dot(b));
            ext = [ext[0].min(s), ext[1].max(s), ext[2].min(t), ext[3].max(t)];
        }
        let area = (ext[1] - ext[0]) * (ext[3] - ext[2]);
        // Ties (within 1e-6: far past the rounding of f32 input) go to the first edge.
        if best.is_none_or(|(best_area, ..)| area < best_area * (1.0 - 1e-6)) {
            best = Some((area, a, b, ext));
        }
    }
    let (_, a, b, ext) = best?;
    Some((
        origin + a * ext[0] + b * ext[2],
        a * (ext[1] - ext[0]),
        b * (ext[3] - ext[2]),
        false,
    ))
}

/// The lengths of the sides of a polygon's (u, v) frame ([`texture_axes`]), for sizing
/// its patch grid; `None` when its vertices make no valid polygon (its own checks then
/// name the problem).
pub(crate) fn texture_side_lengths(vertices: &[Vec3]) -> Option<(f64, f64)> {
    texture_sides(vertices).map(|(e_u, e_v)| (e_u.length(), e_v.length()))
}

/// The sides (e_u, e_v) of a polygon's (u, v) frame ([`texture_axes`]); `None` as for
/// [`texture_side_lengths`].
pub(crate) fn texture_sides(vertices: &[Vec3]) -> Option<(DVec3, DVec3)> {
    let pts: Vec<DVec3> = vertices.iter().map(|p| p.as_dvec3()).collect();
    if pts.len() < 3 || !pts.iter().all(|p| p.is_finite()) {
        return None;
    }
    let mut newell = DVec3::ZERO;
    for k in 0..pts.len() {
        newell += pts[k].cross(pts[(k + 1) % pts.len()]);
    }
    let diameter = pts
        .iter()
        .flat_map(|a| pts.iter().map(move |b| (*a - *b).length()))
        .fold(0.0, f64::max);
    if !(newell.length() > 0.0) || !(diameter > 0.0) {
        return None;
    }
    let (_, e_u, e_v, _) = texture_axes(&pts, newell.normalize(), diameter)?;
    Some((e_u, e_v))
}

/// Checks `vertices` and the grid size: (the vertices in f64, the unit normal, the
/// diameter, the area).
fn validated(
    vertices: &[Vec3],
    nu: u64,
    nv: u64,
) -> Result<(Vec<DVec3>, DVec3, f64, f64), PolygonProblem> {
    let n_vertices = vertices.len();
    if n_vertices < 3 {
        return Err(PolygonProblem::TooFewVertices { count: n_vertices });
    }
    if let Some((vertex, p)) = vertices.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(PolygonProblem::NonFinite {
            vertex,
            value: p.to_array(),
        });
    }
    let pts: Vec<DVec3> = vertices.iter().map(|p| p.as_dvec3()).collect();
    // Newell's normal: robust for any planar polygon; its length is twice the area.
    let mut newell = DVec3::ZERO;
    for k in 0..n_vertices {
        newell += pts[k].cross(pts[(k + 1) % n_vertices]);
    }
    let diameter = pts
        .iter()
        .flat_map(|a| pts.iter().map(move |b| (*a - *b).length()))
        .fold(0.0, f64::max);
    // The numeric range the f32 ray tests resolve.
    if let Some((vertex, p)) = pts
        .iter()
        .enumerate()
        .find(|(_, p)| p.abs().max_element() > MAX_COORDINATE)
    {
        return Err(PolygonProblem::OutOfRange {
            vertex,
            value: p.abs().max_element(),
            limit: MAX_COORDINATE,
        });
    }
    let extent = pts
        .iter()
        .map(|p| p.abs().max_element())
        .fold(0.0, f64::max);
    let min_size = MIN_POLYGON_SIZE.max(MIN_POLYGON_SIZE_RELATIVE * extent);
    if diameter > 0.0 && diameter < min_size {
        return Err(PolygonProblem::TooSmall {
            diameter,
            limit: min_size,
            coordinate: extent,
        });
    }
    let area = 0.5 * newell.length();
    let min_edge = (0..n_vertices)
        .map(|k| (pts[(k + 1) % n_vertices] - pts[k]).length())
        .fold(f64::INFINITY, f64::min);
    if !(area > 1e-12 * diameter * diameter) || diameter == 0.0 || !(min_edge > 1e-9 * diameter) {
        return Err(PolygonProblem::Degenerate { area });
    }
    let normal = newell / newell.length();
    let centroid = pts.iter().copied().sum::<DVec3>() / n_vertices as f64;
    let tolerance = PLANARITY_TOLERANCE * diameter;
    for (vertex, p) in pts.iter().enumerate() {
        let deviation = (*p - centroid).dot(normal).abs();
        if deviation > tolerance {
            return Err(PolygonProblem::NonPlanar {
                vertex,
                deviation,
                tolerance,
                rel_tolerance: PLANARITY_TOLERANCE,
            });
        }
    }
    // Convex, with every turn the same way as the normal (collinear vertices allowed),
    // and winding once: every vertex on the inner side of every edge (a star, whose
    // turns all agree, fails this).
    for k in 0..n_vertices {
        let a = pts[k];
        let b = pts[(k + 1) % n_vertices];
        let c = pts[(k + 2) % n_vertices];
        let turn = (b - a).cross(c - b).dot(normal);
        if turn < -1e-9 * diameter * diameter {
            return Err(PolygonProblem::NonConvex {
                vertex: (k + 1) % n_vertices,
            });
        }
        let inward = normal.cross(b - a);
        if let Some(vertex) =
            (0..n_vertices).find(|&m| (pts[m] - a).dot(inward) < -1e-9 * diameter * diameter)
        {
            return Err(PolygonProblem::NonConvex { vertex });
        }
    }
    if nu == 0 || nv == 0 {
        return Err(PolygonProblem::ZeroPatchGrid { nu, nv });
    }
    if nu.saturating_mul(nv) > MAX_CELLS_PER_POLYGON {
        return Err(PolygonProblem::PatchGridTooLarge {
            nu,
            nv,
            limit: MAX_CELLS_PER_POLYGON,
        });
    }
    Ok((pts, normal, diameter, area))
}

/// Where a polygon's patch texture lies: its (u, v) frame's origin and edges
/// ([`texture_axes`]), the area of their parallelogram and the unit normal.
struct TextureFrame {
    origin: DVec3,
    e_u: DVec3,
    e_v: DVec3,
    par_area: f64,
    normal: DVec3,
}

/// The `nu × nv` patch texture over the (u, v) box of `uv_vertices` (clipped to the
/// polygon unless a parallelogram), its patches numbered from `first_patch`: (cell →
/// patch, the patches, the (u, v) box, the cell sizes).
#[allow(clippy::type_complexity)]
fn patch_texture(
    frame: &TextureFrame,
    uv_vertices: &[[f64; 2]],
    parallelogram: bool,
    nu32: u32,
    nv32: u32,
    first_patch: PatchId,
) -> (Vec<PatchId>, Vec<Patch>, [f64; 4], f64, f64) {
    let TextureFrame {
        origin,
        e_u,
        e_v,
        par_area,
        normal,
    } = *frame;
    let (nu, nv) = (u64::from(nu32), u64::from(nv32));
    // The grid spans the polygon's (u, v) bounding box: [0, 1]² for a parallelogram
    // (or any polygon whose vertices lie in it), wider for e.g. a trapezoid.
    let mut uv_box = [0.0f64, 1.0, 0.0, 1.0];
    for [u, v] in uv_vertices {
        uv_box = [
            uv_box[0].min(*u),
            uv_box[1].max(*u),
            uv_box[2].min(*v),
            uv_box[3].max(*v),
        ];
    }
    if parallelogram {
        uv_box = [0.0, 1.0, 0.0, 1.0];
    }
    let (cu, cv) = (
        (uv_box[1] - uv_box[0]) / nu as f64,
        (uv_box[3] - uv_box[2]) / nv as f64,
    );
    let cell_full = cu * cv;
    let mut cell_patch = vec![PatchId::MAX; (nu * nv) as usize];
    let mut patches = Vec::new();
    let normal_f = normal.as_vec3();
    let world = |uv: [f64; 2]| (origin + e_u * uv[0] + e_v * uv[1]).as_vec3();
    let mut shapes: Vec<Option<Vec<[f64; 2]>>> = vec![None; (nu * nv) as usize];
    for j in 0..nv32 {
        for i in 0..nu32 {
            let (u0, u1) = (uv_box[0] + i as f64 * cu, uv_box[0] + (i + 1) as f64 * cu);
            let (v0, v1) = (uv_box[2] + j as f64 * cv, uv_box[2] + (j + 1) as f64 * cv);
            let square = vec![[u0, v0], [u1, v0], [u1, v1], [u0, v1]];
            let cell = if parallelogram {
                square
            } else {
                clip_convex(&square, &uv_vertices)
            };
            let idx = (j * nu32 + i) as usize;
            let (a, _) = polygon_area_centroid(&cell);
            if a > MIN_CELL_FRACTION * cell_full {
                shapes[idx] = Some(cell);
            }
        }
    }
    for j in 0..nv32 {
        for i in 0..nu32 {
            let idx = (j * nu32 + i) as usize;
            let Some(cell) = &shapes[idx] else { continue };
            let (a_uv, c_uv) = polygon_area_centroid(cell);
            let has = |ii: i64, jj: i64| {
                ii >= 0
                    && jj >= 0
                    && ii < nu as i64
                    && jj < nv as i64
                    && shapes[(jj as u64 * nu + ii as u64) as usize].is_some()
            };
            let (ii, jj) = (i as i64, j as i64);
            let on_boundary = a_uv < cell_full * (1.0 - 1e-9)
                || !has(ii - 1, jj)
                || !has(ii + 1, jj)
                || !has(ii, jj - 1)
                || !has(ii, jj + 1);
            cell_patch[idx] = first_patch + patches.len() as PatchId;
            patches.push(Patch {
                polygon: 0, // set by the scene
                cell: [i, j],
                center: world(c_uv),
                normal: normal_f,
                corners: cell.iter().map(|&p| world(p)).collect(),
                area: a_uv * par_area,
                on_boundary,
            });
        }
    }
    if !patches.is_empty() {
        fill_empty_cells(&mut cell_patch, nu32, nv32);
    }
    (cell_patch, patches, uv_box, cu, cv)
}

/// Gives each patch-less cell the patch of the nearest non-empty cell of its row (or of
/// the nearest non-empty row): the cells of a convex polygon on a row are contiguous.
fn fill_empty_cells(cell_patch: &mut [PatchId], nu: u32, nv: u32) {
    let (nu, nv) = (nu as usize, nv as usize);
    let row_range = |cp: &[PatchId], j: usize| {
        let row = &cp[j * nu..(j + 1) * nu];
        let first = row.iter().position(|&p| p != PatchId::MAX)?;
        let last = row.iter().rposition(|&p| p != PatchId::MAX)?;
        Some((first, last))
    };
    let ranges: Vec<Option<(usize, usize)>> = (0..nv).map(|j| row_range(cell_patch, j)).collect();
    // The nearest row with patches at or below each row, and at or above it (one pass
    // each way, so that a grid of many rows costs linear time).
    let mut below = vec![None; nv];
    let mut last = None;
    for j in 0..nv {
        if ranges[j].is_some() {
            last = Some(j);
        }
        below[j] = last;
    }
    let mut above = vec![None; nv];
    let mut next = None;
    for j in (0..nv).rev() {
        if ranges[j].is_some() {
            next = Some(j);
        }
        above[j] = next;
    }
    for j in 0..nv {
        // Nearest row with patches, the lower on ties.
        let src = match (below[j], above[j]) {
            (Some(b), Some(a)) if j - b <= a - j => b,
            (_, Some(a)) => a,
            (Some(b), None) => b,
            (None, None) => unreachable!("called only on a texture with patches"),
        };
        let (first, last) = ranges[src].expect("filtered above");
        for i in 0..nu {
            if cell_patch[j * nu + i] == PatchId::MAX {
                let ii = i.clamp(first, last);
                cell_patch[j * nu + i] = cell_patch[src * nu + ii];
            }
        }
    }
}

/// What would make `vertices` an invalid polygon (the checks of [`Polygon::build`] but
/// the patch grid's), or `None` when they make a valid one.
pub fn vertices_problem(vertices: &[Vec3]) -> Option<PolygonProblem> {
    validated(vertices, 1, 1).err()
}

/// How far past its edges (world units) the inside test of a polygon of reach `reach`
/// (its [`Polygon::reach`]) and corners `corners` (in order) reaches: twice its reach
/// over the sine of its sharpest half-angle.
pub fn reach_past_corners(reach: f32, corners: &[glam::DVec3]) -> f64 {
    let n = corners.len();
    let mut min_sin_half = 1.0f64;
    for k in 0..n {
        let (a, b, c) = (corners[(k + n - 1) % n], corners[k], corners[(k + 1) % n]);
        let (e0, e1) = ((a - b).normalize_or_zero(), (c - b).normalize_or_zero());
        let angle = e0.dot(e1).clamp(-1.0, 1.0).acos();
        min_sin_half = min_sin_half.min((0.5 * angle).sin());
    }
    2.0 * reach as f64 / min_sin_half.max(1e-6)
}
