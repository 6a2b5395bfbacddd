//! Surface-to-surface view factors against closed forms (Howell's catalogue) at the
//! default settings and with more origins a patch; the enclosure rules; the formats.

use glam::Vec3;
use rad_core::Rgb;
use rad_geometry::{Material, PatchGrid, PolygonDesc, Scene, SceneDesc};
use rad_pipeline::viewfactors::{
    view_factors, write_view_factors, Grouping, MatrixFormat, ViewFactorConfig, ViewFactorMethod,
    ViewFactorRun, ViewFactors, DEFAULT_ORIGINS,
};
use rad_pipeline::{Enclosure, Hemisphere, HemisphereConfig};
use rad_repro::closed_form::{
    obstructed_parallel_squares, parallel_rectangles, unit_cube_face_factor,
};

fn white() -> Vec<Material> {
    vec![Material {
        name: "white".into(),
        reflectance: Rgb([0.5; 3]),
        emission: Rgb::BLACK,
    }]
}

fn poly(name: &str, vertices: Vec<Vec3>, grid: PatchGrid, group: Option<&str>) -> PolygonDesc {
    PolygonDesc {
        name: name.into(),
        vertices: vertices.iter().map(|v| v.as_dvec3()).collect(),
        material: 0,
        grid,
        group: group.map(str::to_string),
        obstruction: false,
        two_sided: false,
    }
}

fn square(z: f32, up: bool) -> Vec<Vec3> {
    let mut v = vec![
        Vec3::new(0.0, 0.0, z),
        Vec3::new(1.0, 0.0, z),
        Vec3::new(1.0, 1.0, z),
        Vec3::new(0.0, 1.0, z),
    ];
    if !up {
        v.reverse();
    }
    v
}

fn scene(polygons: Vec<PolygonDesc>) -> Scene {
    Scene::new(SceneDesc {
        materials: white(),
        polygons,
        camera: None,
    })
    .unwrap()
}

const GRID: PatchGrid = PatchGrid::Cells { nu: 10, nv: 10 };

fn parallel() -> Scene {
    scene(vec![
        poly("bottom", square(0.0, true), GRID, None),
        poly("top", square(1.0, false), GRID, None),
    ])
}

fn hemi() -> Hemisphere {
    Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap()
}

/// Every factor from hemispheres.
fn run(scene: &Scene, origins: u32, enclosure: Enclosure, by: Grouping) -> ViewFactors {
    let opts = ViewFactorConfig {
        by,
        origins,
        enclosure,
        method: ViewFactorMethod::Hemisphere,
        ..ViewFactorConfig::for_scene(scene)
    };
    view_factors(scene, &hemi(), &opts, &|_| {}).unwrap()
}

/// By `method` (auto or exact), by polygon, raw.
fn by_method(scene: &Scene, method: ViewFactorMethod) -> Result<ViewFactors, String> {
    let opts = ViewFactorConfig {
        method,
        ..ViewFactorConfig::for_scene(scene)
    };
    view_factors(scene, &hemi(), &opts, &|_| {}).map_err(|e| e.to_string())
}

#[test]
fn auto_puts_the_unobstructed_closed_forms_within_1e9() {
    for case in rad_repro::viewfactors::closed_form_cases() {
        let scene = Scene::new(case.scene).unwrap();
        let vf = by_method(&scene, ViewFactorMethod::Auto).unwrap();
        let got = vf.matrix.get(case.from, case.to);
        let err = ((got - case.reference).abs() - case.slack).max(0.0);
        let name = case.name;
        if name.contains("between them") {
            // The plate between: that pair from hemispheres, as by hemispheres alone.
            assert!(
                vf.hemisphere_pairs >= 1 && err < 1e-3,
                "{name}: {got} ({vf:?})"
            );
            let e = by_method(&scene, ViewFactorMethod::Exact).unwrap_err();
            assert!(e.contains("\"bottom\" and \"top\" (\"obstruction\""), "{e}");
        } else {
            assert_eq!((vf.exact_pairs, vf.hemisphere_pairs), (1, 0), "{name}");
            // (The 96-gons' reference is a range between two discs' closed forms, which
            // the polygons' own factor need not fall in to more than 1e-6.)
            let within = if name.contains("96-gons") { 1e-6 } else { 1e-9 };
            assert!(err < within, "{name}: {got} against {}", case.reference);
            // Reciprocal as computed: the one integral serves both ways.
            let (a, b) = (vf.matrix.area[0], vf.matrix.area[1]);
            assert!((a * got - b * vf.matrix.get(case.to, case.from)).abs() < 1e-15 * a);
        }
    }
}

