//! `coherad export`: glTF and PLY files that read back as what was written.

use rad_geometry::file::{load, LoadConfig};
use rad_geometry::{scenes, Scene};
use rad_pipeline::export::{auto_scale, export, ExportFormat};
use rad_pipeline::SceneFile;

fn file_of(scene: Scene) -> SceneFile {
    SceneFile::of_scene("scene.json", scene)
}

fn opts() -> LoadConfig {
    LoadConfig {
        patch_size: Some(1e9),
        ..LoadConfig::default()
    }
}

#[test]
fn a_triangle_mesh_round_trips_through_gltf_and_glb_to_the_bit() {
    // The blob room: 20,480 curved triangles and the room's quads, three materials
    // (a lamp among them), a camera.
    let scene = Scene::new(scenes::blob_room()).unwrap();
    let file = file_of(scene.clone());
    let dir = tempfile::tempdir().unwrap();
    for name in ["blob.glb", "blob.gltf"] {
        let path = dir.path().join(name);
        let summary = export(&file, None, None, &path).unwrap();
        assert_eq!(summary.format, ExportFormat::of_path(&path).unwrap());
        let back = Scene::new(load(&path, &opts()).unwrap().desc).unwrap();
        // Materials exactly (extras.coherad), by name.
        for m in scene.materials() {
            let b = back.materials().iter().find(|x| x.name == m.name).unwrap();
            assert_eq!((b.reflectance, b.emission), (m.reflectance, m.emission));
        }
        // Every triangle comes back with its vertices' bits; quads as two triangles of
        // the same area. Meshes are by group, so gather per (material, area).
        let triangles = |s: &Scene| {
            let mut v: Vec<_> = s
                .polygons()
                .iter()
                .filter(|p| p.vertices().len() == 3)
                .map(|p| {
                    let name = &s.materials()[p.material() as usize].name;
                    let bits: Vec<[u32; 3]> = p
                        .vertices()
                        .iter()
                        .map(|v| v.to_array().map(f32::to_bits))
                        .collect();
                    (name.clone(), bits)
                })
                .collect();
            v.sort();
            v
        };
        let quads = scene
            .polygons()
            .iter()
            .filter(|p| p.vertices().len() == 4)
            .count();
        let original = triangles(&scene);
        let read = triangles(&back);
        assert_eq!(read.len(), original.len() + 2 * quads, "{name}");
        assert!(
            original.iter().all(|t| read.binary_search(t).is_ok()),
            "{name}"
        );
        let area = |s: &Scene| s.polygons().iter().map(|p| p.area()).sum::<f64>();
        assert!((area(&back) - area(&scene)).abs() < 1e-9 * area(&scene));
        let (cam, got) = (scene.camera().unwrap(), back.camera().unwrap());
        assert!((cam.position - got.position).length() < 1e-5);
        let dir_of = |c: &rad_pipeline::Camera| (c.look_at - c.position).normalize();
        assert!(
            (dir_of(cam) - dir_of(got)).length() < 1e-5,
            "{cam:?} {got:?}"
        );
        assert!((cam.fov_y - got.fov_y).abs() < 1e-6);
    }
}

/// The glTF JSON and BIN chunks of a GLB file.
fn glb_parts(bytes: &[u8]) -> (serde_json::Value, Vec<u8>) {
    assert_eq!(&bytes[..4], b"glTF");
    let word = |k: usize| u32::from_le_bytes(bytes[k..k + 4].try_into().unwrap()) as usize;
    assert_eq!(word(4), 2);
    assert_eq!(word(8), bytes.len());
    let json_len = word(12);
    assert_eq!(&bytes[16..20], b"JSON");
    let doc = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    (doc, bytes[bin_at + 8..bin_at + 8 + word(bin_at)].to_vec())
}

