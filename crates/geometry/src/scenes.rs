//! Deterministic builders of the bench scenes: the report's empty cube, our loft-like
//! interior (the report never published its loft), the Cornell box, and the mesh
//! scenes (the loft tessellated at three levels, a curved mesh in a room, galleries of
//! scan-like sculptures of ~10^5 and ~10^6 triangles), an urban canyon of 20,536
//! facets for view factors at scale, and scenes that move (a satellite, a room with a
//! cart) with their motions.

mod canyon;
mod cornell;
mod cube;
mod loft;
mod meshes;
mod moving;
mod sculptures;

pub use canyon::{urban_canyon, CANYON_FACETS};
pub use cornell::{cornell_box, CORNELL_PATCH_MM};
pub use cube::{cube, CUBE_FACES};
pub use meshes::{blob_room, loft_fine_triangles, loft_patches, loft_triangles, BLOB_ROOM};
pub use moving::{
    cart_motion, room_with_cart, satellite, satellite_motion, slide, with_cart, SATELLITE_ARRAYS,
    SATELLITE_STILL,
};
pub use sculptures::{sculptures, sculptures_100k, sculptures_1m, SCULPTURES_100K, SCULPTURES_1M};

use crate::scene::{Material, PatchGrid, PolygonDesc};
use glam::Vec3;
use rad_core::Rgb;

/// A vertex built in f32 as a scene file written from it gives it (the f64 of the
/// shortest decimal that reads back as that f32: 0.02, not 0.0199999995529651): so a
/// built scene and its committed file are the same description, to the divided scene
/// rows are made from ([`crate::Scene::for_rows`]).
pub fn as_written(v: Vec3) -> glam::DVec3 {
    let decimal = |c: f32| c.to_string().parse::<f64>().unwrap_or(f64::from(c));
    glam::DVec3::new(decimal(v.x), decimal(v.y), decimal(v.z))
}

/// A parallelogram `o, o+e_u, o+e_u+e_v, o+e_v`; its normal is `e_u × e_v`.
pub(crate) fn rect(
    name: impl Into<String>,
    o: Vec3,
    e_u: Vec3,
    e_v: Vec3,
    material: usize,
    grid: PatchGrid,
) -> PolygonDesc {
    PolygonDesc {
        name: name.into(),
        vertices: [o, o + e_u, o + e_u + e_v, o + e_v]
            .map(as_written)
            .to_vec(),
        material,
        grid,
        group: None,
        obstruction: false,
        two_sided: false,
    }
}

/// Patch grid of a rectangle with edges `lu`, `lv` cut into cells of about `size`.
pub(crate) fn cells_for(lu: f32, lv: f32, size: f32) -> PatchGrid {
    let c = |l: f32| ((l / size).round() as u64).max(1);
    PatchGrid::Cells {
        nu: c(lu),
        nv: c(lv),
    }
}

/// The six faces of the box `[lo, hi]`, facing out (`outward`) or in, each cut into
/// cells of about `size`. Order: −x, +x, −y, +y, −z, +z.
pub(crate) fn box_faces(
    name: &str,
    lo: Vec3,
    hi: Vec3,
    material: usize,
    size: f32,
    outward: bool,
) -> Vec<PolygonDesc> {
    let d = hi - lo;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    // (label, origin, a, b) with a × b pointing outward.
    let faces = [
        ("-x", lo, z, y),
        ("+x", Vec3::new(hi.x, lo.y, lo.z), y, z),
        ("-y", lo, x, z),
        ("+y", Vec3::new(lo.x, hi.y, lo.z), z, x),
        ("-z", lo, y, x),
        ("+z", Vec3::new(lo.x, lo.y, hi.z), x, y),
    ];
    faces
        .into_iter()
        .map(|(label, o, a, b)| {
            let (a, b) = if outward { (a, b) } else { (b, a) };
            rect(
                format!("{name} {label}"),
                o,
                a,
                b,
                material,
                cells_for(a.length(), b.length(), size),
            )
        })
        .collect()
}

pub(crate) fn material(name: &str, reflectance: [f64; 3], emission: [f64; 3]) -> Material {
    Material {
        name: name.to_string(),
        reflectance: Rgb(reflectance),
        emission: Rgb(emission),
    }
}
pub use loft::{loft, loft_boxes, LOFT_SIZE};
