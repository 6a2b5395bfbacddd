//! `--repair`: a mesh's faces turned over at random come back as they were; a closed
//! room faces inward and what stands in it outward; duplicates, folded faces and
//! welded cracks are mended, and a survey says the same as the repair without changing
//! anything.

use glam::DVec3;
use proptest::prelude::*;
use rad_geometry::scenes::blob_room;
use rad_geometry::{repair, survey, PatchGrid, PolygonDesc, Scene, SceneDesc};

/// Turns a face over as the repair does: the first vertex kept, the rest reversed.
fn turn_over(p: &mut PolygonDesc) {
    p.vertices[1..].reverse();
}

/// A flat `n` x `n` grid of unit squares in z = 0, each cut into two triangles facing
/// +z, one open piece.
fn sheet(n: usize) -> SceneDesc {
    let mut desc = blob_room();
    desc.polygons.clear();
    let at = |i: usize, j: usize| DVec3::new(i as f64, j as f64, 0.0);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            for (k, tri) in [[a, b, c], [a, c, d]].into_iter().enumerate() {
                desc.polygons.push(PolygonDesc {
                    name: format!("sheet {i} {j} {k}"),
                    vertices: tri.to_vec(),
                    material: 0,
                    grid: PatchGrid::Cells { nu: 1, nv: 1 },
                    group: None,
                    obstruction: false,
                    two_sided: false,
                });
            }
        }
    }
    desc
}

#[test]
fn a_sound_scene_is_left_as_it_is() {
    let mut desc = blob_room();
    let before = desc.clone();
    let r = repair(&mut desc, None);
    assert_eq!(desc, before, "{r:?}");
    assert!(!r.changes(), "{r:?}");
    // The room, the lamp and the blob: all closed; the room encloses the scene.
    assert_eq!((r.pieces, r.closed, r.enclosures), (3, 3, 1), "{r:?}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// Faces of the room, the lamp and the blob turned over at random: the repair turns
    /// exactly those back, and the scene is the one built, to the bit.
    #[test]
    fn faces_turned_over_at_random_are_turned_back(seed in any::<u64>(), share in 1u64..60) {
        let built = blob_room();
        let mut desc = built.clone();
        let mut state = seed | 1;
        let mut turned = 0;
        for p in &mut desc.polygons {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            if state % 100 < share {
                turn_over(p);
                turned += 1;
            }
        }
        let seen = survey(&desc, None);
        let r = repair(&mut desc, None);
        prop_assert_eq!(&seen, &r);
        prop_assert_eq!(r.flipped, turned);
        prop_assert_eq!(r.dropped(), 0);
        prop_assert!(desc == built);
    }
}

#[test]
fn a_closed_mesh_given_inside_out_is_turned_outward() {
    let mut desc = blob_room();
    let blob = |p: &PolygonDesc| p.name.starts_with("blob");
    let built = desc.clone();
    desc.polygons.retain(blob);
    let alone = desc.clone();
    desc.polygons.iter_mut().for_each(turn_over);
    let r = repair(&mut desc, None);
    assert_eq!(r.flipped, alone.polygons.len());
    assert_eq!((r.pieces, r.closed, r.enclosures), (1, 1, 0));
    assert_eq!(desc, alone);
    // And with the room about it, the room turned outward is turned back in.
    let mut desc = built.clone();
    desc.polygons
        .iter_mut()
        .filter(|p| p.name.starts_with("room"))
        .for_each(turn_over);
    let r = repair(&mut desc, None);
    assert_eq!((r.flipped, r.enclosures), (6, 1));
    assert_eq!(desc, built);
}

#[test]
fn an_open_sheet_faces_the_way_most_of_it_does() {
    let built = sheet(4);
    let mut desc = built.clone();
    for k in [3, 8, 13] {
        turn_over(&mut desc.polygons[k]);
    }
    let r = repair(&mut desc, None);
    assert_eq!((r.flipped, r.pieces, r.closed), (3, 1, 0));
    assert_eq!(desc, built);
    assert_eq!(r.examples[0], "\"sheet 0 1 1\" turned over");
}

#[test]
fn duplicates_are_dropped_whichever_way_they_turn() {
    let built = sheet(3);
    let mut desc = built.clone();
    let mut twin = desc.polygons[4].clone();
    twin.name = "twin".into();
    desc.polygons.push(twin.clone());
    turn_over(&mut twin);
    twin.name = "reversed twin".into();
    desc.polygons.push(twin);
    let r = repair(&mut desc, None);
    assert_eq!((r.duplicates, r.flipped), (2, 0), "{r:?}");
    assert_eq!(desc, built);
    // The first in the file is kept.
    assert_eq!(
        r.examples,
        [
            "\"twin\" dropped: a duplicate of \"sheet 0 2 0\"",
            "\"reversed twin\" dropped: a duplicate of \"sheet 0 2 0\""
        ]
    );
}

/// A triangle of the sheet folded over its diagonal onto its neighbour, wound either
/// way: the scene refuses the one that faces the same way by naming `--repair`, and
/// the repair drops the folded triangle and nothing else.
#[test]
fn a_triangle_folded_onto_its_neighbour_is_dropped() {
    for same_way in [false, true] {
        let built = sheet(3);
        let mut desc = built.clone();
        // Faces 8 and 9 are (a, b, c) and (a, c, d) of square (1, 1), joined across
        // a-c. Fold (a, c, d) onto (a, b, c): d goes inside it.
        let folded = 9;
        let [a, c] = [
            desc.polygons[folded].vertices[0],
            desc.polygons[folded].vertices[1],
        ];
        let inside = DVec3::new(1.7, 1.2, 0.0);
        desc.polygons[folded].vertices = if same_way {
            vec![a, inside, c]
        } else {
            vec![a, c, inside]
        };
        if same_way {
            let e = Scene::new(desc.clone()).unwrap_err().to_string();
            assert!(e.contains("--repair"), "{e}");
        }
        let r = repair(&mut desc, None);
        assert_eq!((r.folded, r.dropped()), (1, 1), "{r:?}");
        let mut expected = built.clone();
        expected.polygons.remove(folded);
        assert_eq!(desc, expected, "{r:?}");
        Scene::new(desc).unwrap();
    }
}

#[test]
fn near_vertices_are_welded_and_join_their_pieces() {
    let built = sheet(2);
    let mut desc = built.clone();
    // Two triangles whose shared corners are 1e-9 apart (as unindexed files give
    // them), one of them turned over: two pieces until welded.
    desc.polygons[6].vertices[0] += DVec3::new(1e-9, 0.0, 0.0);
    turn_over(&mut desc.polygons[6]);
    let unwelded = survey(&desc, Some(0.0));
    assert_eq!((unwelded.welded, unwelded.flipped), (0, 0), "{unwelded:?}");
    let r = repair(&mut desc, None);
    assert_eq!((r.welded, r.flipped, r.pieces), (1, 1, 1), "{r:?}");
    assert_eq!(desc, built);
}

#[test]
fn welding_that_collapses_a_face_drops_it() {
    let mut desc = sheet(1);
    desc.polygons.push(PolygonDesc {
        name: "sliver".into(),
        vertices: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 1e-8, 0.0),
        ],
        ..desc.polygons[0].clone()
    });
    let r = repair(&mut desc, Some(1e-6));
    assert_eq!(r.collapsed, 1, "{r:?}");
    assert_eq!(desc.polygons.len(), 2);
}
