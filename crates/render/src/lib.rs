//! Images of a radiosity solution, in memory: a pinhole [`View`], rays through any
//! [`RayCast`] to a patch, and that patch's radiosity, flat or smooth
//! ([`Shading`]). Pixels hold linear RGB radiosity (divide by π for radiance); a ray
//! that misses, or meets a polygon's back face, is black. Writing files is
//! `rad-pipeline`'s.
//!
//! One module, this file: [`View`] (a pinhole camera), [`render`] (stratified rays a pixel,
//! [`RenderConfig`]), [`corner_values`] and [`smooth_at`] (the smooth shading, which
//! exports bake too), [`Image`], and [`relative_difference`] (the report's figure 9).

use glam::Vec3;
use rad_core::{PatchId, Ray, RayCast};
use rad_geometry::{Camera, Polygon, Scene};
use rayon::prelude::*;

/// Largest image side, and largest pixel count, accepted.
pub const MAX_SIDE: u32 = 16_384;
pub const MAX_PIXELS: u64 = 1 << 26;
/// Largest samples per pixel side (`samples²` rays per pixel).
pub const MAX_SAMPLES: u32 = 16;

/// Invalid render requests.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    #[error("image size {width}x{height} is invalid (each side 1..={MAX_SIDE}, at most {MAX_PIXELS} pixels)")]
    Size { width: u32, height: u32 },
    #[error("{samples} samples per pixel side is invalid (1..={MAX_SAMPLES})")]
    Samples { samples: u32 },
    #[error("the scene has no camera; give one")]
    NoCamera,
    #[error("camera: {problem}")]
    Camera { problem: String },
    #[error("{len} radiosities for a scene of {n_patches} patches")]
    Radiosity { len: usize, n_patches: usize },
    #[error("radiosity of patch {patch} is {value:?}, not finite and >= 0")]
    BadRadiosity { patch: PatchId, value: [f64; 3] },
    #[error("images differ in size: {a:?} and {b:?}")]
    SizeMismatch { a: (u32, u32), b: (u32, u32) },
}

/// A pinhole camera and an image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
}

impl View {
    /// The scene's own camera at this size.
    pub fn of_scene(scene: &Scene, width: u32, height: u32) -> Result<View, Error> {
        let c = scene.camera().ok_or(Error::NoCamera)?;
        View::new(c, width, height)
    }

    /// A camera at this size, checked.
    pub fn new(c: &Camera, width: u32, height: u32) -> Result<View, Error> {
        if width == 0
            || height == 0
            || width > MAX_SIDE
            || height > MAX_SIDE
            || width as u64 * height as u64 > MAX_PIXELS
        {
            return Err(Error::Size { width, height });
        }
        if let Some(problem) = c.problem() {
            return Err(Error::Camera { problem });
        }
        Ok(View {
            position: c.position,
            look_at: c.look_at,
            up: c.up,
            fov_y: c.fov_y,
            width,
            height,
        })
    }

    /// The ray through image point (x, y) in pixels (0, 0 the top-left corner).
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        self.rays().ray(x, y)
    }

    /// What every ray of the view shares, made once (the same rays, to the bit).
    fn rays(&self) -> ViewRays {
        let w = (self.look_at - self.position).normalize();
        let u = w.cross(self.up).normalize();
        ViewRays {
            position: self.position,
            w,
            u,
            v: u.cross(w),
            half: (0.5 * self.fov_y).tan(),
            aspect: self.width as f32 / self.height as f32,
            width: self.width as f32,
            height: self.height as f32,
        }
    }
}

/// A view's camera frame and scale ([`View::ray`]'s terms that do not depend on the
/// pixel).
#[derive(Clone, Copy, Debug)]
struct ViewRays {
    position: Vec3,
    w: Vec3,
    u: Vec3,
    v: Vec3,
    half: f32,
    aspect: f32,
    width: f32,
    height: f32,
}

impl ViewRays {
    #[inline]
    fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = (2.0 * x / self.width - 1.0) * self.half * self.aspect;
        let sy = (1.0 - 2.0 * y / self.height) * self.half;
        Ray::new(
            self.position,
            (self.w + sx * self.u + sy * self.v).normalize(),
        )
    }
}

/// How a patch's radiosity becomes a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shading {
    /// The patch's own value.
    Flat,
    /// Values at patch corners (the mean of the patches around each corner, on the
    /// same polygon), interpolated bilinearly across the patch texture.
    Smooth,
}

