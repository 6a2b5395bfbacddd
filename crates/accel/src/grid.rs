//! A uniform voxel grid over a scene's polygons, traversed by 3D-DDA.

use crate::{Error, Mailbox};
use glam::{UVec3, Vec3};
use rad_core::{Hit, Ray, RayCast};
use rad_geometry::{Polygon, Scene};

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

/// A uniform grid of half-open voxels over the scene's bounds, each listing the
/// polygons that may cross it (a conservative plane–box test, padded by a few ulps).
///
/// Queries walk the voxels a ray crosses in order (Amanatides and Woo), testing each
/// polygon at most once per ray (a [`Mailbox`]). Ties in `t` go to the lower polygon id,
/// as in [`crate::BruteForce`].
pub struct VoxelGrid<'s> {
    scene: &'s Scene,
    lo: Vec3,
    hi: Vec3,
    dims: UVec3,
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
        // Pad so that no polygon lies on the grid's outer faces.
        let pad = Vec3::splat(1e-4 * diag);
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
        // Count, then fill (CSR).
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n_voxels];
        for (idx, poly) in scene.polygons().iter().enumerate() {
            let (plo, phi) = poly_bounds(poly);
            let eps = 1e-5 * diag;
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
                        let vlo = lo + Vec3::new(x as f32, y as f32, z as f32) * cell;
                        let centre = vlo + 0.5 * cell;
                        let half = 0.5 * cell + Vec3::splat(eps);
                        // Plane–box overlap: |n·c − d| ≤ Σ|n_k|·half_k.
                        let r = n.abs().dot(half);
                        if (n.dot(centre) - d).abs() <= r {
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
        Ok(VoxelGrid {
            scene,
            lo,
            hi,
            dims,
            cell,
            inv_cell: Vec3::ONE / cell,
            start,
            items,
        })
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [u32; 3] {
        self.dims.to_array()
    }

    /// Mean number of polygons listed per voxel.
    pub fn mean_occupancy(&self) -> f64 {
        self.items.len() as f64 / (self.start.len() - 1) as f64
    }

    /// Walks the voxels along `ray`; calls `visit(polygons, t_exit)` for each in order
    /// until it returns false or the ray leaves the grid or passes `t_max`.
    #[inline(always)]
    fn walk(&self, ray: &Ray, mut visit: impl FnMut(&[u32], f32) -> bool) {
        let o = ray.origin;
        let d = ray.dir;
        let inv = Vec3::ONE / d;
        // Slab test against the grid's box.
        let t0 = (self.lo - o) * inv;
        let t1 = (self.hi - o) * inv;
        let tmin = t0.min(t1);
        let tmax = t0.max(t1);
        let t_enter = tmin.max_element().max(0.0);
        let t_leave = tmax.min_element().min(ray.t_max);
        if !(t_enter <= t_leave) {
            return;
        }
        let p = o + d * t_enter;
        let dims = self.dims.as_ivec3();
        let mut v = ((p - self.lo) * self.inv_cell)
            .floor()
            .as_ivec3()
            .clamp(glam::IVec3::ZERO, dims - 1);
        let step = glam::IVec3::new(
            if d.x >= 0.0 { 1 } else { -1 },
            if d.y >= 0.0 { 1 } else { -1 },
            if d.z >= 0.0 { 1 } else { -1 },
        );
        let next_boundary = |v: glam::IVec3| {
            let b = (v + step.max(glam::IVec3::ZERO)).as_vec3();
            self.lo + b * self.cell
        };
        // t at which the ray crosses the next boundary on each axis; inf if parallel.
        let mut t_next = (next_boundary(v) - o) * inv;
        let t_delta = (self.cell * inv).abs();
        for k in 0..3 {
            if d[k] == 0.0 {
                t_next[k] = f32::INFINITY;
            }
        }
        let (sx, sy, sz) = (dims.x, dims.x * dims.y, 1);
        let _ = sz;
        let mut idx = (v.z * sy + v.y * sx + v.x) as usize;
        loop {
            let t_exit = t_next.min_element();
            let polys = &self.items[self.start[idx] as usize..self.start[idx + 1] as usize];
            if !visit(polys, t_exit) || t_exit >= t_leave {
                return;
            }
            // Step along the axis whose boundary comes first.
            if t_next.x <= t_next.y && t_next.x <= t_next.z {
                v.x += step.x;
                if v.x < 0 || v.x >= dims.x {
                    return;
                }
                idx = (idx as i32 + step.x) as usize;
                t_next.x += t_delta.x;
            } else if t_next.y <= t_next.z {
                v.y += step.y;
                if v.y < 0 || v.y >= dims.y {
                    return;
                }
                idx = (idx as i32 + step.y * sx) as usize;
                t_next.y += t_delta.y;
            } else {
                v.z += step.z;
                if v.z < 0 || v.z >= dims.z {
                    return;
                }
                idx = (idx as i32 + step.z * sy) as usize;
                t_next.z += t_delta.z;
            }
        }
    }
}

fn poly_bounds(poly: &Polygon) -> (Vec3, Vec3) {
    poly.vertices().iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(a, b), v| (a.min(*v), b.max(*v)),
    )
}

impl RayCast for VoxelGrid<'_> {
    type Scratch = Mailbox;

    fn new_scratch(&self) -> Mailbox {
        Mailbox::new(self.scene.polygons().len())
    }

    fn closest_hit(&self, ray: &Ray, mailbox: &mut Mailbox) -> Option<Hit> {
        mailbox.next_ray();
        let polygons = self.scene.polygons();
        let mut best: Option<Hit> = None;
        let mut t_best = ray.t_max;
        self.walk(ray, |polys, t_exit| {
            for &p in polys {
                if p == ray.skip || !mailbox.first_visit(p) {
                    continue;
                }
                // `t_best` is exclusive; ties go to the lower id, so test `<=` there.
                let limit = if best.is_some_and(|b| p < b.polygon) {
                    next_up(t_best)
                } else {
                    t_best
                };
                if let Some((t, u, v, front)) =
                    polygons[p as usize].intersect(ray.origin, ray.dir, limit)
                {
                    if t < t_best || best.is_some_and(|b| p < b.polygon) {
                        t_best = t;
                        best = Some(Hit {
                            polygon: p,
                            u,
                            v,
                            t,
                            front,
                        });
                    }
                }
            }
            t_best >= t_exit
        });
        best
    }

    fn all_hits(&self, ray: &Ray, mailbox: &mut Mailbox, out: &mut Vec<Hit>) {
        mailbox.next_ray();
        out.clear();
        let polygons = self.scene.polygons();
        self.walk(ray, |polys, _| {
            for &p in polys {
                if p == ray.skip || !mailbox.first_visit(p) {
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
        });
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
    }
}

/// The next f32 above a finite `x` (identity for infinities).
fn next_up(x: f32) -> f32 {
    if x.is_finite() {
        f32::from_bits(if x >= 0.0 {
            x.to_bits() + 1
        } else {
            x.to_bits() - 1
        })
    } else {
        x
    }
}
