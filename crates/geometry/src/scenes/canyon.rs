//! An urban street canyon for view factors at scale (the kind of case View3D users
//! bring): two rows of six 12 × 12 × 25 m buildings either side of a 12 m street, 6 m
//! apart along it, on open ground with 8 m margins; every wall, roof and the ground
//! between the buildings cut into 1 m facets, each facet a polygon of one patch, each
//! building face (and the ground) a group.

use super::{material, rect};
use crate::scene::{Camera, PatchGrid, SceneDesc};
use glam::Vec3;

/// Facets of [`urban_canyon`]: 4,408 of ground, 14,400 of walls, 1,728 of roofs.
pub const CANYON_FACETS: usize = 20_536;

const SIDE: i32 = 12;
const HEIGHT: i32 = 25;
const MARGIN: i32 = 8;
const GAP: i32 = 6;
const STREET: i32 = 12;
const PER_ROW: i32 = 6;

/// The canyon (Y up, metres; x along the street, z across it).
pub fn urban_canyon() -> SceneDesc {
    let one = PatchGrid::Cells { nu: 1, nv: 1 };
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let footprints: Vec<(i32, i32)> = (0..2)
        .flat_map(|row| {
            (0..PER_ROW).map(move |c| (MARGIN + c * (SIDE + GAP), MARGIN + row * (SIDE + STREET)))
        })
        .collect();
    let len_x = 2 * MARGIN + PER_ROW * SIDE + (PER_ROW - 1) * GAP;
    let len_z = 2 * MARGIN + 2 * SIDE + STREET;
    let inside = |i: i32, k: i32| {
        footprints
            .iter()
            .any(|&(x0, z0)| (x0..x0 + SIDE).contains(&i) && (z0..z0 + SIDE).contains(&k))
    };
    let p = |a: i32, b: i32, c: i32| Vec3::new(a as f32, b as f32, c as f32);
    let mut polygons = Vec::with_capacity(CANYON_FACETS);
    let mut add = |group: &str, o: Vec3, e_u: Vec3, e_v: Vec3, material: usize| {
        let name = format!("polygon {}", polygons.len());
        let mut facet = rect(name, o, e_u, e_v, material, one);
        facet.group = Some(group.to_string());
        polygons.push(facet);
    };
    // The ground, facing up (u along +z, v along +x).
    for k in 0..len_z {
        for i in 0..len_x {
            if !inside(i, k) {
                add("ground", p(i, 0, k), z, x, 0);
            }
        }
    }
    for (b, &(x0, z0)) in footprints.iter().enumerate() {
        let name = |face: &str| format!("building {b} {face}");
        for h in 0..HEIGHT {
            for s in 0..SIDE {
                add(&name("west"), p(x0, h, z0 + s), z, y, 1);
                add(&name("east"), p(x0 + SIDE, h, z0 + s), y, z, 1);
                add(&name("south"), p(x0 + s, h, z0), y, x, 1);
                add(&name("north"), p(x0 + s, h, z0 + SIDE), x, y, 1);
            }
        }
        for k in 0..SIDE {
            for i in 0..SIDE {
                add(&name("roof"), p(x0 + i, HEIGHT, z0 + k), z, x, 2);
            }
        }
    }
    SceneDesc {
        materials: vec![
            material("ground", [0.15; 3], [0.0; 3]),
            material("facade", [0.3; 3], [0.0; 3]),
            material("roof", [0.2; 3], [0.0; 3]),
        ],
        polygons,
        camera: Some(Camera {
            position: Vec3::new(-10.0, 30.0, (len_z / 2) as f32),
            look_at: Vec3::new(60.0, 5.0, (len_z / 2) as f32),
            up: Vec3::Y,
            fov_y: 50f32.to_radians(),
        }),
    }
}
