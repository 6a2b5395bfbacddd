//! Edge neighbours and facets: a mesh's flat pieces, and the polygon of a point on them.

use glam::Vec3;
use proptest::prelude::*;
use rad_core::NO_POLYGON;
use rad_geometry::scenes::cube;
use rad_geometry::{LocateScratch, Located, PatchGrid, PolygonDesc, Scene, SceneDesc};

fn one_patch(name: String, vertices: Vec<Vec3>) -> PolygonDesc {
    PolygonDesc {
        name,
        vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
        material: 0,
        grid: PatchGrid::Cells { nu: 1, nv: 1 },
        group: None,
        obstruction: false,
        two_sided: false,
    }
}

/// The unit square of the floor (y = 0, facing +y) cut into `n` × `n` squares of two
/// triangles, under the cube's ceiling; triangle `2(i n + j) + k`.
fn tessellated_floor(n: usize) -> SceneDesc {
    let mut desc = cube(2);
    desc.polygons.remove(0);
    let q = |i: usize, j: usize| Vec3::new(j as f32 / n as f32, 0.0, i as f32 / n as f32);
    for i in 0..n {
        for j in 0..n {
            // Counter-clockwise seen from above: +z before +x.
            let (a, b, c, d) = (q(i, j), q(i + 1, j), q(i + 1, j + 1), q(i, j + 1));
            desc.polygons
                .push(one_patch(format!("t{i}.{j}a"), vec![a, b, c]));
            desc.polygons
                .push(one_patch(format!("t{i}.{j}b"), vec![a, c, d]));
        }
    }
    desc
}

#[test]
fn edges_are_shared_by_the_polygon_across_them() {
    let scene = Scene::new(tessellated_floor(3)).unwrap();
    let first = 5; // the cube's other faces come first
    let edges = scene.edge_neighbours();
    // Triangle (0, 0, a) = [q00, q10, q11]: its edge q11 → q00 is shared with (0, 0, b);
    // q00 → q10 is the floor's border; q10 → q11 is shared with (1, 0, b).
    let a = first as u32;
    assert_eq!(edges.across(a), &[NO_POLYGON, a + 2 * 3 + 1, a + 1]);
    // The cube's walls meet the floor at right angles, facing other ways, along edges
    // that are not the triangles' (the walls are whole): no neighbour across theirs.
    assert!(edges.across(0).iter().all(|&q| q == NO_POLYGON));
}

#[test]
fn a_tessellated_plane_is_one_facet_and_its_points_find_their_triangle() {
    let n = 8;
    let scene = Scene::new(tessellated_floor(n)).unwrap();
    let facets = scene.facets();
    // The cube's five faces are facets alone (patch grids of their own), the floor's
    // 128 triangles one.
    assert_eq!(facets.len(), 6);
    let floor = facets.facet_of(5);
    assert!(facets.is_several(floor));
    assert_eq!(facets.polygons(floor).len(), 2 * n * n);
    for p in 0..5 {
        assert!(!facets.is_several(facets.facet_of(p)));
    }
    // Rays from above the floor: each clear point is in the triangle brute force finds.
    let o = Vec3::new(0.37, 0.6, 0.41);
    let mut dirs = [Vec::new(), Vec::new(), Vec::new()];
    let mut want = Vec::new();
    for k in 0..500 {
        let (x, z) = ((k % 25) as f32 / 24.5 + 0.01, (k / 25) as f32 / 19.5 + 0.01);
        let d = (Vec3::new(x, 0.0, z) - o).normalize();
        for (c, v) in dirs.iter_mut().zip([d.x, d.y, d.z]) {
            c.push(v);
        }
        let holder = scene.polygons()[5..]
            .iter()
            .position(|p| p.intersect(o, d, f32::INFINITY).is_some_and(|h| h.3))
            .map(|i| i as u32 + 5);
        want.push(holder);
    }
    let mut out = Vec::new();
    let mut scratch = LocateScratch::default();
    let far = vec![f32::INFINITY; 500];
    facets.locate_span(
        floor,
        o,
        [&dirs[0], &dirs[1], &dirs[2]],
        &far,
        &mut out,
        &mut scratch,
    );
    let mut clear = 0;
    for (k, l) in out.iter().enumerate() {
        match *l {
            Located::Clear(p, t) => {
                clear += 1;
                assert_eq!(Some(p), want[k], "ray {k}");
                let d = Vec3::new(dirs[0][k], dirs[1][k], dirs[2][k]);
                assert!(((o + d * t).y).abs() < 1e-5, "ray {k}: t {t}");
            }
            Located::Near => {
                let mut held = Vec::new();
                let d = Vec3::new(dirs[0][k], dirs[1][k], dirs[2][k]);
                facets.for_each_holding(floor, o, d, |p| held.push(p));
                assert!(
                    want[k].is_some_and(|w| held.contains(&w)),
                    "ray {k}: {held:?}"
                );
            }
            Located::Outside => panic!("ray {k} meets the floor"),
        }
    }
    assert!(clear > 450, "{clear} clear");
    // A ray that misses the floor (upward) meets nothing.
    facets.locate_span(
        floor,
        o,
        [&[0.0], &[1.0], &[0.0]],
        &far,
        &mut out,
        &mut scratch,
    );
    assert_eq!(out, [Located::Outside]);
}

