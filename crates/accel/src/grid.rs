//! A uniform voxel grid over a scene's polygons, traversed by 3D-DDA.

use crate::Error;
use glam::{IVec3, UVec3, Vec3};
use rad_core::{Hit, PolygonId, Ray, RayCast};
use rad_geometry::{OriginTerms, Polygon, PolygonTerms, Scene};

/// Largest number of voxels a grid may have.
pub const MAX_VOXELS: u64 = 1 << 27;

/// How many voxels along each axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GridResolution {
    /// About `density × n_polygons` voxels, cubic in shape, at least 1 and at most
    /// `max_per_axis` along each axis.
    Auto { density: f64, max_per_axis: u32 },
    /// Exactly these counts along x, y, z.
    Fixed([u32; 3]),
}

/// Settings of a [`VoxelGrid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelGridConfig {
    pub resolution: GridResolution,
}

impl VoxelGridConfig {
    /// The grid used unless told otherwise: about 4 voxels per polygon, at most 256 a
    /// side (measured best on the loft at 180 × 720 by `cargo run --release -p rad-repro
    /// --example grid_density`).
    pub const DEFAULT: VoxelGridConfig = VoxelGridConfig {
        resolution: GridResolution::Auto {
            density: 4.0,
            max_per_axis: 256,
        },
    };
}

/// Per-thread working memory of a [`VoxelGrid`]: the mailbox, and the per-origin terms
/// of every polygon for the origin last used by [`RayCast::closest_hits_from`].
#[derive(Clone, Debug)]
pub struct GridScratch {
    /// Mailbox: the last ray that tested each polygon, or [`CULLED`].
    stamps: Vec<u32>,
    ray: u32,
    /// Origin, own polygon and culling the `per_origin` terms were computed for.
    origin: Option<(Vec3, PolygonId, bool)>,
    /// Each polygon's intersection terms for that origin.
    per_origin: Vec<OriginTerms>,
    /// Polygons marked [`CULLED`] for the current origin.
    culled: Vec<u32>,
}

/// Stamp of a polygon no ray from the current origin can hit: it counts as tested for
/// every ray, since real stamps never exceed the current ray.
const CULLED: u32 = u32::MAX;

impl GridScratch {
    #[inline]
    fn next_ray(&mut self) {
        self.ray += 1;
        if self.ray == CULLED {
            self.stamps.fill(0);
            self.culled.clear();
            self.origin = None;
            self.ray = 1;
        }
    }

    /// Marks `polygon` tested; false if it already was for this ray (mailboxing), or
    /// if it is culled for this origin.
    #[inline(always)]
    fn first_visit(&mut self, polygon: u32) -> bool {
        let s = &mut self.stamps[polygon as usize];
        let first = *s < self.ray;
        if first {
            *s = self.ray;
        }
        first
    }

    /// Drops the per-origin state, before a query from another origin.
    #[inline]
    fn forget_origin(&mut self) {
        if !self.culled.is_empty() {
            self.uncull();
        }
        self.origin = None;
    }

    fn uncull(&mut self) {
        for p in self.culled.drain(..) {
            self.stamps[p as usize] = 0;
        }
    }
}

