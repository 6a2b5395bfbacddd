//! Bad input gets a typed error naming the file, the polygon and the problem.

use glam::Vec3;
use rad_core::Rgb;
use rad_geometry::file::{load_scene, scene_desc_from_json};
use rad_geometry::{Error, Material, PatchGrid, PolygonDesc, PolygonProblem, Scene, SceneDesc};
use std::io::Write;

fn one(vertices: Vec<Vec3>, grid: PatchGrid) -> SceneDesc {
    SceneDesc {
        materials: vec![Material {
            name: "m".into(),
            reflectance: Rgb([0.5; 3]),
            emission: Rgb::BLACK,
        }],
        polygons: vec![PolygonDesc {
            name: "p".into(),
            vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
            material: 0,
            grid,
            group: None,
            obstruction: false,
            two_sided: false,
        }],
        camera: None,
    }
}

fn square() -> Vec<Vec3> {
    vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
}

fn problem(desc: SceneDesc) -> PolygonProblem {
    match Scene::new(desc) {
        Err(Error::Polygon {
            polygon: 0,
            name,
            problem,
        }) => {
            assert_eq!(name, "p");
            problem
        }
        other => panic!("expected a polygon error, got {other:?}"),
    }
}

const G: PatchGrid = PatchGrid::Cells { nu: 2, nv: 2 };

#[test]
fn non_planar_polygon() {
    let mut v = square();
    v[2].z = 0.01;
    let p = problem(one(v, G));
    assert!(
        matches!(p, PolygonProblem::NonPlanar { deviation, .. } if deviation > 1e-3),
        "{p:?}"
    );
    assert!(p.to_string().contains("not planar"));
}

#[test]
fn planar_within_tolerance_is_accepted() {
    let mut v = square();
    v[2].z = 1e-5;
    assert!(Scene::new(one(v, G)).is_ok());
}

#[test]
fn degenerate_polygons() {
    let collinear = vec![Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0)];
    assert!(matches!(
        problem(one(collinear, G)),
        PolygonProblem::Degenerate { .. }
    ));
    let repeated = vec![Vec3::ZERO, Vec3::X, Vec3::X, Vec3::Y];
    assert!(matches!(
        problem(one(repeated, G)),
        PolygonProblem::Degenerate { .. }
    ));
    let two = vec![Vec3::ZERO, Vec3::X];
    assert!(matches!(
        problem(one(two, G)),
        PolygonProblem::TooFewVertices { count: 2 }
    ));
}

