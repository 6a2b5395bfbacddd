//! Curved mesh scenes that behave like scans, at about 10^5 and 10^6 triangles: a
//! gallery of sculptures in a closed room, every triangle one patch.
//!
//! What a scanned mesh has that `blob_room` lacks, and how each sculpture gets it:
//! - triangles of very uneven size: the icosphere's directions are drawn towards one
//!   side before displacement (`d → normalize(d + 0.7 a)`), so triangle areas vary
//!   about fiftyfold over a sculpture (1st to 99th percentile; 80-fold over the
//!   ~10^5 gallery), and sculptures differ in subdivision level;
//! - concavities and deep self-occlusion: the radius has narrow V-shaped crevices
//!   (`|s|^0.6` of a sum of sines `s`, a cusp where `s` crosses zero), down to 45 % of
//!   the outer radius, whose walls hide one another from most viewpoints;
//! - thin parts: four horns (a narrow bump of 60 % of the radius over 9° of
//!   directions), a few triangles across at their tips;
//! - nothing flat: neighbouring triangles are not coplanar, so facets gather none.
//! Each sculpture is star-shaped about its centre (its radius a positive function of
//! direction), so it cannot intersect itself, and sculptures stand in disjoint balls
//! clear of the floor and walls: valid by construction, deterministic (seeded shapes).

use super::meshes::{icosphere, lit_room, one_patch_triangles};
use crate::scene::{Camera, SceneDesc};
use glam::Vec3;

/// The sculptures' subdivision levels of the ~10^5-triangle gallery: 81,920 + 20,480
/// triangles, and the room's 30 (the lamp's and the walls' polygons).
pub const SCULPTURES_100K: [u32; 2] = [6, 5];

/// The same for the ~10^6-triangle gallery: three sculptures of 327,680 triangles.
pub const SCULPTURES_1M: [u32; 3] = [7, 7, 7];

/// A sculpture's outer radius before its horns, metres; horns reach 1.6 times it.
const RADIUS: f32 = 0.5;

/// Spacing of the sculptures' centres along x, metres (more than twice 1.6 radii).
const SPACING: f32 = 1.8;

/// The gallery of ~10^5 triangles ([`SCULPTURES_100K`]).
pub fn sculptures_100k() -> SceneDesc {
    sculptures(&SCULPTURES_100K)
}

/// The gallery of ~10^6 triangles ([`SCULPTURES_1M`]).
pub fn sculptures_1m() -> SceneDesc {
    sculptures(&SCULPTURES_1M)
}

/// Sculptures of the given subdivision levels (20 · 4^level triangles each) in a row
/// along x, in a closed room 3 m high and 3.6 m deep lit by a ceiling lamp.
pub fn sculptures(levels: &[u32]) -> SceneDesc {
    let (x, y, z) = (SPACING * levels.len() as f32 + 0.6, 3.0, 3.6);
    let (materials, mut polygons) = lit_room(Vec3::new(x, y, z), ("stone", [0.55, 0.5, 0.45]));
    for (k, &level) in levels.iter().enumerate() {
        let centre = Vec3::new(0.3 + SPACING * (k as f32 + 0.5), 1.05, 0.5 * z);
        let shape = Shape::seeded(k as u64 + 1);
        let (directions, faces) = icosphere(level);
        let at: Vec<Vec3> = directions
            .iter()
            .map(|&d| {
                let d = (d + 0.7 * shape.dense).normalize();
                centre + d * shape.radius(d)
            })
            .collect();
        let name = format!("sculpture {k}");
        polygons.extend(one_patch_triangles(&name, &at, &faces, 1));
    }
    SceneDesc {
        materials,
        polygons,
        camera: Some(Camera {
            position: Vec3::new(0.5 * x, 1.7, z - 0.05),
            look_at: Vec3::new(0.5 * x, 1.0, 0.5 * z),
            up: Vec3::Y,
            fov_y: 70f32.to_radians(),
        }),
    }
}

/// One sculpture's shape: where its triangles crowd, its crevices' phases and its
/// horns' directions.
struct Shape {
    dense: Vec3,
    phase: [f32; 3],
    horns: [Vec3; 4],
}

impl Shape {
    /// A shape from a seed (xorshift64*: the same seed, the same shape).
    fn seeded(seed: u64) -> Shape {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move || {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            let bits = state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40;
            bits as f32 / (1u64 << 24) as f32
        };
        let mut unit = || {
            let (u, v) = (2.0 * next() - 1.0, std::f32::consts::TAU * next());
            let s = (1.0 - u * u).max(0.0).sqrt();
            Vec3::new(s * v.cos(), u, s * v.sin())
        };
        let dense = unit();
        let horns = [unit(), unit(), unit(), unit()];
        let phase = [
            std::f32::consts::TAU * next(),
            std::f32::consts::TAU * next(),
            std::f32::consts::TAU * next(),
        ];
        Shape {
            dense,
            phase,
            horns,
        }
    }

    /// The radius towards unit direction `d`: crevices, then horns.
    fn radius(&self, d: Vec3) -> f32 {
        let (theta, phi) = (d.y.clamp(-1.0, 1.0).acos(), d.z.atan2(d.x));
        let s = (5.0 * theta + self.phase[0]).sin() * (3.0 * phi + self.phase[1]).cos()
            + 0.5 * (4.0 * phi + 2.0 * theta + self.phase[2]).sin();
        // |s| ≤ 1.5: 0.45 at a crevice's floor, 1 at the highest ridge.
        let ridges = 0.45 + 0.55 * (s.abs() / 1.5).powf(0.6);
        let cos_tip = 9f32.to_radians().cos();
        let horns: f32 = self
            .horns
            .iter()
            .map(|&h| ((d.dot(h) - cos_tip) / (1.0 - cos_tip)).max(0.0).powi(2))
            .sum();
        RADIUS * (ridges + 0.6 * horns.min(1.0))
    }
}
