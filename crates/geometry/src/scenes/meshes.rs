//! Mesh bench scenes, for exact hemispheres as the polygon count grows: the loft
//! tessellated at three levels (the same geometry, so the same form factors up to the
//! patches' shapes), and a curved, irregular triangle mesh in a closed room.

use super::{box_faces, loft, material};
use crate::scene::{Camera, Material, PatchGrid, PolygonDesc, SceneDesc};
use crate::Scene;
use glam::Vec3;
use std::collections::HashMap;

const ONE: PatchGrid = PatchGrid::Cells { nu: 1, nv: 1 };

/// The loft's patches, each with its polygon's material and name, corners
/// counter-clockwise seen from the side it faces.
fn loft_cells() -> (SceneDesc, Vec<(usize, String, Vec<Vec3>)>) {
    let desc = loft();
    let scene = Scene::new(desc.clone()).expect("the loft is valid");
    let cells = scene
        .patches()
        .iter()
        .map(|p| {
            let poly = &desc.polygons[p.polygon as usize];
            let name = format!("{} {},{}", poly.name, p.cell[0], p.cell[1]);
            (poly.material, name, p.corners.clone())
        })
        .collect();
    (desc, cells)
}

/// The loft with its polygons replaced by `cut` of each patch's corners (every piece
/// one patch).
fn loft_cut(cut: impl Fn(&[Vec3]) -> Vec<Vec<Vec3>>) -> SceneDesc {
    let (desc, cells) = loft_cells();
    let mut polygons = Vec::new();
    for (material, name, corners) in cells {
        for (k, vertices) in cut(&corners).into_iter().enumerate() {
            polygons.push(PolygonDesc {
                name: format!("{name} {k}"),
                vertices: vertices.iter().map(|&v| super::as_written(v)).collect(),
                material,
                grid: ONE,
                group: None,
                obstruction: false,
                two_sided: false,
            });
        }
    }
    SceneDesc { polygons, ..desc }
}

/// The loft with every patch its own polygon: 14,400 polygons of one patch each.
pub fn loft_patches() -> SceneDesc {
    loft_cut(|c| vec![c.to_vec()])
}

/// The loft with every patch cut into triangles (a fan from its first corner; two a
/// rectangular patch): 28,800 one-patch triangles.
pub fn loft_triangles() -> SceneDesc {
    loft_cut(fan)
}

/// The loft with every patch cut 2 × 2 (through its edges' midpoints), each quarter
/// into two triangles: 115,200 one-patch triangles.
pub fn loft_fine_triangles() -> SceneDesc {
    loft_cut(|c| {
        if c.len() == 4 {
            let mid = |a: Vec3, b: Vec3| (a + b) * 0.5;
            let (m01, m12, m23, m30) = (
                mid(c[0], c[1]),
                mid(c[1], c[2]),
                mid(c[2], c[3]),
                mid(c[3], c[0]),
            );
            let centre = mid(m01, m23);
            [
                [c[0], m01, centre, m30],
                [m01, c[1], m12, centre],
                [centre, m12, c[2], m23],
                [m30, centre, m23, c[3]],
            ]
            .iter()
            .flat_map(|q| fan(q))
            .collect()
        } else {
            fan(c)
        }
    })
}

/// A convex polygon's fan of triangles from its first vertex.
fn fan(c: &[Vec3]) -> Vec<Vec<Vec3>> {
    (1..c.len() - 1)
        .map(|k| vec![c[0], c[k], c[k + 1]])
        .collect()
}

/// Size (x, y, z) of the blob's room, metres.
pub const BLOB_ROOM: [f32; 3] = [4.0, 3.0, 4.0];