#[test]
fn auto_closes_the_cube_without_a_hemisphere() {
    let scene = Scene::new(rad_geometry::scenes::cube(10)).unwrap();
    let vf = by_method(&scene, ViewFactorMethod::Exact).unwrap();
    assert_eq!((vf.exact_pairs, vf.hemisphere_pairs), (15, 0));
    for i in 0..6 {
        let sum: f64 = vf.matrix.rows[i].iter().map(|e| e.1).sum();
        assert!((sum - 1.0).abs() < 1e-9, "row {i}: {sum}");
        assert!(vf.escaped[i] < 1e-9, "row {i}: {}", vf.escaped[i]);
        for j in 0..6 {
            let want = unit_cube_face_factor(&scene, i, j);
            assert!((vf.matrix.get(i, j) - want).abs() < 1e-9, "{i} {j}");
        }
    }
}

#[test]
fn exact_by_patch_is_refused_by_name() {
    let opts = ViewFactorConfig {
        method: ViewFactorMethod::Exact,
        by: Grouping::Patch,
        ..ViewFactorConfig::for_scene(&parallel())
    };
    let e = view_factors(&parallel(), &hemi(), &opts, &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("--by polygon or group"), "{e}");
}

#[test]
fn closed_forms_within_1e3_at_the_defaults_and_closer_with_more_origins() {
    for case in rad_repro::viewfactors::closed_form_cases() {
        let scene = Scene::new(case.scene).unwrap();
        let mut errors = Vec::new();
        for origins in [1, DEFAULT_ORIGINS, 4] {
            let vf = run(&scene, origins, Enclosure::Raw, Grouping::Polygon);
            let got = vf.matrix.get(case.from, case.to);
            let err = ((got - case.reference).abs() - case.slack).max(0.0);
            errors.push((origins, got, err));
        }
        let name = case.name;
        let at_default = errors.iter().find(|e| e.0 == DEFAULT_ORIGINS).unwrap();
        assert!(
            at_default.2 < 1e-3,
            "{name}: {errors:?} against {}",
            case.reference
        );
        // More origins, smaller error (the point-to-area error falls; what is left is
        // the hemisphere's).
        let (one, four) = (errors[0].2, errors[2].2);
        assert!(four <= one, "{name}: {errors:?} against {}", case.reference);
    }
    // The obstructed pair's reference is half the unobstructed one, by symmetry.
    assert!((obstructed_parallel_squares(0.5) - 0.5 * parallel_rectangles(1.0, 1.0)).abs() < 1e-9);
}

#[test]
fn the_unit_cubes_face_factors() {
    let scene = Scene::new(rad_geometry::scenes::cube(10)).unwrap();
    let vf = run(&scene, DEFAULT_ORIGINS, Enclosure::Raw, Grouping::Polygon);
    for i in 0..6 {
        for j in 0..6 {
            let f = vf.matrix.get(i, j);
            let want = unit_cube_face_factor(&scene, i, j);
            assert!(
                (f - want).abs() < 1e-3,
                "F_{i}{j} = {f}, closed form {want}"
            );
        }
        assert!((vf.matrix.row_sum(i) - 1.0).abs() < 1e-9);
    }
}

