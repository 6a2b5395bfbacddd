//! `--triangulate`: faces that are not valid polygons as they are (concave or warped)
//! are split into triangles by ear clipping; degenerate faces, and degenerate pieces of
//! split ones, are dropped and counted.

use crate::clip::plane_frame;
use crate::error::PolygonProblem;
use crate::polygon::vertices_problem;
use crate::scene::{rounded, PatchGrid, PolygonDesc, SceneDesc};
use glam::{DVec2, DVec3, Vec3};

/// What [`triangulate`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Triangulation {
    /// Faces split into triangles (concave or not planar).
    pub split: usize,
    /// Triangles those faces gave (degenerate ones not counted).
    pub triangles: usize,
    /// Faces, or triangles of split faces, dropped as degenerate (too few distinct
    /// vertices, no area, too small for the f32 ray tests, or a self-crossing outline).
    pub dropped: usize,
    /// The first face dropped and why, for the warning.
    pub first_dropped: Option<String>,
}

/// Splits every face of `desc` that is concave or not planar into triangles, and drops
/// degenerate faces; valid faces, and faces with problems splitting cannot mend (a
/// non-finite or out-of-range vertex), are kept as they are, for validation to name.
///
/// A split face's triangles keep its material, group and obstruction flag, are named
/// `<face>/tri <k>`, and take its patch size (a face with an `nu × nv` grid gives its
/// triangles cells of the same mean area).
pub fn triangulate(desc: &mut SceneDesc) -> Triangulation {
    let mut report = Triangulation::default();
    let faces = std::mem::take(&mut desc.polygons);
    let mut out = Vec::with_capacity(faces.len());
    let discard = |report: &mut Triangulation, name: &str, why: String| {
        report.dropped += 1;
        if report.first_dropped.is_none() {
            report.first_dropped = Some(format!("{name:?} {why}"));
        }
    };
    for mut face in faces {
        // (Repeats as the polygon would hold them, in f32.)
        let same = |a: &DVec3, b: &DVec3| a.as_vec3() == b.as_vec3();
        face.vertices.dedup_by(|a, b| same(a, b));
        while face.vertices.len() > 1
            && same(&face.vertices[0], &face.vertices[face.vertices.len() - 1])
        {
            face.vertices.pop();
        }
        match vertices_problem(&rounded(&face.vertices)) {
            None => out.push(face),
            Some(PolygonProblem::NonConvex { .. } | PolygonProblem::NonPlanar { .. }) => {
                let Some(triangles) = ear_clip(&rounded(&face.vertices)) else {
                    discard(
                        &mut report,
                        &face.name,
                        "has an outline that crosses itself".into(),
                    );
                    continue;
                };
                report.split += 1;
                let grid = split_grid(&face);
                for (k, [a, b, c]) in triangles.into_iter().enumerate() {
                    let vertices = vec![face.vertices[a], face.vertices[b], face.vertices[c]];
                    let name = format!("{}/tri {k}", face.name);
                    if let Some(problem) = vertices_problem(&rounded(&vertices)) {
                        discard(&mut report, &name, problem.to_string());
                        continue;
                    }
                    report.triangles += 1;
                    out.push(PolygonDesc {
                        name,
                        vertices,
                        grid,
                        group: face.group.clone(),
                        ..face.clone()
                    });
                }
            }
            Some(
                problem @ (PolygonProblem::TooFewVertices { .. }
                | PolygonProblem::Degenerate { .. }
                | PolygonProblem::TooSmall { .. }),
            ) => discard(&mut report, &face.name, problem.to_string()),
            Some(_) => out.push(face),
        }
    }
    desc.polygons = out;
    report
}

/// The patch grid of a split face's triangles.
fn split_grid(face: &PolygonDesc) -> PatchGrid {
    match face.grid {
        PatchGrid::Size(s) => PatchGrid::Size(s),
        PatchGrid::Cells { nu, nv } => {
            let area = 0.5 * newell(&rounded(&face.vertices)).length();
            PatchGrid::Size((area / nu.max(1).saturating_mul(nv.max(1)) as f64).sqrt())
        }
    }
}

/// Newell's normal (twice the area, for a planar outline).
fn newell(vertices: &[Vec3]) -> DVec3 {
    let n = vertices.len();
    (0..n)
        .map(|k| {
            vertices[k]
                .as_dvec3()
                .cross(vertices[(k + 1) % n].as_dvec3())
        })
        .sum()
}

/// Outlines up to this many vertices cut their fattest ear first; longer ones their
/// first ear (quadratic rather than cubic).
pub const BEST_EAR_VERTICES: usize = 64;

/// Longest outline [`ear_clip`] splits.
pub const MAX_EAR_CLIP_VERTICES: usize = 100_000;