#[test]
fn non_convex_polygon() {
    let dart = vec![
        Vec3::ZERO,
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(1.0, 0.3, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    assert!(matches!(
        problem(one(dart, G)),
        PolygonProblem::NonConvex { vertex: 2 }
    ));
    // Vertices out of order (a bow tie) are not convex either.
    let bow = vec![Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::X, Vec3::Y];
    assert!(matches!(
        problem(one(bow, G)),
        PolygonProblem::NonConvex { .. } | PolygonProblem::Degenerate { .. }
    ));
}

#[test]
fn stars_are_not_convex() {
    // A pentagram: every turn has the same sign, but it winds twice.
    let star: Vec<Vec3> = [0, 2, 4, 1, 3]
        .iter()
        .map(|&k| {
            let a = std::f32::consts::TAU * k as f32 / 5.0;
            Vec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    assert!(matches!(
        problem(one(star, G)),
        PolygonProblem::NonConvex { .. }
    ));
}

#[test]
fn nan_and_infinite_coordinates() {
    let mut v = square();
    v[1].y = f32::NAN;
    assert!(matches!(
        problem(one(v, G)),
        PolygonProblem::NonFinite { vertex: 1, .. }
    ));
    // JSON has no NaN; a number too large for f32 becomes infinite and is caught.
    let json = r#"{"materials":[{"name":"m","reflectance":[0.5,0.5,0.5]}],
        "polygons":[{"name":"p","material":"m","patches":[1,1],"vertices":[[0,0,0],[1e39,0,0],[1,1,0]]}]}"#;
    let desc = scene_desc_from_json(json, None).unwrap();
    assert!(matches!(
        problem(desc),
        PolygonProblem::NonFinite { vertex: 1, .. }
    ));
}

#[test]
fn zero_and_huge_patch_grids() {
    let p = problem(one(square(), PatchGrid::Cells { nu: 0, nv: 3 }));
    assert!(matches!(p, PolygonProblem::ZeroPatchGrid { nu: 0, nv: 3 }));
    let p = problem(one(
        square(),
        PatchGrid::Cells {
            nu: 1 << 20,
            nv: 1 << 20,
        },
    ));
    assert!(matches!(p, PolygonProblem::PatchGridTooLarge { .. }));
    let p = problem(one(square(), PatchGrid::Size(0.0)));
    assert!(matches!(p, PolygonProblem::BadPatchSize { .. }));
}

#[test]
fn a_scene_too_large_for_the_patch_ids_is_refused_before_any_patch_is_made() {
    // Five polygons of 4096 x 4096 patches each (each within the per-polygon limit):
    // 5 x 2^24 patches, over the 2^26 the ids allow. Refused at once, without making
    // the 2^26 patches before the fifth polygon.
    let mut desc = one(square(), PatchGrid::Cells { nu: 4096, nv: 4096 });
    let first = desc.polygons[0].clone();
    for k in 1..5 {
        let mut p = first.clone();
        p.name = format!("p{k}");
        for v in &mut p.vertices {
            v.z = k as f64;
        }
        desc.polygons.push(p);
    }
    let err = Scene::new(desc).expect_err("too many patches");
    assert!(
        matches!(err, Error::TooManyPatches { count, limit } if count == 5 << 24 && limit == rad_geometry::MAX_PATCHES),
        "{err:?}"
    );
    assert!(err.to_string().contains("83886080 patches"), "{err}");
}

#[test]
fn bad_materials() {
    let mut d = one(square(), G);
    d.materials[0].reflectance = Rgb([0.5, 1.0, 0.5]);
    let e = Scene::new(d).unwrap_err();
    assert!(
        matches!(
            &e,
            Error::Material {
                what: "reflectance",
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("[0, 1)"));
    let mut d = one(square(), G);
    d.materials[0].emission = Rgb([-1.0, 0.0, 0.0]);
    assert!(matches!(
        Scene::new(d).unwrap_err(),
        Error::Material {
            what: "emission",
            ..
        }
    ));
    let mut d = one(square(), G);
    d.polygons[0].material = 3;
    assert!(matches!(
        problem(d),
        PolygonProblem::MaterialIndexOutOfRange { index: 3, len: 1 }
    ));
    let json = r#"{"materials":[{"name":"m","reflectance":[0.5,0.5,0.5]}],
        "polygons":[{"name":"p","material":"nope","patches":[1,1],"vertices":[[0,0,0],[1,0,0],[1,1,0]]}]}"#;
    let e = scene_desc_from_json(json, None).unwrap_err();
    assert!(
        matches!(&e, Error::Polygon { problem: PolygonProblem::UnknownMaterial { name }, .. } if name == "nope"),
        "{e}"
    );
}

#[test]
fn vertex_index_out_of_range() {
    let json = r#"{"materials":[{"name":"m","reflectance":[0.5,0.5,0.5]}], "vertices":[[0,0,0],[1,0,0],[1,1,0]],
        "polygons":[{"name":"p","material":"m","patches":[1,1],"indices":[0,1,7]}]}"#;
    let e = scene_desc_from_json(json, None).unwrap_err();
    assert!(
        matches!(
            &e,
            Error::IndexOutOfRange {
                index: 7,
                len: 3,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("polygon 0"));
}

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.path().join(name);
    std::fs::File::create(&path)
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    path
}

#[test]
fn missing_truncated_and_unknown_files() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.json");
    let e = load_scene(&missing, None).unwrap_err();
    assert!(matches!(&e, Error::Io { .. }), "{e}");
    assert!(e.to_string().contains("missing.json"));

    let full = rad_geometry::file::scene_desc_to_json(&rad_geometry::scenes::cube(2), None);
    let cut = write(&dir, "cut.json", &full[..full.len() / 2]);
    let e = load_scene(&cut, None).unwrap_err();
    assert!(matches!(&e, Error::Json { line, .. } if *line > 1), "{e}");
    assert!(e.to_string().contains("cut.json"));

    let e = load_scene(&write(&dir, "scene.txt", "x"), None).unwrap_err();
    assert!(matches!(e, Error::UnknownFormat { .. }));
}

#[test]
fn file_errors_name_the_file_and_the_polygon() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "bad.json",
        r#"{"materials":[{"name":"m","reflectance":[0.5,0.5,0.5]}],
        "polygons":[{"name":"ok","material":"m","patches":[1,1],"vertices":[[0,0,0],[1,0,0],[1,1,0]]},
                    {"name":"warped","material":"m","patches":[1,1],"vertices":[[0,0,0],[1,0,0],[1,1,0.5],[0,1,0]]}]}"#,
    );
    let msg = load_scene(&path, None).unwrap_err().to_string();
    assert!(
        msg.contains("bad.json")
            && msg.contains("polygon 1")
            && msg.contains("warped")
            && msg.contains("not planar"),
        "{msg}"
    );
}