#[test]
fn closed_enclosures_are_exactly_reciprocal_and_closed() {
    // The cube by polygon and by patch (600 surfaces), and groups of faces.
    let desc = rad_geometry::scenes::cube(10);
    let mut grouped = desc.clone();
    for (k, p) in grouped.polygons.iter_mut().enumerate() {
        p.group = Some(if k < 3 { "first" } else { "second" }.into());
    }
    let scenes = [Scene::new(desc).unwrap(), Scene::new(grouped).unwrap()];
    for (scene, by) in [
        (&scenes[0], Grouping::Polygon),
        (&scenes[0], Grouping::Patch),
        (&scenes[1], Grouping::Group),
    ] {
        let raw = run(scene, 1, Enclosure::Raw, by);
        if by == Grouping::Patch {
            // Point-to-area rows: reciprocal only to their discretisation error (by
            // polygon the cube's symmetry makes them reciprocal already).
            assert!(
                raw.report.raw.reciprocity.max > 1e-4,
                "{:?}",
                raw.report.raw
            );
        }
        for rule in [Enclosure::Reciprocal, Enclosure::Closed] {
            let vf = run(scene, 1, rule, by);
            let m = &vf.matrix;
            for i in 0..m.n() {
                if rule == Enclosure::Closed {
                    assert!(
                        (m.row_sum(i) - 1.0).abs() < 1e-9,
                        "{by:?} row {i}: {}",
                        m.row_sum(i)
                    );
                } else {
                    let raw_sum = raw.matrix.row_sum(i);
                    assert!((m.row_sum(i) - raw_sum).abs() < 1e-9 * raw_sum.max(1e-300));
                }
                for &(j, f) in &m.rows[i] {
                    let (a, b) = (m.area[i] * f, m.area[j as usize] * m.get(j as usize, i));
                    assert!(
                        (a - b).abs() <= 1e-9 * a.max(b),
                        "{by:?} ({i}, {j}): {a} vs {b}"
                    );
                }
            }
            assert!(vf.report.fixed.reciprocity.max <= 1e-9);
            assert!(vf.report.max_change > 0.0 && vf.report.max_change < 1e-2);
        }
    }
    // Groups: the faces of one group see each other (F_II > 0) and the rows still add up.
    let vf = run(&scenes[1], 1, Enclosure::Raw, Grouping::Group);
    assert_eq!(vf.names, ["first", "second"]);
    assert!(vf.matrix.get(0, 0) > 0.1);
}

#[test]
fn closed_refuses_an_open_scene_naming_the_rows_that_leak() {
    let opts = ViewFactorConfig {
        enclosure: Enclosure::Closed,
        origins: 1,
        ..ViewFactorConfig::for_scene(&parallel())
    };
    let err = view_factors(&parallel(), &hemi(), &opts, &|_| {})
        .unwrap_err()
        .to_string();
    // (Each row in closed form: the parallel squares' 0.19982489569838...)
    assert!(
        err.contains("2 rows leak") && err.contains("(0, 0.1998248956983"),
        "{err}"
    );
}

#[test]
fn by_group_without_a_group_is_an_error_naming_the_polygon() {
    let s = scene(vec![
        poly("bottom", square(0.0, true), GRID, Some("floor")),
        poly("top", square(1.0, false), GRID, None),
    ]);
    let opts = ViewFactorConfig {
        by: Grouping::Group,
        ..ViewFactorConfig::for_scene(&s)
    };
    let err = view_factors(&s, &hemi(), &opts, &|_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("polygon 1 (\"top\") belongs to no group"),
        "{err}"
    );
    let opts = ViewFactorConfig {
        origins: 0,
        method: ViewFactorMethod::Hemisphere,
        ..ViewFactorConfig::for_scene(&s)
    };
    let err = view_factors(&s, &hemi(), &opts, &|_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("0 origins"), "{err}");
}

#[test]
fn one_origin_is_the_hemisphere_rows_and_threads_change_nothing() {
    let scene = Scene::new(rad_geometry::scenes::cube(10)).unwrap();
    let vf = run(&scene, 1, Enclosure::Raw, Grouping::Patch);
    let rows = rad_pipeline::rows(
        &scene,
        &hemi(),
        rad_pipeline::RowMethod::Exact {
            caster: rad_pipeline::CasterKind::Scan,
        },
        &(0..scene.patches().len() as u32).collect::<Vec<_>>(),
        &|_| {},
    )
    .unwrap();
    for (i, r) in rows.rows.iter().enumerate() {
        let mine: Vec<(u32, f64)> = vf.matrix.rows[i].clone();
        assert_eq!(mine, r.entries, "row {i}");
    }
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for by in [Grouping::Polygon, Grouping::Patch] {
        let a = run(&scene, 2, Enclosure::Closed, by);
        let b = one.install(|| run(&scene, 2, Enclosure::Closed, by));
        assert_eq!(a.matrix, b.matrix, "{by:?}");
    }
}