#[test]
fn facets_keep_to_one_plane_facing_one_way() {
    // Two triangles sharing an edge at a slight angle, and a pair back to back.
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let mut desc = cube(1);
    desc.polygons.truncate(1);
    let bent = [
        vec![v(0.0, 0.5, 0.0), v(0.0, 0.5, 1.0), v(1.0, 0.5, 1.0)],
        vec![v(0.0, 0.5, 0.0), v(1.0, 0.5, 1.0), v(1.0, 0.51, 0.0)],
    ];
    for (k, t) in bent.into_iter().enumerate() {
        desc.polygons.push(one_patch(format!("bent {k}"), t));
    }
    let scene = Scene::new(desc).unwrap();
    let facets = scene.facets();
    assert_eq!(facets.len(), 3, "a tilt of 0.01 rad is not one plane");
    assert_eq!(
        scene.edge_neighbours().across(1)[2],
        2,
        "yet they share the edge"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Wherever a ray from above meets a tessellated floor, a clear answer is the
    /// triangle that holds the point, and a near one lists it.
    #[test]
    fn located_points_are_in_their_triangle(
        n in 1usize..12,
        ox in -0.5f32..1.5, oy in 0.01f32..2.0, oz in -0.5f32..1.5,
        tx in 0.0f32..1.0, tz in 0.0f32..1.0,
    ) {
        let scene = Scene::new(tessellated_floor(n)).unwrap();
        let facets = scene.facets();
        let floor = facets.facet_of(5);
        let o = Vec3::new(ox, oy, oz);
        let d = (Vec3::new(tx, 0.0, tz) - o).normalize();
        let mut out = Vec::new();
        let mut scratch = LocateScratch::default();
        facets.locate_span(floor, o, [&[d.x], &[d.y], &[d.z]], &[f32::INFINITY], &mut out, &mut scratch);
        let holders: Vec<u32> = (5..scene.polygons().len() as u32)
            .filter(|&p| scene.polygons()[p as usize].intersect(o, d, f32::INFINITY).is_some())
            .collect();
        match out[0] {
            Located::Clear(p, _) => prop_assert_eq!(holders, vec![p]),
            Located::Near => {
                let mut held = Vec::new();
                facets.for_each_holding(floor, o, d, |p| held.push(p));
                prop_assert!(holders.iter().all(|h| held.contains(h)), "{:?} {:?}", holders, held);
            }
            Located::Outside => prop_assert!(holders.is_empty(), "{:?}", holders),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Given a likely polygon (any of the floor's, or another facet's), the polygons
    /// `for_each_holding_at` names are among those it names without one, and every
    /// polygon it drops rejects the ray: the candidates' own tests find the same hits.
    #[test]
    fn a_likely_polygon_drops_only_polygons_that_miss(
        n in 1usize..12,
        ox in -0.5f32..1.5, oy in 0.01f32..2.0, oz in -0.5f32..1.5,
        tx in -0.05f32..1.05, tz in -0.05f32..1.05,
        likely in any::<prop::sample::Index>(),
        pick in 0..3,
        on_edge in any::<bool>(),
    ) {
        // (Aimed at a grid line, the point lies on the edge two triangles share.)
        let tx = if on_edge { (tx * n as f32).round() / n as f32 } else { tx };
        let scene = Scene::new(tessellated_floor(n)).unwrap();
        let facets = scene.facets();
        let floor = facets.facet_of(5);
        let o = Vec3::new(ox, oy, oz);
        let d = (Vec3::new(tx, 0.0, tz) - o).normalize();
        let (nv, dv) = facets.plane(floor);
        let t = (dv - nv.dot(o)) / nv.dot(d);
        let mut all = Vec::new();
        facets.for_each_holding(floor, o, d, |p| all.push(p));
        let mut some = Vec::new();
        // (The polygon the ray hits, as a camera's last ray would suggest, one across
        // its edge, or any.)
        let hit = all.iter().copied().find(|&p| scene.polygons()[p as usize].intersect(o, d, f32::INFINITY).is_some());
        let any = likely.index(scene.polygons().len()) as u32;
        let q = match (hit, pick) {
            (Some(h), 0) => h,
            (Some(h), 1) => {
                let across = scene.edge_neighbours().across(h).to_vec();
                across.into_iter().filter(|&p| p != NO_POLYGON).nth(likely.index(3)).unwrap_or(h)
            }
            _ => any,
        };
        facets.for_each_holding_at(floor, o, d, t, Some(q), |p| some.push(p));
        prop_assert!(some.iter().all(|p| all.contains(p)), "{:?} {:?}", some, all);
        let hits = |ps: &[u32]| -> Vec<u32> {
            ps.iter()
                .copied()
                .filter(|&p| scene.polygons()[p as usize].intersect(o, d, f32::INFINITY).is_some())
                .collect()
        };
        prop_assert_eq!(hits(&some), hits(&all));
    }
}

/// Rays from above onto a tessellated floor, each suggested the triangle it hits: the
/// likely triangle alone is named for most (those well inside it), the same hits found.
#[test]
fn a_likely_polygon_that_holds_the_point_is_named_alone() {
    let scene = Scene::new(tessellated_floor(8)).unwrap();
    let facets = scene.facets();
    let floor = facets.facet_of(5);
    let o = Vec3::new(0.3, 1.2, 0.6);
    let (nv, dv) = facets.plane(floor);
    let mut alone = 0;
    for k in 0..500 {
        let (x, z) = (
            (k as f32 * 0.618_034).fract(),
            (k as f32 * 0.414_214).fract(),
        );
        let d = (Vec3::new(x, 0.0, z) - o).normalize();
        let t = (dv - nv.dot(o)) / nv.dot(d);
        let hit = (5..scene.polygons().len() as u32)
            .find(|&p| {
                scene.polygons()[p as usize]
                    .intersect(o, d, f32::INFINITY)
                    .is_some()
            })
            .unwrap();
        let mut some = Vec::new();
        facets.for_each_holding_at(floor, o, d, t, Some(hit), |p| some.push(p));
        assert!(some.contains(&hit), "ray {k}: {some:?}");
        alone += usize::from(some == [hit]);
    }
    assert!(alone > 400, "{alone} of 500 named alone");
}