/// Ear clipping of a simple outline, projected on the plane of its Newell normal: the
/// triangles as vertex indices, each turning the outline's way; `None` when no ear is
/// left to cut before the end (an outline that crosses itself, or no area).
///
/// An ear is a convex corner whose triangle holds no other remaining vertex (on its
/// edges included); of the ears, the one whose triangle is the least thin is cut first
/// (outlines of up to [`BEST_EAR_VERTICES`]; the first ear found beyond), so that
/// collinear runs are not cut into slivers while a better ear remains. The triangles'
/// areas must add up to the outline's (within 1e-6), else `None`: an outline that
/// crosses itself is refused, never mis-split. Outlines of over [`MAX_EAR_CLIP_VERTICES`]
/// are refused too (ear clipping is quadratic).
pub fn ear_clip(vertices: &[Vec3]) -> Option<Vec<[usize; 3]>> {
    let n = vertices.len();
    if !(3..=MAX_EAR_CLIP_VERTICES).contains(&n) {
        return None;
    }
    let normal = newell(vertices);
    if !(normal.length() > 0.0) {
        return None;
    }
    let normal = normal.normalize();
    let (ex, ey) = plane_frame(normal);
    let origin = vertices[0].as_dvec3();
    let pts: Vec<DVec2> = vertices
        .iter()
        .map(|p| {
            let d = p.as_dvec3() - origin;
            DVec2::new(d.dot(ex), d.dot(ey))
        })
        .collect();
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut ring: Vec<usize> = (0..n).collect();
    let mut triangles = Vec::with_capacity(n - 2);
    while ring.len() > 3 {
        let m = ring.len();
        let mut best: Option<(usize, f64)> = None;
        for k in 0..m {
            let (a, b, c) = (ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]);
            let (pa, pb, pc) = (pts[a], pts[b], pts[c]);
            let area2 = cross(pa, pb, pc);
            if !(area2 > 0.0) {
                continue;
            }
            let inside = ring.iter().any(|&q| {
                q != a
                    && q != b
                    && q != c
                    && pts[q] != pa
                    && pts[q] != pb
                    && pts[q] != pc
                    && cross(pa, pb, pts[q]) >= 0.0
                    && cross(pb, pc, pts[q]) >= 0.0
                    && cross(pc, pa, pts[q]) >= 0.0
            });
            if inside {
                continue;
            }
            // Thinness: area over the squared longest edge (larger is fatter).
            let longest = (pb - pa)
                .length_squared()
                .max((pc - pb).length_squared())
                .max((pa - pc).length_squared());
            let quality = area2 / longest;
            if best.is_none_or(|(_, q)| quality > q) {
                best = Some((k, quality));
                if n > BEST_EAR_VERTICES {
                    break;
                }
            }
        }
        let (k, _) = best?;
        let m = ring.len();
        triangles.push([ring[(k + m - 1) % m], ring[k], ring[(k + 1) % m]]);
        ring.remove(k);
    }
    if cross(pts[ring[0]], pts[ring[1]], pts[ring[2]]) > 0.0 {
        triangles.push([ring[0], ring[1], ring[2]]);
    }
    // The pieces must tile the outline: their areas add up to its own.
    let outline = 0.5
        * (0..n)
            .map(|k| pts[k].perp_dot(pts[(k + 1) % n]))
            .sum::<f64>();
    let pieces: f64 = triangles
        .iter()
        .map(|t| 0.5 * cross(pts[t[0]], pts[t[1]], pts[t[2]]))
        .sum();
    if triangles.is_empty() || !((pieces - outline).abs() <= 1e-6 * outline.abs()) {
        return None;
    }
    Some(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Scene};
    use rad_core::Rgb;

    fn desc(faces: Vec<Vec<Vec3>>) -> SceneDesc {
        SceneDesc {
            materials: vec![Material {
                name: "m".into(),
                reflectance: Rgb([0.5; 3]),
                emission: Rgb::BLACK,
            }],
            polygons: faces
                .into_iter()
                .enumerate()
                .map(|(k, vertices)| PolygonDesc {
                    name: format!("face {k}"),
                    vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
                    material: 0,
                    grid: PatchGrid::Size(0.25),
                    group: Some("g".into()),
                    obstruction: false,
                    two_sided: false,
                })
                .collect(),
            camera: None,
        }
    }

    fn area(vertices: &[Vec3]) -> f64 {
        0.5 * newell(vertices).length()
    }

    /// An L-shaped hexagon (concave at vertex 3), area 3.
    fn ell() -> Vec<Vec3> {
        [[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]]
            .map(|[x, y]| Vec3::new(x, y, 0.0))
            .to_vec()
    }

    #[test]
    fn a_concave_face_is_refused_as_it_is_and_split_when_asked() {
        let err = Scene::new(desc(vec![ell()])).unwrap_err();
        assert!(matches!(
            err.polygon_problem(),
            Some(PolygonProblem::NonConvex { .. })
        ));
        let mut d = desc(vec![ell()]);
        let report = triangulate(&mut d);
        assert_eq!((report.split, report.triangles, report.dropped), (1, 4, 0));
        let total: f64 = d.polygons.iter().map(|p| area(&rounded(&p.vertices))).sum();
        assert!((total - 3.0).abs() < 1e-12, "{total}");
        for p in &d.polygons {
            assert!(
                newell(&rounded(&p.vertices)).z > 0.0,
                "{} turns the wrong way",
                p.name
            );
            assert_eq!(p.group.as_deref(), Some("g"));
        }
        Scene::new(d).unwrap();
    }

    #[test]
    fn a_warped_quad_becomes_two_planar_triangles() {
        let quad = vec![
            Vec3::new(0., 0., 0.),
            Vec3::new(1., 0., 0.1),
            Vec3::new(1., 1., 0.),
            Vec3::new(0., 1., 0.1),
        ];
        assert!(matches!(
            vertices_problem(&quad),
            Some(PolygonProblem::NonPlanar { .. })
        ));
        let mut d = desc(vec![quad]);
        let report = triangulate(&mut d);
        assert_eq!((report.split, report.triangles), (1, 2));
        Scene::new(d).unwrap();
    }

    #[test]
    fn degenerate_faces_are_dropped_and_counted_valid_ones_kept_bit_for_bit() {
        let good = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let collinear = vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let repeated = vec![Vec3::ZERO, Vec3::ZERO, Vec3::X];
        let mut d = desc(vec![good.clone(), collinear, repeated, good.clone()]);
        let before = d.polygons[0].clone();
        let report = triangulate(&mut d);
        assert_eq!((report.split, report.dropped), (0, 2));
        assert!(report.first_dropped.unwrap().contains("face 1"));
        assert_eq!(d.polygons.len(), 2);
        assert_eq!(d.polygons[0], before);
    }

    #[test]
    fn ear_clipping_covers_random_star_shaped_outlines_exactly() {
        // Star-shaped (hence simple) outlines with radii in [0.3, 1]: the triangles'
        // areas add up to the outline's and each turns its way.
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..300 {
            let n = 3 + case % 17;
            let pts: Vec<Vec3> = (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * (k as f64 + 0.8 * next()) / n as f64;
                    let r = 0.3 + 0.7 * next();
                    Vec3::new((r * a.cos()) as f32, (r * a.sin()) as f32, 0.0)
                })
                .collect();
            let tris = ear_clip(&pts).unwrap_or_else(|| panic!("case {case}: no ears"));
            assert_eq!(tris.len(), n - 2, "case {case}");
            let sum: f64 = tris
                .iter()
                .map(|t| {
                    let v = t.map(|i| pts[i]);
                    let n = newell(&v);
                    assert!(n.z >= 0.0, "case {case}: a triangle turns the wrong way");
                    0.5 * n.length()
                })
                .sum();
            assert!(
                (sum - area(&pts)).abs() < 1e-9,
                "case {case}: {sum} vs {}",
                area(&pts)
            );
        }
    }

    #[test]
    fn a_lopsided_self_crossing_outline_is_refused() {
        // Lobes of 16/3 and 4/3: a nonzero Newell normal, but no tiling by ears.
        let pts = [[0., 0.], [4., 4.], [4., 0.], [0., 2.]].map(|[x, y]| Vec3::new(x, y, 0.0));
        assert_eq!(ear_clip(&pts), None);
    }

    #[test]
    fn clockwise_and_tilted_outlines_split_their_own_way() {
        // The L, wound clockwise (normal -z), then turned about an oblique axis.
        let mut l = ell();
        l.reverse();
        let rot = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
        for pts in [l.clone(), l.iter().map(|&p| rot * p).collect::<Vec<_>>()] {
            let n = newell(&pts);
            let tris = ear_clip(&pts).unwrap();
            assert_eq!(tris.len(), 4);
            let mut sum = 0.0;
            for t in &tris {
                let tn = newell(&t.map(|i| pts[i]));
                assert!(tn.dot(n) > 0.0, "a triangle turns the wrong way");
                sum += 0.5 * tn.length();
            }
            assert!((sum - 3.0).abs() < 1e-5, "{sum}");
        }
    }

    #[test]
    fn a_self_crossing_outline_is_dropped_not_mis_split() {
        // A bow tie: its Newell normal is zero, so no plane to cut it in.
        let bow = vec![Vec3::ZERO, Vec3::new(1., 1., 0.), Vec3::X, Vec3::Y];
        let mut d = desc(vec![bow, vec![Vec3::ZERO, Vec3::X, Vec3::Y]]);
        let report = triangulate(&mut d);
        assert_eq!(report.dropped, 1);
        assert_eq!(d.polygons.len(), 1);
    }
}