/// A uniform grid of half-open voxels over the scene's bounds, each listing the
/// polygons that may cross it (a conservative plane–box test, padded by a few ulps).
///
/// Queries walk the voxels a ray crosses in order (Amanatides and Woo), testing each
/// polygon at most once per ray (mailboxing). Ties in `t` go to the lower polygon id,
/// as in [`crate::BruteForce`].
pub struct VoxelGrid<'s> {
    scene: &'s Scene,
    /// Every polygon's hit-test terms, compact.
    hot: Vec<PolygonTerms>,
    /// True for polygons whose inside test needs their edges (not parallelograms).
    general: Vec<bool>,
    lo: Vec3,
    hi: Vec3,
    dims: IVec3,
    cell: Vec3,
    inv_cell: Vec3,
    /// CSR: polygons of voxel `k` are `items[start[k]..start[k+1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl<'s> VoxelGrid<'s> {
    pub fn build(scene: &'s Scene, config: &VoxelGridConfig) -> Result<Self, Error> {
        let (lo0, hi0) = scene.bounds();
        let diag = (hi0 - lo0).length().max(1e-6);
        // Pad so that no polygon lies on the grid's outer faces, and every hit a
        // polygon's test accepts (up to its hull reach off it) lies inside.
        let far = scene
            .polygons()
            .iter()
            .map(|p| p.hull_reach() as f32)
            .fold(0.0, f32::max);
        let pad = Vec3::splat(1e-4 * diag + 2.0 * far);
        let (lo, hi) = (lo0 - pad, hi0 + pad);
        let ext = hi - lo;
        let dims = match config.resolution {
            GridResolution::Fixed(d) => {
                let d64 = d.map(u64::from);
                if d.contains(&0) {
                    return Err(Error::Resolution {
                        dims: d64,
                        reason: "every axis needs at least one voxel",
                    });
                }
                if d64.iter().product::<u64>() > MAX_VOXELS {
                    return Err(Error::Resolution {
                        dims: d64,
                        reason: "more voxels than MAX_VOXELS",
                    });
                }
                UVec3::from(d)
            }
            GridResolution::Auto {
                density,
                max_per_axis,
            } => {
                if !(density.is_finite() && density > 0.0) {
                    return Err(Error::Density { density });
                }
                let target = density * scene.polygons().len() as f64;
                let volume = (ext.x as f64) * (ext.y as f64) * (ext.z as f64);
                let per_len = (target / volume).cbrt();
                let cap = (max_per_axis.max(1) as f64).min((MAX_VOXELS as f64).cbrt().floor());
                let axis = |l: f32| ((l as f64 * per_len).round().clamp(1.0, cap)) as u32;
                UVec3::new(axis(ext.x), axis(ext.y), axis(ext.z))
            }
        };
        let cell = ext / dims.as_vec3();
        let n_voxels = (dims.x * dims.y * dims.z) as usize;
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n_voxels];
        let eps = 1e-5 * diag;
        for (idx, poly) in scene.polygons().iter().enumerate() {
            // A polygon accepts hits up to its reach past its edges, farther at an acute
            // corner: pad by that too.
            let eps = eps.max(2.0 * poly.reach()).max(poly.hull_reach() as f32);
            let (plo, phi) = poly_bounds(poly);
            let v0 = (((plo - lo - eps) / cell).floor().max(Vec3::ZERO))
                .as_uvec3()
                .min(dims - 1);
            let v1 = (((phi - lo + eps) / cell).floor().max(Vec3::ZERO))
                .as_uvec3()
                .min(dims - 1);
            let n = poly.normal();
            let d = n.dot(poly.origin());
            for z in v0.z..=v1.z {
                for y in v0.y..=v1.y {
                    for x in v0.x..=v1.x {
                        let centre = lo + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * cell;
                        let half = 0.5 * cell + Vec3::splat(eps);
                        // Plane–box overlap: |n·c − d| ≤ Σ|n_k|·half_k.
                        if (n.dot(centre) - d).abs() <= n.abs().dot(half) {
                            lists[((z * dims.y + y) * dims.x + x) as usize].push(idx as u32);
                        }
                    }
                }
            }
        }
        let mut start = Vec::with_capacity(n_voxels + 1);
        let mut items = Vec::new();
        start.push(0);
        for l in &lists {
            items.extend_from_slice(l);
            start.push(items.len() as u32);
        }
        let hot = scene.polygons().iter().map(Polygon::terms).collect();
        Ok(VoxelGrid {
            scene,
            hot,
            general: scene
                .polygons()
                .iter()
                .map(|p| !p.is_parallelogram())
                .collect(),
            lo,
            hi,
            dims: dims.as_ivec3(),
            cell,
            inv_cell: Vec3::ONE / cell,
            start,
            items,
        })
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [u32; 3] {
        self.dims.as_uvec3().to_array()
    }

    /// Mean number of polygons listed per voxel.
    pub fn mean_occupancy(&self) -> f64 {
        self.items.len() as f64 / (self.start.len() - 1) as f64
    }

    /// Where a ray from `o` in direction `d` enters the grid (`t ≥ 0`), or None if it
    /// misses the grid before `t_max`.
    #[inline(always)]
    fn entry(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(Vec3, f32)> {
        let inv = Vec3::ONE / d;
        let t0 = (self.lo - o) * inv;
        let t1 = (self.hi - o) * inv;
        let t_enter = t0.min(t1).max_element().max(0.0);
        let t_leave = t0.max(t1).min_element().min(t_max);
        (t_enter <= t_leave).then(|| (o + d * t_enter, t_enter))
    }

    /// The voxel containing point `p` (clamped into the grid).
    #[inline(always)]
    fn voxel_of(&self, p: Vec3) -> IVec3 {
        ((p - self.lo) * self.inv_cell)
            .max(Vec3::ZERO)
            .as_ivec3()
            .min(self.dims - 1)
    }

    /// Walks the voxels along `o + t·d` from voxel `v` (which must contain the ray's
    /// point of entry); calls `visit(polygons, t_exit)` for each voxel in order until it
    /// returns false, the ray leaves the grid, or a voxel ends past `t_max`.
    #[inline(always)]
    fn walk(
        &self,
        o: Vec3,
        d: Vec3,
        v: IVec3,
        t_max: f32,
        mut visit: impl FnMut(&[u32], f32) -> bool,
    ) {
        let inv = Vec3::ONE / d;
        let dims = self.dims;
        let pos = d.cmpge(Vec3::ZERO);
        let boundary =
            self.lo + (v + IVec3::select(pos, IVec3::ONE, IVec3::ZERO)).as_vec3() * self.cell;
        // t at which the ray crosses the next boundary on each axis; inf if parallel.
        let zero = d.cmpeq(Vec3::ZERO);
        let mut t_next = Vec3::select(zero, Vec3::INFINITY, (boundary - o) * inv).to_array();
        let t_delta = Vec3::select(zero, Vec3::INFINITY, (self.cell * inv).abs());
        // Voxel index and its strides; `left` counts the steps before leaving each axis.
        let stride =
            IVec3::select(pos, IVec3::ONE, IVec3::NEG_ONE) * IVec3::new(1, dims.x, dims.x * dims.y);
        let mut left = IVec3::select(pos, dims - 1 - v, v).to_array();
        let mut idx = (v.z * dims.y + v.y) * dims.x + v.x;
        let (stride, t_delta) = (stride.to_array(), t_delta.to_array());
        loop {
            let t_exit = t_next[0].min(t_next[1]).min(t_next[2]);
            let (a, b) = (
                self.start[idx as usize] as usize,
                self.start[idx as usize + 1] as usize,
            );
            if !visit(&self.items[a..b], t_exit) || t_exit >= t_max {
                return;
            }
            // Step along the axis whose boundary comes first (branch-free choice).
            let a = usize::from(t_next[1] < t_next[0]);
            let t_ab = if a == 1 { t_next[1] } else { t_next[0] };
            let k = if t_next[2] < t_ab { 2 } else { a };
            if left[k] == 0 {
                return;
            }
            left[k] -= 1;
            idx += stride[k];
            t_next[k] += t_delta[k];
        }
    }

    /// Closest hit along `o + t·d`, `0 < t < t_max`, from voxel `start`, with each
    /// polygon's terms for this origin given by `view(polygon)`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn closest(
        &self,
        o: Vec3,
        d: Vec3,
        start: IVec3,
        t_max: f32,
        skip: PolygonId,
        scratch: &mut GridScratch,
        view: impl Fn(&GridScratch, u32) -> OriginTerms,
    ) -> Option<Hit> {
        scratch.next_ray();
        if let Some(s) = scratch.stamps.get_mut(skip as usize) {
            *s = (*s).max(scratch.ray);
        }
        let (mut t_best, mut best_p, mut best_u, mut best_v) = (t_max, u32::MAX, 0.0f32, 0.0f32);
        self.walk(o, d, start, t_max, |polys, t_exit| {
            for &p in polys {
                if !scratch.first_visit(p) {
                    continue;
                }
                if let Some((t, u, v)) = self.test(&view(scratch, p), p as usize, d, t_best, best_p)
                {
                    (t_best, best_p, best_u, best_v) = (t, p, u, v);
                }
            }
            t_best >= t_exit
        });
        (best_p != u32::MAX).then(|| {
            let front = self.hot[best_p as usize].normal.dot(d) < 0.0;
            Hit {
                polygon: best_p,
                u: best_u,
                v: best_v,
                t: t_best,
                front,
            }
        })
    }

    /// One polygon's test for a ray in direction `d`, given its terms for the ray's
    /// origin: the hit's (t, u, v) if it is closer than the best so far (`t_best`, with
    /// ties going to the lower polygon id below `best_p`), else None.
    #[inline(always)]
    fn test(
        &self,
        h: &OriginTerms,
        p: usize,
        d: Vec3,
        t_best: f32,
        best_p: u32,
    ) -> Option<(f32, f32, f32)> {
        let denom = h.denom(d.x, d.y, d.z);
        let t = h.num / denom;
        if !(t > 0.0 && (t < t_best || (t == t_best && (p as u32) < best_p))) {
            return None;
        }
        let (u, v) = h.uv(t, d.x, d.y, d.z);
        if !h.in_bounds(u, v) {
            return None;
        }
        // Back faces (rare) take the shrunk inside test, as in `Polygon::intersect`.
        let inside = self.scene.polygons()[p].accepts(denom, !self.general[p], u, v);
        inside.then_some((t, u, v))
    }

    /// The hot loop of [`RayCast::closest_hits_from`]: [`VoxelGrid::closest`] for a ray
    /// from a shared origin inside the grid, with that origin's `views`, written without
    /// bounds checks (about a fifth of its instructions otherwise).
    ///
    /// # Safety
    /// `start` must be a voxel of this grid, and `stamps` and `views` must hold one entry
    /// per polygon of the scene; every index used below is then in range: voxel indices
    /// stay in the grid (the `left` counters stop the walk at its faces), `start` has one
    /// more entry than there are voxels, and `items` holds polygon ids.
    #[inline(always)]
    unsafe fn closest_shared_origin(
        &self,
        o: Vec3,
        d: Vec3,
        start: IVec3,
        stamps: &mut [u32],
        ray: u32,
        views: &[OriginTerms],
    ) -> Option<Hit> {
        debug_assert!(stamps.len() == self.hot.len() && views.len() == self.hot.len());
        debug_assert!(start.cmpge(IVec3::ZERO).all() && start.cmplt(self.dims).all());
        let polygons = self.scene.polygons();
        let (mut t_best, mut best_p, mut best_u, mut best_v) =
            (f32::INFINITY, u32::MAX, 0.0f32, 0.0f32);
        let inv = Vec3::ONE / d;
        let dims = self.dims;
        let pos = d.cmpge(Vec3::ZERO);
        let boundary =
            self.lo + (start + IVec3::select(pos, IVec3::ONE, IVec3::ZERO)).as_vec3() * self.cell;
        let zero = d.cmpeq(Vec3::ZERO);
        let mut t_next = Vec3::select(zero, Vec3::INFINITY, (boundary - o) * inv).to_array();
        let t_delta = Vec3::select(zero, Vec3::INFINITY, (self.cell * inv).abs()).to_array();
        let stride = (IVec3::select(pos, IVec3::ONE, IVec3::NEG_ONE)
            * IVec3::new(1, dims.x, dims.x * dims.y))
        .to_array();
        let mut left = IVec3::select(pos, dims - 1 - start, start).to_array();
        let mut idx = ((start.z * dims.y + start.y) * dims.x + start.x) as usize;
        let (starts, items) = (self.start.as_ptr(), self.items.as_ptr());
        loop {
            let t_exit = t_next[0].min(t_next[1]).min(t_next[2]);
            // SAFETY: idx < n_voxels and start has n_voxels + 1 entries.
            let (a, b) = unsafe { (*starts.add(idx) as usize, *starts.add(idx + 1) as usize) };
            for k in a..b {
                // SAFETY: items[k] exists (k < start[n_voxels] = items.len()) and is a polygon id.
                let p = unsafe { *items.add(k) } as usize;
                let stamp = unsafe { stamps.get_unchecked_mut(p) };
                if *stamp >= ray {
                    continue;
                }
                *stamp = ray;
                // SAFETY: p is a polygon id and views has one entry per polygon.
                let h = unsafe { views.get_unchecked(p) };
                // `VoxelGrid::test`, written out: through a helper this loop runs 10 %
                // more instructions and 25 % more mispredicted branches (cachegrind).
                let denom = h.denom(d.x, d.y, d.z);
                let t = h.num / denom;
                if !(t > 0.0 && (t < t_best || (t == t_best && (p as u32) < best_p))) {
                    continue;
                }
                let (u, v) = h.uv(t, d.x, d.y, d.z);
                if !h.in_bounds(u, v) {
                    continue;
                }
                if polygons[p].accepts(denom, !self.general[p], u, v) {
                    (t_best, best_p, best_u, best_v) = (t, p as u32, u, v);
                }
            }
            if t_best < t_exit {
                break;
            }
            let a = usize::from(t_next[1] < t_next[0]);
            let t_ab = if a == 1 { t_next[1] } else { t_next[0] };
            let k = if t_next[2] < t_ab { 2 } else { a };
            if left[k] == 0 {
                break;
            }
            left[k] -= 1;
            idx = (idx as i32 + stride[k]) as usize;
            t_next[k] += t_delta[k];
        }
        (best_p != u32::MAX).then(|| {
            let front = self.hot[best_p as usize].normal.dot(d) < 0.0;
            Hit {
                polygon: best_p,
                u: best_u,
                v: best_v,
                t: t_best,
                front,
            }
        })
    }
}