/// A star-shaped blob of 20,480 triangles (an icosphere subdivided five times, its
/// radius displaced by a smooth sum of sines) standing clear of the floor in a closed
/// 4 × 3 × 4 m room lit by a ceiling lamp, every triangle one patch.
///
/// Why this shape: like a scanned object, it is a closed, curved mesh of many small,
/// irregular triangles (areas varying about fourfold), whose bumps hide one another
/// from most viewpoints, so a hemisphere sees thousands of polygons at every angle,
/// grazing ones included; and being star-shaped about its centre (radius a positive
/// function of direction), it cannot intersect itself, so it is valid by construction.
pub fn blob_room() -> SceneDesc {
    let [x, y, z] = BLOB_ROOM;
    let (materials, mut polygons) = lit_room(Vec3::new(x, y, z), ("clay", [0.6, 0.45, 0.35]));
    let centre = Vec3::new(0.5 * x, 1.15, 0.5 * z);
    let (vertices, faces) = icosphere(5);
    let radius = |d: Vec3| {
        let (theta, phi) = (d.y.clamp(-1.0, 1.0).acos(), d.z.atan2(d.x));
        0.75 * (1.0
            + 0.16 * (3.0 * theta).sin() * (2.0 * phi).cos()
            + 0.09 * (5.0 * phi + 1.0).sin() * (4.0 * theta).sin()
            + 0.05 * (7.0 * theta + 2.0 * phi).cos())
    };
    let at: Vec<Vec3> = vertices.iter().map(|&d| centre + d * radius(d)).collect();
    polygons.extend(one_patch_triangles("blob", &at, &faces, 1));
    SceneDesc {
        materials,
        polygons,
        camera: Some(Camera {
            position: Vec3::new(0.5 * x, 1.6, z - 0.05),
            look_at: centre,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
        }),
    }
}

/// A closed room of `size` (white walls facing in, cut into 0.25 m cells) lit by a
/// 0.8 × 0.06 × 0.8 m lamp box under the middle of its ceiling: the materials (white,
/// the object's `(name, reflectance)`, the lamp) and the polygons.
pub(super) fn lit_room(size: Vec3, object: (&str, [f64; 3])) -> (Vec<Material>, Vec<PolygonDesc>) {
    let materials = vec![
        material("white", [0.7, 0.7, 0.7], [0.0; 3]),
        material(object.0, object.1, [0.0; 3]),
        material("lamp", [0.8, 0.8, 0.8], [30.0, 30.0, 28.0]),
    ];
    let mut polygons = box_faces("room", Vec3::ZERO, size, 0, 0.25, false);
    let lamp_lo = Vec3::new(0.5 * size.x - 0.4, size.y - 0.12, 0.5 * size.z - 0.4);
    polygons.extend(box_faces(
        "lamp",
        lamp_lo,
        lamp_lo + Vec3::new(0.8, 0.06, 0.8),
        2,
        0.2,
        true,
    ));
    (materials, polygons)
}

/// Triangles `faces` of the vertices `at`, each one patch of `material`, named
/// `"{name} {k}"`.
pub(super) fn one_patch_triangles<'a>(
    name: &'a str,
    at: &'a [Vec3],
    faces: &'a [[usize; 3]],
    material: usize,
) -> impl Iterator<Item = PolygonDesc> + 'a {
    faces.iter().enumerate().map(move |(k, f)| PolygonDesc {
        name: format!("{name} {k}"),
        vertices: f.iter().map(|&i| super::as_written(at[i])).collect(),
        material,
        grid: ONE,
        group: None,
        obstruction: false,
        two_sided: false,
    })
}

/// The unit icosphere subdivided `levels` times: vertices, and triangles
/// counter-clockwise seen from outside (20 · 4^levels of them).
pub(super) fn icosphere(levels: u32) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(a, b, c)| Vec3::new(a, b, c).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut split = |a: usize, b: usize, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        let mut next = Vec::with_capacity(4 * f.len());
        for &[a, b, c] in &f {
            let (ab, bc, ca) = (
                split(a, b, &mut v),
                split(b, c, &mut v),
                split(c, a, &mut v),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}