/// The Matrix Market file of a run, read back by a small reader of the format.
fn read_mtx(text: &str) -> (usize, Vec<(usize, usize, f64)>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('%'));
    let size: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let entries: Vec<(usize, usize, f64)> = lines
        .map(|l| {
            let t: Vec<&str> = l.split_whitespace().collect();
            (
                t[0].parse().unwrap(),
                t[1].parse().unwrap(),
                t[2].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(size[2], entries.len());
    (size[0], entries)
}

/// The cube's face factors, closed, at the defaults, and run facts to write them with.
fn closed_cube() -> (ViewFactors, ViewFactorRun) {
    let scene = Scene::new(rad_geometry::scenes::cube(10)).unwrap();
    let vf = run(
        &scene,
        DEFAULT_ORIGINS,
        Enclosure::Closed,
        Grouping::Polygon,
    );
    let info = ViewFactorRun {
        scene: "cube".into(),
        scene_hash: "0".into(),
        resolution: (180, 720),
    };
    (vf, info)
}

#[test]
fn json_csv_and_matrix_market_agree_to_the_bit() {
    let (vf, info) = closed_cube();
    let write = |format| {
        let mut out = Vec::new();
        write_view_factors(&mut out, &vf, &info, format).unwrap();
        String::from_utf8(out).unwrap()
    };
    assert!(text_starts(
        &write(MatrixFormat::Mtx),
        "%%MatrixMarket matrix coordinate real general"
    ));
    let (n, entries) = read_mtx(&write(MatrixFormat::Mtx));
    assert_eq!(n, 6);
    for (i, j, f) in &entries {
        assert_eq!(*f, vf.matrix.get(i - 1, j - 1));
    }
    assert_eq!(
        entries.len(),
        vf.matrix.rows.iter().map(Vec::len).sum::<usize>()
    );
    // JSON read as text, parsed by Rust's exact float parser (serde_json's default
    // parser may be an ulp off; Python's json and numpy read these numbers exactly).
    let json = write(MatrixFormat::Json);
    let parsed: serde_json::Value = serde_json::from_str(&json).unwrap();
    let csv = write(MatrixFormat::Csv);
    let mut csv_lines = csv.lines();
    let header: Vec<&str> = csv_lines.next().unwrap().split(',').collect();
    assert_eq!(
        header[1..],
        vf.names.iter().map(String::as_str).collect::<Vec<_>>()[..]
    );
    for (i, line) in csv_lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells[0], vf.names[i]);
        assert_eq!(parsed["surfaces"][i]["name"], vf.names[i].as_str());
        let json_line = json
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{{\"id\": {i},")))
            .unwrap();
        let factors = &json_line[json_line.find("\"factors\": [").unwrap() + 12..];
        let pairs: Vec<(usize, f64)> = factors
            .trim_end_matches(['}', ',', ']'])
            .split("], [")
            .map(|p| {
                let p = p.trim_matches(['[', ']']);
                let (j, v) = p.split_once(", ").unwrap();
                (j.parse().unwrap(), v.parse().unwrap())
            })
            .collect();
        for j in 0..6 {
            let from_csv: f64 = cells[j + 1].parse().unwrap();
            let from_json = pairs.iter().find(|e| e.0 == j).map_or(0.0, |e| e.1);
            assert_eq!(from_csv, vf.matrix.get(i, j));
            assert_eq!(from_json, from_csv, "({i}, {j})");
        }
    }
}