/// Rendering settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderConfig {
    /// `samples × samples` stratified rays per pixel (their mean is the pixel).
    pub samples: u32,
    pub shading: Shading,
}

/// A linear RGB image, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }
}

/// The smooth shading's value at (u, v) of `poly`: its corner values (one polygon's of
/// [`corner_values`]) interpolated bilinearly across the cell (u, v) lies in (clamped to
/// the grid).
pub fn smooth_at(poly: &Polygon, corners: &[[f64; 3]], u: f32, v: f32) -> [f64; 3] {
    let (nu, nv) = poly.grid();
    let (fu, fv) = poly.cell_coords(u, v);
    let i = (fu.floor() as i64).clamp(0, nu as i64 - 1) as usize;
    let j = (fv.floor() as i64).clamp(0, nv as i64 - 1) as usize;
    let x = (fu - i as f32).clamp(0.0, 1.0) as f64;
    let y = (fv - j as f32).clamp(0.0, 1.0) as f64;
    let row = nu as usize + 1;
    let k = corners;
    let (c00, c10) = (k[j * row + i], k[j * row + i + 1]);
    let (c01, c11) = (k[(j + 1) * row + i], k[(j + 1) * row + i + 1]);
    std::array::from_fn(|c| {
        (1.0 - y) * ((1.0 - x) * c00[c] + x * c10[c]) + y * ((1.0 - x) * c01[c] + x * c11[c])
    })
}

/// Per-polygon corner values for smooth shading ([`corner_values`]), in one array:
/// polygon `k`'s are `corners[k]`, `(nu + 1) × (nv + 1)` of them, row by row.
#[derive(Clone, Debug, Default)]
pub struct Corners {
    /// Polygon k's values are `values[start[k]..start[k + 1]]`.
    start: Vec<usize>,
    values: Vec<[f64; 3]>,
}

impl std::ops::Index<usize> for Corners {
    type Output = [[f64; 3]];

    fn index(&self, k: usize) -> &[[f64; 3]] {
        &self.values[self.start[k]..self.start[k + 1]]
    }
}

/// Per-polygon corner values for smooth shading: `(nu + 1) × (nv + 1)` per polygon, the
/// mean of the (one to four) patches of the polygon around each corner of its grid.
pub fn corner_values(scene: &Scene, b: &[[f64; 3]]) -> Corners {
    let patches = scene.patches();
    let polygons = scene.polygons();
    let mut start = Vec::with_capacity(polygons.len() + 1);
    let mut values = Vec::new();
    for poly in polygons {
        start.push(values.len());
        let (nu, nv) = poly.grid();
        let real = |i: i64, j: i64| -> Option<PatchId> {
            if i < 0 || j < 0 || i >= nu as i64 || j >= nv as i64 {
                return None;
            }
            let p = poly.cell_patch(i as u32, j as u32);
            (patches[p as usize].cell == [i as u32, j as u32]).then_some(p)
        };
        if (nu, nv) == (1, 1) {
            // One patch (a mesh's triangle): each corner's mean is of it alone, as
            // below (0 + b, over 1).
            let c = match real(0, 0) {
                Some(p) => b[p as usize].map(|v| (0.0 + v) / 1.0),
                None => b[poly.cell_patch(0, 0) as usize],
            };
            values.extend([c; 4]);
            continue;
        }
        for j in 0..=nv as i64 {
            for i in 0..=nu as i64 {
                let mut s = [0.0; 3];
                let mut n = 0.0;
                for (di, dj) in [(-1, -1), (0, -1), (-1, 0), (0, 0)] {
                    if let Some(p) = real(i + di, j + dj) {
                        for c in 0..3 {
                            s[c] += b[p as usize][c];
                        }
                        n += 1.0;
                    }
                }
                if n == 0.0 {
                    // A corner no patch touches: take the nearest cell's patch.
                    let ci = i.clamp(0, nu as i64 - 1) as u32;
                    let cj = j.clamp(0, nv as i64 - 1) as u32;
                    s = b[poly.cell_patch(ci, cj) as usize];
                    n = 1.0;
                }
                values.push(s.map(|v| v / n));
            }
        }
    }
    start.push(values.len());
    Corners { start, values }
}