#[test]
fn obj_files() {
    let dir = tempfile::tempdir().unwrap();
    write(&dir, "m.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 10 10 10\n");
    write(&dir, "b.mtl", "newmtl bad\nKd 1.2 0.5 0.5\n");
    let ok = write(
        &dir,
        "ok.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl lamp\nf 1 2 3 4\n",
    );
    let s = load_scene(&ok, Some(0.25)).unwrap();
    assert_eq!(s.polygons().len(), 1);
    assert_eq!(s.patches().len(), 16);
    assert_eq!(s.materials()[0].emission, Rgb([10.0; 3]));
    let e = load_scene(&ok, None).unwrap_err();
    assert!(e.to_string().contains("patch size"), "{e}");
    let bad = write(
        &dir,
        "bad.obj",
        "mtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl bad\nf 1 2 3\n",
    );
    let e = load_scene(&bad, Some(0.5)).unwrap_err();
    assert!(
        e.to_string().contains("bad.obj") && e.to_string().contains("reflectance"),
        "{e}"
    );
    let oob = write(&dir, "oob.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n");
    let e = load_scene(&oob, Some(0.5)).unwrap_err();
    assert!(e.to_string().contains("oob.obj"), "{e}");
}

/// Scenes beyond what the f32 ray tests resolve are refused by polygon, with the limit
/// (the unit cube scaled to 1e30 gave rows 99.9 % "escaped", and to 1e-30 radiosities
/// of 0; from 1e-12 to 1e18 the answers are right and the scene is accepted).
#[test]
fn scenes_outside_the_numeric_range_are_refused() {
    let scaled = |k: f32| {
        let mut d = rad_geometry::scenes::cube(2);
        for p in &mut d.polygons {
            for v in &mut p.vertices {
                *v = (v.as_vec3() * k).as_dvec3();
            }
        }
        Scene::new(d)
    };
    for k in [1e-12f32, 1e-6, 1.0, 1e6, 1e18] {
        assert!(scaled(k).is_ok(), "scale {k:e}");
    }
    let e = scaled(1e30).unwrap_err().to_string();
    assert!(e.contains("polygon 0") && e.contains("beyond 1e18"), "{e}");
    let e = scaled(1e-30).unwrap_err().to_string();
    assert!(
        e.contains("polygon 0") && e.contains("under the 1e-12"),
        "{e}"
    );
    // A millimetre triangle a kilometre out: 1e-6 of its coordinates.
    let mut d = rad_geometry::scenes::cube(2);
    d.polygons.push(rad_geometry::PolygonDesc {
        name: "speck".into(),
        vertices: vec![
            glam::DVec3::new(1000.0, 0.0, 0.0),
            glam::DVec3::new(1000.001, 0.0, 0.0),
            glam::DVec3::new(1000.0, 0.001, 0.0),
        ],
        material: 0,
        grid: rad_geometry::PatchGrid::Cells { nu: 1, nv: 1 },
        group: None,
        obstruction: false,
        two_sided: false,
    });
    let e = Scene::new(d).unwrap_err().to_string();
    assert!(
        e.contains("\"speck\"") && e.contains("f32 ray tests resolve"),
        "{e}"
    );
}