#[test]
fn view3d_output_is_view3ds_text_format() {
    let (vf, info) = closed_cube();
    let mut out = Vec::new();
    write_view_factors(&mut out, &vf, &info, MatrixFormat::View3d).unwrap();
    let text = String::from_utf8(out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // Header (30 characters: program, version, format 0, encl 1, didemit 0, 6
    // surfaces), areas, six rows, emissivities.
    assert_eq!(lines.len(), 1 + 1 + 6 + 1);
    assert_eq!(lines[0].len(), 30);
    let head: Vec<&str> = lines[0].split_whitespace().collect();
    assert_eq!(
        (head[0], head[2], head[3], head[4], head[5]),
        ("coherad", "0", "1", "0", "6")
    );
    let areas: Vec<f64> = lines[1].split(' ').map(|t| t.parse().unwrap()).collect();
    assert_eq!(areas, [1.0; 6]);
    for i in 0..6 {
        let row: Vec<f64> = lines[2 + i]
            .split(' ')
            .map(|t| t.parse().unwrap())
            .collect();
        assert_eq!(row.len(), 6);
        for (j, f) in row.iter().enumerate() {
            assert!((f - vf.matrix.get(i, j)).abs() <= 5e-7, "({i}, {j})");
        }
    }
    // Grey emissivity, 1 − the cube's reflectance of 0.7.
    assert_eq!(lines[8], ["0.300"; 6].join(" "));
}

fn text_starts(text: &str, prefix: &str) -> bool {
    text.starts_with(prefix)
}

#[test]
fn the_binary_file_streams_round_trips_and_refuses_truncation() {
    use rad_pipeline::matrix_file::read_matrix_file;
    use rad_pipeline::viewfactors::stream_patch_matrix;
    let scene = Scene::new(rad_geometry::scenes::cube(4)).unwrap();
    let info = ViewFactorRun {
        scene: "cube".into(),
        scene_hash: "0".into(),
        resolution: (180, 720),
    };
    let opts = ViewFactorConfig {
        by: Grouping::Patch,
        origins: 2,
        ..ViewFactorConfig::for_scene(&scene)
    };
    // Streamed as made, and written from the held matrix: the same bytes.
    let mut streamed = Vec::new();
    let done = stream_patch_matrix(&scene, &hemi(), &opts, &info, &mut streamed, &|_| {}).unwrap();
    let vf = view_factors(&scene, &hemi(), &opts, &|_| {}).unwrap();
    let mut held = Vec::new();
    write_view_factors(&mut held, &vf, &info, MatrixFormat::Bin).unwrap();
    assert_eq!(streamed, held);
    assert_eq!(
        done.entries as usize,
        vf.matrix.rows.iter().map(Vec::len).sum::<usize>()
    );
    let path = std::path::Path::new("cube.bin");
    let back = read_matrix_file(&streamed, path).unwrap();
    assert_eq!(back.areas, vf.matrix.area);
    assert_eq!(back.metadata["names"][5], "patch 5");
    assert_eq!(back.metadata["by"], "patch");
    let mut k = 0;
    for (i, row) in vf.matrix.rows.iter().enumerate() {
        for &(j, f) in row {
            assert_eq!(back.entries[k], (i as u32, j, f));
            k += 1;
        }
    }
    assert_eq!(k, back.entries.len());
    // Truncated anywhere, or not ours: refused, naming the file.
    for cut in [
        streamed.len() - 1,
        streamed.len() - 16,
        streamed.len() / 2,
        30,
    ] {
        let err = read_matrix_file(&streamed[..cut], path)
            .unwrap_err()
            .to_string();
        assert!(err.contains("cube.bin"), "{err}");
    }
    let err = read_matrix_file(b"not a matrix file at all, longer than the header", path)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not a coherad matrix file"), "{err}");
}

/// A `.vs3` file in a temporary directory, loaded as the CLI loads it.
fn vs3(text: &str) -> Result<rad_pipeline::SceneFile, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("case.vs3");
    std::fs::write(&path, text).unwrap();
    rad_pipeline::SceneFile::load(&path, None).map_err(|e| e.to_string())
}

const PARALLEL_VS3: &str = "T  two parallel unit squares 1 apart (View3D's ParallelPlanes)
C  list=1 row=0 col=0
F  3
!   #   x     y     z
V   1   0.00  0.00  0.00
V   2   1.00  0.00  0.00
V   3   1.00  1.00  0.00
V   4   0.00  1.00  0.00
V   5   0.00  0.00  1.00
V   6   1.00  0.00  1.00
V   7   1.00  1.00  1.00
V   8   0.00  1.00  1.00
!   #   v1  v2  v3  v4 base cmb emit  name
S   1    1   2   3   4   0   0  0.90  bottom
S   2    8   7   6   5   0   0  0.90  top
End of data
";