#[test]
fn baked_colours_are_the_smooth_shading_times_the_exposure() {
    // The cube (6 faces of 10 x 10 patches): radiosity rising with the patch number.
    let scene = Scene::new(scenes::cube(10)).unwrap();
    let n = scene.patches().len();
    let b: Vec<[f64; 3]> = (0..n).map(|k| [k as f64, 0.5 * k as f64, 1.0]).collect();
    let file = file_of(scene.clone());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.glb");
    let ev = -9.0;
    let summary = export(&file, Some(&b), Some(ev), &path).unwrap();
    assert_eq!(summary.scale, Some(2f64.powf(ev)));
    assert_eq!(summary.triangles, 2 * n);
    let (doc, bin) = glb_parts(&std::fs::read(&path).unwrap());
    assert_eq!(doc["extensionsUsed"][0], "KHR_materials_unlit");
    // Read every primitive's colours and positions; the smooth shading at a patch
    // corner on the polygon's boundary is the mean of its patches there, inside the mean
    // of four; check that the colours span what B x 2^EV does, clipped.
    let floats = |acc: usize| -> Vec<[f32; 3]> {
        let a = &doc["accessors"][acc];
        let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let off = v["byteOffset"].as_u64().unwrap() as usize;
        let count = a["count"].as_u64().unwrap() as usize;
        (0..count)
            .map(|i| {
                std::array::from_fn(|c| {
                    let k = off + 12 * i + 4 * c;
                    f32::from_le_bytes(bin[k..k + 4].try_into().unwrap())
                })
            })
            .collect()
    };
    let mut colours = Vec::new();
    for mesh in doc["meshes"].as_array().unwrap() {
        for prim in mesh["primitives"].as_array().unwrap() {
            let attrs = &prim["attributes"];
            let c = floats(attrs["COLOR_0"].as_u64().unwrap() as usize);
            let p = floats(attrs["POSITION"].as_u64().unwrap() as usize);
            assert_eq!(c.len(), p.len());
            colours.extend(c);
        }
    }
    assert_eq!(colours.len(), 4 * n);
    let scale = 2f64.powf(ev);
    for c in &colours {
        assert!(c.iter().all(|v| (0.0..=1.0).contains(v)));
        // Blue is 1 everywhere: scaled exactly; red is twice green, as in B.
        assert_eq!(c[2], scale as f32);
        assert!((c[0] - (2.0 * c[1]).min(1.0)).abs() <= 1e-6, "{c:?}");
    }
    // The brightest corners are clipped at 1, the darkest are patch 0's, 0.
    assert!(colours.iter().any(|c| c[0] == 1.0));
    assert!(colours.iter().any(|c| c[0] == 0.0));
    // And the default exposure maps the 95th percentile of luminance to 0.8.
    let auto = auto_scale(&b);
    let lum = |k: f64| 0.2126 * k + 0.7152 * 0.5 * k + 0.0722;
    let p95 = lum(((n - 1) as f64 * 0.95).floor());
    assert!((auto * p95 - 0.8).abs() < 1e-12, "{auto} {p95}");
}

#[test]
fn ply_export_reads_back_as_the_patches() {
    let scene = Scene::new(scenes::cube(3)).unwrap();
    let n = scene.patches().len();
    let b = vec![[0.25; 3]; n];
    let file = file_of(scene.clone());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cube.ply");
    export(&file, Some(&b), Some(0.0), &path).unwrap();
    let back = Scene::new(load(&path, &opts()).unwrap().desc).unwrap();
    assert_eq!(back.polygons().len(), n);
    for (patch, poly) in scene.patches().iter().zip(back.polygons()) {
        assert_eq!(&patch.corners[..], poly.vertices());
    }
    // The colours are sRGB(0.25) = 137 in every vertex: find them in the file.
    let bytes = std::fs::read(&path).unwrap();
    let header_end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let stride = 6 * 4 + 3;
    for k in 0..4 * n {
        let at = header_end + k * stride + 24;
        assert_eq!(&bytes[at..at + 3], &[137, 137, 137]);
    }
}

#[test]
fn export_refuses_what_it_cannot_write_and_writes_nothing() {
    let file = file_of(Scene::new(scenes::cube(2)).unwrap());
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("cube.obj");
    let e = export(&file, None, None, &bad).unwrap_err().to_string();
    assert!(e.contains(".glb, .gltf or .ply"), "{e}");
    let short = vec![[1.0; 3]; 5];
    let path = dir.path().join("cube.glb");
    let e = export(&file, Some(&short), None, &path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("5 radiosities") && e.contains("24 patches"),
        "{e}"
    );
    let e = export(&file, Some(&vec![[1.0; 3]; 24]), Some(f64::NAN), &path).unwrap_err();
    assert!(e.to_string().contains("exposure"), "{e}");
    assert!(!path.exists() && !bad.exists());
}
