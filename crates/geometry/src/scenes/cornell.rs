//! The Cornell box from its published geometry (Cornell Program of Computer Graphics,
//! "Cornell Box Data", graphics.cornell.edu/online/box/data.html), in millimetres.
//!
//! Three changes, none of which moves a published vertex:
//! - the left (red) wall is 3.2 mm from planar; it is split into the triangles (0,1,2)
//!   and (0,2,3), as most renderers do;
//! - the light lies in the ceiling's plane; the ceiling is cut into the four rectangles
//!   around the light, so the two do not overlap;
//! - the blocks have no bottom and stand on the floor; the floor is cut into convex
//!   pieces around their footprints, so no floor patch lies under a block.
//!
//! RGB reflectances and the light's emission are those of Benedikt Bitterli's
//! "cornell-box" rendering resource (also Morgan McGuire's CornellBox-Original.mtl):
//! white (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05), green (0.14, 0.45, 0.091),
//! light (17, 12, 4).

use super::material;
use crate::scene::{Camera, PatchGrid, PolygonDesc, SceneDesc};
use glam::{DVec2, Vec3};

fn v(p: [f32; 3]) -> Vec3 {
    Vec3::from(p)
}

const SHORT_BLOCK: [[[f32; 3]; 4]; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];

const TALL_BLOCK: [[[f32; 3]; 4]; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];

/// Patch size of `bench-scenes/cornell.json`, millimetres.
pub const CORNELL_PATCH_MM: f32 = 40.0;