/// Renders radiosities `b` (one RGB per patch) of `scene` through `caster` from `view`.
/// Rows of the image run in parallel; the image does not depend on the thread count.
pub fn render<C: RayCast>(
    scene: &Scene,
    caster: &C,
    view: &View,
    b: &[[f64; 3]],
    config: &RenderConfig,
) -> Result<Image, Error> {
    let n_patches = scene.patches().len();
    if b.len() != n_patches {
        return Err(Error::Radiosity {
            len: b.len(),
            n_patches,
        });
    }
    if let Some((i, v)) = b
        .iter()
        .enumerate()
        .find(|(_, v)| !v.iter().all(|c| c.is_finite() && *c >= 0.0))
    {
        return Err(Error::BadRadiosity {
            patch: i as PatchId,
            value: *v,
        });
    }
    if config.samples == 0 || config.samples > MAX_SAMPLES {
        return Err(Error::Samples {
            samples: config.samples,
        });
    }
    let corners = match config.shading {
        Shading::Smooth => corner_values(scene, b),
        Shading::Flat => Corners::default(),
    };
    let polygons = scene.polygons();
    let n = config.samples;
    let shade = |ray: &Ray, scratch: &mut C::Scratch| -> [f64; 3] {
        let Some(hit) = caster.closest_hit(ray, scratch) else {
            return [0.0; 3];
        };
        if !hit.front {
            return [0.0; 3];
        }
        let poly = &polygons[hit.polygon as usize];
        match config.shading {
            Shading::Flat => b[poly.patch_at(hit.u, hit.v) as usize],
            Shading::Smooth => smooth_at(poly, &corners[hit.polygon as usize], hit.u, hit.v),
        }
    };
    let rays = view.rays();
    let pixels: Vec<[f32; 3]> = (0..view.height)
        .into_par_iter()
        .map_init(
            || caster.new_scratch(),
            |scratch, y| {
                (0..view.width)
                    .map(|x| {
                        let mut s = [0.0f64; 3];
                        for sy in 0..n {
                            for sx in 0..n {
                                let px = x as f32 + (sx as f32 + 0.5) / n as f32;
                                let py = y as f32 + (sy as f32 + 0.5) / n as f32;
                                let v = shade(&rays.ray(px, py), scratch);
                                for c in 0..3 {
                                    s[c] += v[c];
                                }
                            }
                        }
                        let k = 1.0 / (n * n) as f64;
                        s.map(|v| (v * k) as f32)
                    })
                    .collect::<Vec<_>>()
            },
        )
        .flatten()
        .collect();
    Ok(Image {
        width: view.width,
        height: view.height,
        pixels,
    })
}

/// Statistics of a relative-difference image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffStats {
    /// Pixels compared (those where the reference is not black).
    pub pixels: u64,
    pub mean: f64,
    pub p99: f64,
    pub max: f64,
    /// Share of compared pixels whose difference exceeds 10 %.
    pub over_10_percent: f64,
}

/// Luminance (Rec. 709 weights).
pub fn luminance(p: [f32; 3]) -> f64 {
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

/// The relative difference `|L(test) − L(ref)| / L(ref)` of luminances, per pixel, as a
/// grey image scaled so that white is 10 % (the report's figure 9), and its statistics
/// over the pixels where the reference is not black (those are black in the image).
pub fn relative_difference(reference: &Image, test: &Image) -> Result<(Image, DiffStats), Error> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(Error::SizeMismatch {
            a: (reference.width, reference.height),
            b: (test.width, test.height),
        });
    }
    let mut rel = Vec::new();
    let pixels = reference
        .pixels
        .iter()
        .zip(&test.pixels)
        .map(|(&a, &b)| {
            let la = luminance(a);
            if la > 0.0 {
                let d = (luminance(b) - la).abs() / la;
                rel.push(d);
                [(d / 0.1).min(1.0) as f32; 3]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let mut stats = DiffStats {
        pixels: rel.len() as u64,
        ..DiffStats::default()
    };
    if !rel.is_empty() {
        stats.mean = rel.iter().sum::<f64>() / rel.len() as f64;
        stats.over_10_percent = rel.iter().filter(|&&d| d > 0.1).count() as f64 / rel.len() as f64;
        rel.sort_by(f64::total_cmp);
        stats.max = *rel.last().expect("not empty");
        stats.p99 = rel[((rel.len() - 1) as f64 * 0.99).round() as usize];
    }
    Ok((
        Image {
            width: reference.width,
            height: reference.height,
            pixels,
        },
        stats,
    ))
}