fn poly_bounds(poly: &Polygon) -> (Vec3, Vec3) {
    poly.vertices().iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(a, b), v| (a.min(*v), b.max(*v)),
    )
}

impl RayCast for VoxelGrid<'_> {
    type Scratch = GridScratch;

    fn new_scratch(&self) -> GridScratch {
        let n = self.hot.len();
        GridScratch {
            stamps: vec![0; n],
            ray: 0,
            origin: None,
            per_origin: vec![OriginTerms::default(); n],
            culled: Vec::new(),
        }
    }

    fn closest_hit(&self, ray: &Ray, scratch: &mut GridScratch) -> Option<Hit> {
        scratch.forget_origin();
        let o = ray.origin;
        let (p, _) = self.entry(o, ray.dir, ray.t_max)?;
        let start = self.voxel_of(p);
        self.closest(o, ray.dir, start, ray.t_max, ray.skip, scratch, |_, p| {
            self.scene.seen(p as usize, self.hot[p as usize].at(o))
        })
    }

    fn closest_hits_from(
        &self,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut GridScratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        // Polygons wholly behind the plane of `skip` through `origin` cannot be hit by
        // rays that leave that plane forwards (a hemisphere's): cull them for all rays.
        let own = self.scene.polygons().get(skip as usize).map(|p| p.normal());
        let cull = own.is_some_and(|n| dirs.iter().all(|d| d.dot(n) > 0.0));
        if scratch.origin != Some((origin, skip, cull)) {
            scratch.uncull();
            for (p, (t, h)) in scratch.per_origin.iter_mut().zip(&self.hot).enumerate() {
                *t = self.scene.seen(p, h.at(origin));
            }
            if let (true, Some(n)) = (cull, own) {
                let (o, n) = (origin.as_dvec3(), n.as_dvec3());
                for (p, poly) in self.scene.polygons().iter().enumerate() {
                    // Behind by more than the polygon's reach (its edge tolerance and
                    // how far its vertices may lie off its plane): unreachable.
                    if poly.wholly_behind(o, n) {
                        scratch.stamps[p] = CULLED;
                        scratch.culled.push(p as u32);
                    }
                }
            }
            scratch.origin = Some((origin, skip, cull));
        }
        out.clear();
        if !(origin.cmpge(self.lo).all() && origin.cmplt(self.hi).all()) {
            // Outside the grid: no shared start voxel.
            let mut ray = Ray::new(origin, Vec3::Z);
            ray.skip = skip;
            out.extend(
                dirs.iter()
                    .map(|&d| self.closest_hit(&Ray { dir: d, ..ray }, scratch)),
            );
            return;
        }
        let start = self.voxel_of(origin);
        assert!(
            scratch.stamps.len() == self.hot.len() && scratch.per_origin.len() == self.hot.len()
        );
        out.extend(dirs.iter().map(|&d| {
            scratch.next_ray();
            if let Some(s) = scratch.stamps.get_mut(skip as usize) {
                *s = (*s).max(scratch.ray);
            }
            // SAFETY: `start` is the voxel of an origin inside the grid, and the scratch
            // was made by this grid (one stamp and one view per polygon, asserted above).
            unsafe {
                self.closest_shared_origin(
                    origin,
                    d,
                    start,
                    &mut scratch.stamps,
                    scratch.ray,
                    &scratch.per_origin,
                )
            }
        }));
    }

    fn all_hits(&self, ray: &Ray, scratch: &mut GridScratch, out: &mut Vec<Hit>) {
        scratch.forget_origin();
        scratch.next_ray();
        out.clear();
        let polygons = self.scene.polygons();
        let Some((p, _)) = self.entry(ray.origin, ray.dir, ray.t_max) else {
            return;
        };
        self.walk(
            ray.origin,
            ray.dir,
            self.voxel_of(p),
            ray.t_max,
            |polys, _| {
                for &p in polys {
                    if p == ray.skip || !scratch.first_visit(p) {
                        continue;
                    }
                    if let Some((t, u, v, front)) =
                        polygons[p as usize].intersect(ray.origin, ray.dir, ray.t_max)
                    {
                        out.push(Hit {
                            polygon: p,
                            u,
                            v,
                            t,
                            front,
                        });
                    }
                }
                true
            },
        );
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
    }
}