#[test]
fn view3d_text_with_commas_and_non_ascii_words_is_read_not_panicked_on() {
    use rad_geometry::file::vs3_from_text;
    let text = ",Tü façade study, v2\nC encl=1,emit=0\nV 1 0 0 0\nV 2 1 0 0\nV 3 0 1 0\nS 1 1 2 3 0 0 0 0.9 tri\nEnd of data\n";
    let (desc, control) = vs3_from_text(text, None).unwrap();
    assert_eq!(control.title, "façade study, v2");
    assert!(control.encl && !control.emit);
    assert_eq!(desc.polygons.len(), 1);
    assert_eq!(desc.polygons[0].group.as_deref(), Some("tri"));
    // Garbage of every kind: an error with a line, never a panic.
    for bad in [
        "ü",
        ",",
        "S",
        "S 1 1 2 3",
        "V 1 a b c",
        "C =",
        "F",
        "O 1 1 2 3 0\nEnd of data",
    ] {
        assert!(vs3_from_text(bad, None).is_err(), "{bad:?}");
    }
}

#[test]
fn coplanar_overlapping_polygons_facing_the_same_way_are_refused_by_name() {
    use rad_geometry::scenes::cube;
    // A face given twice: the copy would get no light.
    let mut twice = cube(2);
    let mut copy = twice.polygons[0].clone();
    copy.name = "copy of the first".into();
    twice.polygons.push(copy);
    let msg = Scene::new(twice).unwrap_err().to_string();
    assert!(
        msg.contains("polygons 0 (")
            && msg.contains("and 6 (\"copy of the first\")")
            && msg.contains("overlap"),
        "{msg}"
    );
    // A piece inside another, same plane, same facing (z-fighting).
    let mut piece = cube(2);
    let f = piece.polygons[2].clone();
    let c = f.vertices.iter().copied().sum::<glam::DVec3>() / 4.0;
    let mut inner = f.clone();
    inner.name = "patch on the face".into();
    inner.vertices = f.vertices.iter().map(|&v| c + 0.25 * (v - c)).collect();
    piece.polygons.push(inner);
    let msg = Scene::new(piece).unwrap_err().to_string();
    assert!(msg.contains("and 6 (\"patch on the face\")"), "{msg}");
    // The same face reversed (back to back, as a two-sided wall is modelled): allowed;
    // so are coplanar neighbours that share an edge.
    let mut back = cube(2);
    let mut rev = back.polygons[0].clone();
    rev.vertices.reverse();
    back.polygons.push(rev);
    Scene::new(back).unwrap();
    let mut halves = cube(2);
    let f = halves.polygons[0].clone();
    let (a, b, c2, d) = (f.vertices[0], f.vertices[1], f.vertices[2], f.vertices[3]);
    let (m1, m2) = ((a + b) / 2.0, (c2 + d) / 2.0);
    halves.polygons[0].vertices = vec![a, m1, m2, d];
    let mut other = f.clone();
    other.name = "other half".into();
    other.vertices = vec![m1, b, c2, m2];
    halves.polygons.push(other);
    Scene::new(halves).unwrap();
}

#[test]
fn a_two_sided_obstruction_is_refused() {
    let mut desc = one(square(), G);
    desc.polygons[0].obstruction = true;
    desc.polygons[0].two_sided = true;
    let p = problem(desc);
    assert!(matches!(p, PolygonProblem::TwoSidedObstruction), "{p:?}");
    assert!(p.to_string().contains("both two_sided and an obstruction"));
}
