//! A loft-like interior built to the report's counts: 185 polygons, 14,400 patches.
//!
//! The report never published its loft; this one is ours. It is a closed 12 × 5 × 8 m
//! room (one wall with a door, one with a window strip) holding 29 boxes: a mezzanine
//! on two columns with a railing, a stair, two tables, a shelf, four hanging lights and
//! two ceiling beams. Every box keeps a gap of at least 2 cm from every other polygon,
//! so no patch centre lies on another polygon and no patch can see the inside of a box.

use super::{box_faces, material, rect};
use crate::scene::{Camera, PatchGrid, PolygonDesc, SceneDesc};
use glam::Vec3;

/// Room size (x, y, z), metres.
pub const LOFT_SIZE: [f32; 3] = [12.0, 5.0, 8.0];

/// One box of the loft's furniture: name, min corner, max corner, material, patch size.
type BoxSpec = (&'static str, [f32; 3], [f32; 3], usize, f32);

/// The loft's furniture boxes (axis-aligned, faces out).
pub fn loft_boxes() -> Vec<BoxSpec> {
    const WOOD: usize = 1;
    const METAL: usize = 5;
    const LIGHT: usize = 6;
    const PLASTER: usize = 2;
    let s = 0.17;
    let mut b: Vec<BoxSpec> = vec![
        (
            "mezzanine slab",
            [0.02, 2.8, 0.02],
            [4.0, 3.0, 7.98],
            PLASTER,
            0.2,
        ),
        ("column a", [3.7, 0.02, 2.0], [3.9, 2.78, 2.2], METAL, s),
        ("column b", [3.7, 0.02, 5.8], [3.9, 2.78, 6.0], METAL, s),
        ("railing", [3.92, 3.02, 0.3], [3.98, 4.0, 7.5], METAL, s),
    ];
    const STEPS: [&str; 4] = ["step 0", "step 1", "step 2", "step 3"];
    for (k, name) in STEPS.iter().enumerate() {
        let x0 = 4.05 + 0.45 * k as f32;
        b.push((
            name,
            [x0, 0.02, 0.3],
            [x0 + 0.4, 0.6 * (k + 1) as f32, 1.3],
            WOOD,
            s,
        ));
    }
    const TABLES: [[&str; 5]; 2] = [
        [
            "table 0 top",
            "table 0 leg 0",
            "table 0 leg 1",
            "table 0 leg 2",
            "table 0 leg 3",
        ],
        [
            "table 1 top",
            "table 1 leg 0",
            "table 1 leg 1",
            "table 1 leg 2",
            "table 1 leg 3",
        ],
    ];
    for (names, (x0, z0)) in TABLES.iter().zip([(6.0f32, 3.0f32), (8.5, 5.0)]) {
        b.push((
            names[0],
            [x0, 0.74, z0],
            [x0 + 2.0, 0.78, z0 + 1.0],
            WOOD,
            s,
        ));
        let legs = [(0.1, 0.1), (1.84, 0.1), (0.1, 0.84), (1.84, 0.84)];
        for (name, (lx, lz)) in names[1..].iter().zip(legs) {
            b.push((
                name,
                [x0 + lx, 0.02, z0 + lz],
                [x0 + lx + 0.06, 0.72, z0 + lz + 0.06],
                METAL,
                s,
            ));
        }
    }
    b.push((
        "shelf side a",
        [11.6, 0.02, 1.0],
        [11.95, 2.0, 1.04],
        WOOD,
        s,
    ));
    b.push((
        "shelf side b",
        [11.6, 0.02, 2.6],
        [11.95, 2.2, 2.64],
        WOOD,
        s,
    ));
    for (name, y) in [
        ("shelf board 0", 0.3f32),
        ("shelf board 1", 1.0),
        ("shelf board 2", 1.7),
    ] {
        b.push((name, [11.6, y, 1.06], [11.95, y + 0.03, 2.58], WOOD, s));
    }
    for (name, (x, z)) in [
        ("light 0", (5.4f32, 2.0f32)),
        ("light 1", (9.4, 2.0)),
        ("light 2", (5.4, 5.6)),
        ("light 3", (9.4, 5.6)),
    ] {
        b.push((name, [x, 4.8, z], [x + 1.2, 4.85, z + 0.4], LIGHT, s));
    }
    b.push(("beam a", [4.3, 4.6, 0.02], [4.6, 4.98, 7.98], PLASTER, 0.2));
    b.push(("beam b", [7.9, 4.6, 0.02], [8.2, 4.98, 7.98], PLASTER, 0.2));
    b
}

/// The loft: 185 polygons, 14,400 patches, closed, lit by four ceiling lights.
pub fn loft() -> SceneDesc {
    let [sx, sy, sz] = LOFT_SIZE;
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let g = |nu, nv| PatchGrid::Cells { nu, nv };
    let materials = vec![
        material("floor", [0.45, 0.32, 0.22], [0.0; 3]),
        material("wood", [0.55, 0.40, 0.28], [0.0; 3]),
        material("plaster", [0.78, 0.77, 0.74], [0.0; 3]),
        material("brick", [0.55, 0.30, 0.24], [0.0; 3]),
        material("glass", [0.15, 0.18, 0.22], [0.0; 3]),
        material("metal", [0.35, 0.35, 0.37], [0.0; 3]),
        material("light", [0.8, 0.8, 0.8], [40.0, 38.0, 33.0]),
    ];
    let (floor, wood, plaster, brick, glass) = (0, 1, 2, 3, 4);
    // Room: 11 inward polygons, 0.2 m patches.
    let mut polygons: Vec<PolygonDesc> = vec![
        rect("floor", Vec3::ZERO, z * sz, x * sx, floor, g(40, 60)),
        rect("ceiling", y * sy, x * sx, z * sz, plaster, g(60, 40)),
        rect("wall x0", Vec3::ZERO, y * sy, z * sz, brick, g(25, 40)),
        rect("wall x12", x * sx, z * sz, y * sy, plaster, g(40, 25)),
        // z = 0 wall, facing +z: left part, door, over the door, right part.
        rect(
            "wall z0 left",
            Vec3::ZERO,
            x * 5.0,
            y * sy,
            plaster,
            g(25, 25),
        ),
        rect("door", x * 5.0, x * 1.2, y * 2.4, wood, g(6, 12)),
        rect(
            "wall z0 over door",
            Vec3::new(5.0, 2.4, 0.0),
            x * 1.2,
            y * 2.6,
            plaster,
            g(6, 13),
        ),
        rect(
            "wall z0 right",
            x * 6.2,
            x * 5.8,
            y * sy,
            plaster,
            g(29, 25),
        ),
        // z = 8 wall, facing −z: a full-height window strip between two brick parts.
        rect("wall z8 left", z * sz, y * sy, x * 3.0, brick, g(25, 15)),
        rect(
            "window",
            Vec3::new(3.0, 0.0, sz),
            y * sy,
            x * 6.0,
            glass,
            g(25, 30),
        ),
        rect(
            "wall z8 right",
            Vec3::new(9.0, 0.0, sz),
            y * sy,
            x * 3.0,
            brick,
            g(25, 15),
        ),
    ];
    let _ = plaster;
    for (name, lo, hi, mat, size) in loft_boxes() {
        polygons.extend(box_faces(
            name,
            Vec3::from(lo),
            Vec3::from(hi),
            mat,
            size,
            true,
        ));
    }
    let _ = wood;
    SceneDesc {
        materials,
        polygons,
        camera: Some(Camera {
            position: Vec3::new(11.2, 1.7, 0.8),
            look_at: Vec3::new(3.0, 1.6, 6.5),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
        }),
    }
}