fn vs3_options(file: &rad_pipeline::SceneFile) -> ViewFactorConfig {
    let c = file.view3d.as_ref().unwrap();
    ViewFactorConfig {
        by: Grouping::Group,
        enclosure: if c.encl {
            Enclosure::Closed
        } else {
            Enclosure::Raw
        },
        script_f: c.emit,
        ..ViewFactorConfig::for_scene(&file.scene)
    }
}

#[test]
fn view3d_files_parallel_plates() {
    let file = vs3(PARALLEL_VS3).unwrap();
    let c = file.view3d.as_ref().unwrap();
    assert_eq!(
        c.title,
        "two parallel unit squares 1 apart (View3D's ParallelPlanes)"
    );
    assert_eq!(c.ignored, ["list=1", "row=0", "col=0"]);
    let vf = view_factors(&file.scene, &hemi(), &vs3_options(&file), &|_| {}).unwrap();
    assert_eq!(vf.names, ["bottom", "top"]);
    let f = vf.matrix.get(0, 1);
    assert!((f - parallel_rectangles(1.0, 1.0)).abs() < 1e-3, "{f}");
    assert!((vf.emissivity[0] - 0.9).abs() < 1e-12);
}

/// The unit cube as View3D surfaces: its top in two halves combined into one (cmb), a
/// small obstruction plate floating inside (O), encl=1 and emit=1.
const CUBE_VS3: &str = "T cube with a split top, an obstruction and encl=1
C encl=1 emit=1 eps=1e-4
F 3
V 1 0 0 0
V 2 1 0 0
V 3 1 1 0
V 4 0 1 0
V 5 0 0 1
V 6 1 0 1
V 7 1 1 1
V 8 0 1 1
V 9 0.5 0 1
V 10 0.5 1 1
V 11 0.4 0.4 0.5
V 12 0.6 0.4 0.5
V 13 0.6 0.6 0.5
V 14 0.4 0.6 0.5
S 1 1 2 3 4 0 0 0.9 floor
S 2 1 5 6 2 0 0 0.8 south
S 3 2 6 7 3 0 0 0.7 east
S 4 3 7 8 4 0 0 0.6 north
S 5 4 8 5 1 0 0 0.5 west
S 6 5 8 10 9 0 0 0.4 roof
S 7 9 10 7 6 0 6 0.4 roof_b
O 8 11 14 13 12
End of data
";

#[test]
fn view3d_files_with_combining_obstructions_and_an_enclosure() {
    let file = vs3(CUBE_VS3).unwrap();
    let c = file.view3d.as_ref().unwrap();
    assert!(c.encl && c.emit);
    let mut opts = vs3_options(&file);
    opts.script_f = false;
    let vf = view_factors(&file.scene, &hemi(), &opts, &|_| {}).unwrap();
    // Six surfaces: the two roof halves are one, the obstruction none.
    assert_eq!(
        vf.names,
        ["floor", "south", "east", "north", "west", "roof"]
    );
    assert!((vf.matrix.area[5] - 1.0).abs() < 1e-9);
    let m = &vf.matrix;
    for i in 0..6 {
        assert!(
            (m.row_sum(i) - 1.0).abs() < 1e-9,
            "row {i}: {}",
            m.row_sum(i)
        );
        for &(j, f) in &m.rows[i] {
            let (a, b) = (m.area[i] * f, m.area[j as usize] * m.get(j as usize, i));
            assert!((a - b).abs() <= 1e-9 * a.max(b));
        }
    }
    // The floor sees the obstruction's 0.04 m² plate from below: less of the roof
    // than the unobstructed 0.19982 before closing...
    assert!(vf.obstructed[0] > 0.01, "{}", vf.obstructed[0]);
    assert!(vf.report.raw.row_sum.max > 0.01);
    // ...and script-F (emit=1): rows sum to the emissivities, A 𝓕 symmetric.
    let sf = view_factors(&file.scene, &hemi(), &vs3_options(&file), &|_| {}).unwrap();
    assert!(sf.script_f);
    let e = [0.9, 0.8, 0.7, 0.6, 0.5, 0.4];
    for i in 0..6 {
        assert!(
            (sf.matrix.row_sum(i) - e[i]).abs() < 1e-9,
            "row {i}: {}",
            sf.matrix.row_sum(i)
        );
        for j in 0..6 {
            let (a, b) = (sf.matrix.get(i, j), sf.matrix.get(j, i));
            assert!((a - b).abs() < 1e-9, "({i}, {j})");
        }
    }
}

