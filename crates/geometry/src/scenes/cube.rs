//! The report's first test scene: an empty unit cube, six inward faces of 10 × 10 patches.

use super::{material, rect};
use crate::scene::{Camera, PatchGrid, SceneDesc};
use glam::Vec3;

/// Face names of [`cube`], in polygon order.
pub const CUBE_FACES: [&str; 6] = [
    "floor", "ceiling", "wall x0", "wall x1", "wall z0", "wall z1",
];

/// The empty unit cube `[0, 1]³`, faces facing in, each `n × n` patches (the report: 10).
///
/// Polygon 0 is the floor (y = 0), with u along +z and v along +x, so floor patch
/// (i, j) is patch `j·n + i`.
pub fn cube(n: u64) -> SceneDesc {
    let grid = PatchGrid::Cells { nu: n, nv: n };
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let polygons = vec![
        rect(CUBE_FACES[0], Vec3::ZERO, z, x, 0, grid),
        rect(CUBE_FACES[1], y, x, z, 0, grid),
        rect(CUBE_FACES[2], Vec3::ZERO, y, z, 0, grid),
        rect(CUBE_FACES[3], x, z, y, 0, grid),
        rect(CUBE_FACES[4], Vec3::ZERO, x, y, 0, grid),
        rect(CUBE_FACES[5], z, y, x, 0, grid),
    ];
    SceneDesc {
        materials: vec![material("white", [0.7; 3], [0.0; 3])],
        polygons,
        camera: Some(Camera {
            position: Vec3::new(0.5, 0.5, 0.02),
            look_at: Vec3::new(0.5, 0.5, 1.0),
            up: Vec3::Y,
            fov_y: 80f32.to_radians(),
        }),
    }
}