/// The Cornell box with patches about `patch_size` mm on a side.
pub fn cornell_box(patch_size: f32) -> SceneDesc {
    let materials = vec![
        material("white", [0.725, 0.71, 0.68], [0.0; 3]),
        material("red", [0.63, 0.065, 0.05], [0.0; 3]),
        material("green", [0.14, 0.45, 0.091], [0.0; 3]),
        material("light", [0.78, 0.78, 0.78], [17.0, 12.0, 4.0]),
    ];
    let (white, red, green, light) = (0, 1, 2, 3);
    let size = PatchGrid::Size(patch_size as f64);
    let poly = |name: &str, pts: &[[f32; 3]], material| PolygonDesc {
        name: name.to_string(),
        vertices: pts.iter().map(|&p| super::as_written(v(p))).collect(),
        material,
        grid: size,
        group: None,
        obstruction: false,
        two_sided: false,
    };
    let mut polygons = Vec::new();
    // Floor, cut around the two block footprints (y = 0, normal +y).
    let floor = [
        [552.8, 0.0, 0.0],
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 559.2],
        [549.6, 0.0, 559.2],
    ];
    let footprint = |block: &[[[f32; 3]; 4]; 5]| -> Vec<DVec2> {
        // The top face's outline, projected to the floor (x, z).
        block[0]
            .iter()
            .map(|p| DVec2::new(p[0] as f64, p[2] as f64))
            .collect()
    };
    let to2 = |p: &[f32; 3]| DVec2::new(p[0] as f64, p[2] as f64);
    let mut pieces = vec![floor.iter().map(to2).collect::<Vec<_>>()];
    for hole in [footprint(&SHORT_BLOCK), footprint(&TALL_BLOCK)] {
        pieces = pieces
            .into_iter()
            .flat_map(|piece| subtract_convex(&piece, &hole))
            .collect();
    }
    for (k, piece) in pieces.iter().enumerate() {
        let pts: Vec<[f32; 3]> = piece
            .iter()
            .map(|p| [p.x as f32, 0.0, p.y as f32])
            .collect();
        polygons.push(poly(&format!("floor {k}"), &pts, white));
    }
    // Ceiling (y = 548.8, normal −y) around the light [213, 343] × [227, 332].
    let c = |x0: f32, x1: f32, z0: f32, z1: f32| {
        [
            [x1, 548.8, z0],
            [x1, 548.8, z1],
            [x0, 548.8, z1],
            [x0, 548.8, z0],
        ]
    };
    polygons.push(poly("ceiling front", &c(0.0, 556.0, 0.0, 227.0), white));
    polygons.push(poly("ceiling back", &c(0.0, 556.0, 332.0, 559.2), white));
    polygons.push(poly("ceiling right", &c(0.0, 213.0, 227.0, 332.0), white));
    polygons.push(poly("ceiling left", &c(343.0, 556.0, 227.0, 332.0), white));
    polygons.push(poly("light", &c(213.0, 343.0, 227.0, 332.0), light));
    polygons.push(poly(
        "back wall",
        &[
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        white,
    ));
    polygons.push(poly(
        "right wall",
        &[
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        green,
    ));
    let left = [
        [552.8, 0.0, 0.0],
        [549.6, 0.0, 559.2],
        [556.0, 548.8, 559.2],
        [556.0, 548.8, 0.0],
    ];
    polygons.push(poly("left wall a", &[left[0], left[1], left[2]], red));
    polygons.push(poly("left wall b", &[left[0], left[2], left[3]], red));
    for (k, face) in SHORT_BLOCK.iter().enumerate() {
        polygons.push(poly(&format!("short block {k}"), face, white));
    }
    for (k, face) in TALL_BLOCK.iter().enumerate() {
        polygons.push(poly(&format!("tall block {k}"), face, white));
    }
    SceneDesc {
        materials,
        polygons,
        camera: Some(Camera {
            position: Vec3::new(278.0, 273.0, -800.0),
            look_at: Vec3::new(278.0, 273.0, 0.0),
            up: Vec3::Y,
            // Focal length 35 mm, film 25 mm: 2·atan(12.5 / 35).
            fov_y: 2.0 * (12.5f32 / 35.0).atan(),
        }),
    }
}

/// `region − hole` for convex polygons in the plane, as convex pieces: for each edge of
/// the hole, the part of what is left that lies outside that edge's line is a piece.
/// Orientation of the inputs is arbitrary; pieces keep `region`'s orientation.
fn subtract_convex(region: &[DVec2], hole: &[DVec2]) -> Vec<Vec<DVec2>> {
    let ccw = |p: &[DVec2]| {
        let mut a = 0.0;
        for k in 0..p.len() {
            a += p[k].perp_dot(p[(k + 1) % p.len()]);
        }
        a > 0.0
    };
    let mut hole: Vec<DVec2> = hole.to_vec();
    if !ccw(&hole) {
        hole.reverse();
    }
    let mut rest = region.to_vec();
    let mut pieces = Vec::new();
    for k in 0..hole.len() {
        let (a, b) = (hole[k], hole[(k + 1) % hole.len()]);
        // Outside this edge: (b − a) × (p − a) < 0 for a counter-clockwise hole.
        let outside = clip_half_plane(&rest, |p| -(b - a).perp_dot(p - a));
        let inside = clip_half_plane(&rest, |p| (b - a).perp_dot(p - a));
        if area(&outside) > 1e-9 {
            pieces.push(outside);
        }
        rest = inside;
        if area(&rest) <= 1e-9 {
            break;
        }
    }
    pieces
}

fn area(p: &[DVec2]) -> f64 {
    let mut a = 0.0;
    for k in 0..p.len() {
        a += p[k].perp_dot(p[(k + 1) % p.len()]);
    }
    0.5 * a.abs()
}

/// The part of convex polygon `p` where `f ≥ 0` (`f` affine), dropping repeated points.
fn clip_half_plane(p: &[DVec2], f: impl Fn(DVec2) -> f64) -> Vec<DVec2> {
    let mut out: Vec<DVec2> = Vec::new();
    for k in 0..p.len() {
        let (cur, next) = (p[k], p[(k + 1) % p.len()]);
        let (fc, fnx) = (f(cur), f(next));
        if fc >= 0.0 {
            out.push(cur);
        }
        if (fc >= 0.0) != (fnx >= 0.0) {
            let t = fc / (fc - fnx);
            out.push(cur + (next - cur) * t);
        }
    }
    out.dedup_by(|a, b| (*a - *b).length() < 1e-9);
    if out.len() > 1 && (out[0] - out[out.len() - 1]).length() < 1e-9 {
        out.pop();
    }
    out
}
