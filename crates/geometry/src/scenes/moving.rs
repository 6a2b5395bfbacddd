//! Scenes that move, and their motions: a satellite whose two solar arrays turn about
//! their long axis (a spacecraft thermal model's commonest articulation, the bus and an
//! antenna still), and a room across whose floor a cart slides (a moving object
//! holding a small share of the area: what a step's cost is measured on).

use super::{box_faces, material, rect};
use crate::motion::{Motion, MotionStep, Rigid};
use crate::scene::{PatchGrid, PolygonDesc, SceneDesc};
use glam::{DVec3, Vec3};
use std::collections::BTreeMap;

/// The satellite's groups that move, and the still ones.
pub const SATELLITE_ARRAYS: [&str; 2] = ["array +x", "array -x"];
pub const SATELLITE_STILL: [&str; 2] = ["bus", "antenna"];

/// A satellite (metres): a 1 m cube bus about the origin (group `bus`, patches of 0.25
/// m); on each side along x, from 0.8 m to 3.8 m, a solar array of three 1 m panels,
/// two-sided, in the plane y = 0 as written (facing +y) (groups `array +x`, `array -x`), cut into
/// patches of 0.5 m; above the bus a flat hexagonal antenna of 0.4 m radius at z = 1
/// facing the bus's top (group `antenna`), on a boom. The arrays turn about the x axis.
pub fn satellite() -> SceneDesc {
    let mut polygons = box_faces("bus", Vec3::splat(-0.5), Vec3::splat(0.5), 0, 0.25, true);
    for p in &mut polygons {
        p.group = Some("bus".into());
    }
    for (group, sign) in [(SATELLITE_ARRAYS[0], 1.0f32), (SATELLITE_ARRAYS[1], -1.0)] {
        for k in 0..3 {
            let x0 = sign * (0.8 + k as f32);
            let (o, e_u) = if sign > 0.0 {
                (Vec3::new(x0, 0.0, -0.5), Vec3::X)
            } else {
                (Vec3::new(x0 - 1.0, 0.0, -0.5), Vec3::X)
            };
            let mut p = rect(
                format!("{group} panel {k}"),
                o,
                Vec3::Z,
                e_u,
                1,
                PatchGrid::Cells { nu: 2, nv: 2 },
            );
            p.group = Some(group.into());
            p.two_sided = true;
            polygons.push(p);
        }
    }
    let hexagon = (0..6)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 6.0;
            // (Clockwise from above: facing down, towards the bus.)
            DVec3::new(0.4 * a.cos(), -0.4 * a.sin(), 1.0)
        })
        .map(|v| super::as_written(v.as_vec3()))
        .collect();
    polygons.push(PolygonDesc {
        name: "antenna dish".into(),
        vertices: hexagon,
        material: 2,
        grid: PatchGrid::Cells { nu: 3, nv: 3 },
        group: Some("antenna".into()),
        obstruction: false,
        two_sided: true,
    });
    let mut boom = rect(
        "antenna boom",
        Vec3::new(-0.05, 0.0, 0.5),
        Vec3::X * 0.1,
        Vec3::Z * 0.45,
        2,
        PatchGrid::Cells { nu: 1, nv: 2 },
    );
    boom.group = Some("antenna".into());
    boom.two_sided = true;
    polygons.push(boom);
    SceneDesc {
        materials: vec![
            material("bus blanket", [0.6; 3], [0.0; 3]),
            material("solar cells", [0.2; 3], [0.0; 3]),
            material("antenna", [0.8; 3], [0.0; 3]),
        ],
        polygons,
        camera: None,
    }
}

/// The arrays of [`satellite`] turning through `steps` equal steps of a full turn about
/// the x axis (10° a step for 36), both alike; the bus and antenna still.
pub fn satellite_motion(steps: usize) -> Motion {
    let steps = (0..steps)
        .map(|k| {
            let degrees = 360.0 * k as f64 / steps as f64;
            let pose = Rigid::turn(DVec3::X, degrees.to_radians(), DVec3::ZERO, DVec3::ZERO);
            MotionStep {
                name: format!("arrays at {degrees} deg"),
                poses: SATELLITE_ARRAYS
                    .iter()
                    .map(|g| (g.to_string(), pose))
                    .collect(),
            }
        })
        .collect();
    Motion {
        path: "satellite motion".into(),
        steps,
    }
}

/// A room 5 × 3 × 4 m (walls facing in, patches of 0.25 m, a light panel in the
/// ceiling), a table, and a cube cart of side `cart` m (group `cart`) on the floor
/// near a corner, lifted 1 cm off it.
pub fn room_with_cart(cart: f32) -> SceneDesc {
    let size = Vec3::new(5.0, 3.0, 4.0);
    let mut polygons = box_faces("room", Vec3::ZERO, size, 0, 0.25, false);
    let mut light = rect(
        "light",
        Vec3::new(2.0, 2.99, 1.5),
        Vec3::X,
        Vec3::Z,
        2,
        PatchGrid::Cells { nu: 2, nv: 2 },
    );
    light.two_sided = false;
    polygons.push(light);
    polygons.extend(box_faces(
        "table",
        Vec3::new(3.2, 0.7, 2.2),
        Vec3::new(4.4, 0.75, 3.4),
        1,
        0.25,
        true,
    ));
    let desc = SceneDesc {
        materials: vec![
            material("plaster", [0.7; 3], [0.0; 3]),
            material("wood", [0.5; 3], [0.0; 3]),
            material("light", [0.0; 3], [10.0; 3]),
        ],
        polygons,
        camera: None,
    };
    with_cart(desc, Vec3::new(0.4, 0.01, 0.4), cart, 1)
}

/// `desc` with a cube cart (group `cart`, six faces facing out, patches of 0.25 m) of
/// side `side` from corner `lo`, of material `material`.
pub fn with_cart(mut desc: SceneDesc, lo: Vec3, side: f32, material: usize) -> SceneDesc {
    let mut cart = box_faces("cart", lo, lo + Vec3::splat(side), material, 0.25, true);
    for p in &mut cart {
        p.group = Some("cart".into());
    }
    desc.polygons.extend(cart);
    desc
}

/// `steps` equal steps of a translation from nothing to `by` of group `group`.
pub fn slide(group: &str, by: DVec3, steps: usize) -> Motion {
    let steps = (0..steps)
        .map(|k| {
            let s = k as f64 / (steps.max(2) - 1) as f64;
            let pose = Rigid::turn(DVec3::Y, 0.0, DVec3::ZERO, by * s);
            MotionStep {
                name: format!("{group} at {s:.3}"),
                poses: BTreeMap::from([(group.to_string(), pose)]),
            }
        })
        .collect();
    Motion {
        path: format!("{group} sliding").into(),
        steps,
    }
}

/// The cart of [`room_with_cart`] sliding 2.5 m along the floor's diagonal in `steps`
/// equal steps, turning a quarter turn as it goes.
pub fn cart_motion(steps: usize) -> Motion {
    let steps = (0..steps)
        .map(|k| {
            let s = k as f64 / (steps.max(2) - 1) as f64;
            let pose = Rigid::turn(
                DVec3::Y,
                s * std::f64::consts::FRAC_PI_2,
                DVec3::new(0.7, 0.0, 0.7),
                DVec3::new(2.0 * s, 0.0, 1.5 * s),
            );
            MotionStep {
                name: format!("cart at {:.3}", s),
                poses: BTreeMap::from([("cart".to_string(), pose)]),
            }
        })
        .collect();
    Motion {
        path: "cart motion".into(),
        steps,
    }
}