#[test]
fn bad_view3d_files_are_refused_by_line() {
    let lines: Vec<&str> = PARALLEL_VS3.lines().collect();
    let with = |k: usize, new: &str| {
        let mut l = lines.clone();
        l[k] = new;
        l.join("\n") + "\n"
    };
    let cases = [
        (
            with(14, "S   2    8   7   6   9   0   0  0.90  top"),
            "case.vs3:15: vertex 9 is out of range",
        ),
        (
            with(14, "Q   2    8   7   6   5   0   0  0.90  top"),
            "case.vs3:15: unknown record \"Q\"",
        ),
        (with(15, "! no end"), "no \"End of data\""),
        (
            with(14, "S   2    8   7   6   5   1   0  0.90  top"),
            "subsurfaces are not supported",
        ),
        (
            with(1, "C  encl=1 speed=3"),
            "case.vs3:2: unknown control option \"speed\"",
        ),
        (
            with(9, "V   6   1.00  0.00  1.30"),
            "top (surface 2, line 15)\") is not planar",
        ),
        (
            with(9, "V   6   0.40  0.60  1.00"),
            "top (surface 2, line 15)\") is not convex",
        ),
        (with(6, "V   4   0.00  1.00"), "case.vs3:7: too few fields"),
        (
            with(6, "V   5   0.00  1.00  0.00"),
            "case.vs3:7: vertex 5 out of sequence",
        ),
    ];
    for (text, says) in cases {
        let err = vs3(&text).map(|_| ()).unwrap_err();
        assert!(err.contains(says), "{err}\n  wanted: {says}");
    }
}

/// A two-sided plate between two plates: each side sees the plate it faces (the closed
/// form of parallel squares) and nothing else, no ray meets a back, and the side facing
/// the bottom is what a one-sided plate would be, to the bit; one-sided, the top sees
/// the plate's back instead.
#[test]
fn a_two_sided_plate_is_seen_from_both_sides() {
    let plates = |two_sided: bool| {
        let panel = PolygonDesc {
            two_sided,
            ..poly("panel", square(1.0, false), GRID, None)
        };
        scene(vec![
            poly("bottom", square(0.0, true), GRID, None),
            panel,
            poly("top", square(2.0, false), GRID, None),
        ])
    };
    let (two, one) = (plates(true), plates(false));
    assert_eq!(two.polygons().len(), 4);
    assert_eq!(two.polygons()[3].name(), "panel:back");
    assert!(two.polygons()[3].normal().dot(two.polygons()[1].normal()) < -0.999);
    let vf = run(&two, DEFAULT_ORIGINS, Enclosure::Raw, Grouping::Polygon);
    assert_eq!(vf.names[3], "panel:back");
    let c = parallel_rectangles(1.0, 1.0);
    // bottom 0, panel 1, top 2, panel:back 3.
    for (i, j) in [(0, 1), (1, 0), (2, 3), (3, 2)] {
        let f = vf.matrix.get(i, j);
        assert!((f - c).abs() < 1e-3, "F_{i}{j} = {f}, closed form {c}");
    }
    for i in 0..4 {
        for j in 0..4 {
            if ![(0, 1), (1, 0), (2, 3), (3, 2)].contains(&(i, j)) {
                assert_eq!(vf.matrix.get(i, j), 0.0, "F_{i}{j}");
            }
        }
        assert_eq!(vf.back[i], 0.0, "surface {i} meets a back");
    }
    let vf1 = run(&one, DEFAULT_ORIGINS, Enclosure::Raw, Grouping::Polygon);
    for (i, j) in [(0, 1), (1, 0)] {
        assert_eq!(vf.matrix.get(i, j), vf1.matrix.get(i, j));
    }
    assert!((vf1.back[2] - c).abs() < 1e-3, "{}", vf1.back[2]);
    assert_eq!(vf1.matrix.get(2, 1), 0.0);
}
