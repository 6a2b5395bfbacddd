//! Test support (a dev-dependency only): proptest strategies for random valid scenes
//! of convex polygons, and for rays through them; a mutation fuzzer for the scene-file
//! parsers (`fuzz`).
//!
//! - `fuzz`: the byte-level mutation fuzzer, deterministic for a seed.
//!
//! The strategies (`convex_polygon`, `random_scene`, `ray`, ...) live in the crate root.

pub mod fuzz;

use glam::Vec3;
use proptest::prelude::*;
use rad_core::Rgb;
use rad_geometry::{Material, PatchGrid, PolygonDesc, SceneDesc};

/// A unit vector, uniformly distributed enough for tests (normalised Gaussian-ish).
pub fn unit_vector() -> impl Strategy<Value = Vec3> {
    (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
        .prop_filter("not too short", |(x, y, z)| {
            let l = (x * x + y * y + z * z).sqrt();
            l > 0.2 && l <= 1.0
        })
        .prop_map(|(x, y, z)| Vec3::new(x, y, z).normalize())
}

/// A random planar convex polygon: 3 to 7 vertices on an ellipse (sorted angles), or a
/// parallelogram, centred in `[-2, 2]³`, of size up to about 1.5.
pub fn convex_polygon(idx: usize) -> impl Strategy<Value = PolygonDesc> {
    let centre =
        (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    let shape = prop_oneof![
        // Parallelogram: two edge vectors.
        (unit_vector(), unit_vector(), 0.1f32..1.5, 0.1f32..1.5).prop_filter_map(
            "edges too parallel",
            |(a, b, la, lb)| {
                (a.cross(b).length() > 0.3).then(|| {
                    let (eu, ev) = (a * la, b * lb);
                    vec![
                        -0.5 * (eu + ev),
                        0.5 * (eu - ev),
                        0.5 * (eu + ev),
                        0.5 * (ev - eu),
                    ]
                })
            }
        ),
        // Ellipse polygon.
        (
            unit_vector(),
            unit_vector(),
            0.1f32..1.0,
            0.1f32..1.0,
            proptest::collection::vec(0.0f32..1.0, 3..=7)
        )
            .prop_filter_map("degenerate", |(n, a, ra, rb, mut cuts)| {
                let t = (a - n * n.dot(a)).try_normalize()?;
                let b = n.cross(t);
                cuts.sort_by(f32::total_cmp);
                cuts.dedup_by(|x, y| (*x - *y).abs() < 0.05);
                if cuts.len() < 3 || (1.0 - cuts[cuts.len() - 1] + cuts[0]) < 0.05 {
                    return None;
                }
                // Every vertex angle gap below π keeps the centre inside; require it.
                let gaps_ok = cuts.windows(2).all(|w| w[1] - w[0] < 0.45)
                    && (1.0 - cuts[cuts.len() - 1] + cuts[0]) < 0.45;
                gaps_ok.then(|| {
                    cuts.iter()
                        .map(|c| {
                            let phi = c * std::f32::consts::TAU;
                            t * (ra * phi.cos()) + b * (rb * phi.sin())
                        })
                        .collect()
                })
            }),
    ];
    (centre, shape, 1u64..4, 1u64..4).prop_map(move |(c, pts, nu, nv)| PolygonDesc {
        name: format!("random {idx}"),
        vertices: pts.into_iter().map(|p: Vec3| (p + c).as_dvec3()).collect(),
        material: 0,
        grid: PatchGrid::Cells { nu, nv },
        group: None,
        obstruction: false,
        two_sided: false,
    })
}

/// A scene of 1 to `max` random convex polygons (they may intersect each other).
pub fn random_scene(max: usize) -> impl Strategy<Value = SceneDesc> {
    proptest::collection::vec(0usize..1, 1..=max)
        .prop_flat_map(|v| {
            v.iter()
                .enumerate()
                .map(|(i, _)| convex_polygon(i))
                .collect::<Vec<_>>()
        })
        .prop_map(|polygons| SceneDesc {
            materials: vec![Material {
                name: "grey".into(),
                reflectance: Rgb([0.5; 3]),
                emission: Rgb::BLACK,
            }],
            polygons,
            camera: None,
        })
}

/// `desc` with polygon k two-sided where `sides[k % len]` says so (none if `sides` is
/// empty; obstructions stay one-sided).
pub fn with_two_sided(mut desc: SceneDesc, sides: &[bool]) -> SceneDesc {
    if !sides.is_empty() {
        for (k, p) in desc.polygons.iter_mut().enumerate() {
            p.two_sided = sides[k % sides.len()] && !p.obstruction;
        }
    }
    desc
}

/// Flags for [`with_two_sided`]: none two-sided in about a third of the cases, else a
/// random mix.
pub fn two_sided_flags() -> impl Strategy<Value = Vec<bool>> {
    prop_oneof![
        Just(Vec::new()),
        proptest::collection::vec(any::<bool>(), 1..8),
        proptest::collection::vec(any::<bool>(), 1..8),
    ]
}

/// A ray origin in `[-3, 3]³` and a unit direction.
pub fn ray() -> impl Strategy<Value = (Vec3, Vec3)> {
    (
        (-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
        unit_vector(),
    )
}
