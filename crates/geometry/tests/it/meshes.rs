//! Mesh formats: the same irregular mesh as PLY (ASCII, both binary orders), STL
//! (ASCII, binary) and OBJ gives the same polygons and patches to the bit; glTF with
//! transforms, materials and a camera; the material side file; `--triangulate`; and
//! clear errors for truncated or malformed files.

use glam::Vec3;
use rad_geometry::file::{load, LoadConfig};
use rad_geometry::scenes::blob_room;
use rad_geometry::Scene;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The first 3,000 triangles of the blob (curved, irregular, areas varying fourfold).
fn blob_triangles() -> Vec<[Vec3; 3]> {
    let desc = blob_room();
    let clay = desc
        .materials
        .iter()
        .position(|m| m.name == "clay")
        .unwrap();
    desc.polygons
        .iter()
        .filter(|p| p.material == clay)
        .take(3000)
        .map(|p| [0, 1, 2].map(|k| p.vertices[k].as_vec3()))
        .collect()
}

/// Shared vertices (first appearance order) and faces of index triples.
fn indexed(tris: &[[Vec3; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut index = std::collections::HashMap::new();
    let faces = tris
        .iter()
        .map(|t| {
            t.map(|v| {
                *index
                    .entry(v.to_array().map(f32::to_bits))
                    .or_insert_with(|| {
                        vertices.push(v);
                        vertices.len() as u32 - 1
                    })
            })
        })
        .collect();
    (vertices, faces)
}

pub(crate) fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn ply_bytes(tris: &[[Vec3; 3]], format: &str) -> Vec<u8> {
    let (v, f) = indexed(tris);
    let mut out = Vec::new();
    write!(
        out,
        "ply\nformat {format} 1.0\ncomment irregular blob\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        v.len(),
        f.len()
    )
    .unwrap();
    match format {
        "ascii" => {
            for p in &v {
                writeln!(out, "{} {} {} 200", p.x, p.y, p.z).unwrap();
            }
            for t in &f {
                writeln!(out, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
            }
        }
        _ => {
            let be = format == "binary_big_endian";
            let put = |out: &mut Vec<u8>, b: [u8; 4]| {
                out.extend(if be {
                    b.iter().rev().copied().collect::<Vec<_>>()
                } else {
                    b.to_vec()
                })
            };
            for p in &v {
                for c in p.to_array() {
                    put(&mut out, c.to_le_bytes());
                }
                out.push(200);
            }
            for t in &f {
                out.push(3);
                for i in t {
                    put(&mut out, (*i as i32).to_le_bytes());
                }
            }
        }
    }
    out
}

fn stl_bytes(tris: &[[Vec3; 3]], ascii: bool) -> Vec<u8> {
    let mut out = Vec::new();
    if ascii {
        writeln!(out, "solid blob").unwrap();
        for t in tris {
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
            writeln!(out, "facet normal {} {} {}\n outer loop", n.x, n.y, n.z).unwrap();
            for p in t {
                writeln!(out, "  vertex {} {} {}", p.x, p.y, p.z).unwrap();
            }
            writeln!(out, " endloop\nendfacet").unwrap();
        }
        writeln!(out, "endsolid blob").unwrap();
    } else {
        out.extend([0u8; 80]);
        out.extend((tris.len() as u32).to_le_bytes());
        for t in tris {
            out.extend([0u8; 12]);
            for p in t {
                for c in p.to_array() {
                    out.extend(c.to_le_bytes());
                }
            }
            out.extend([0u8; 2]);
        }
    }
    out
}

fn obj_bytes(tris: &[[Vec3; 3]]) -> Vec<u8> {
    let (v, f) = indexed(tris);
    let mut out = Vec::new();
    writeln!(out, "o blob").unwrap();
    for p in &v {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for t in &f {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    out
}

fn options(patch_size: f64) -> LoadConfig {
    LoadConfig {
        patch_size: Some(patch_size),
        ..LoadConfig::default()
    }
}

fn scene_of(path: &Path, options: &LoadConfig) -> Scene {
    let loaded = load(path, options).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    Scene::new(loaded.desc).unwrap()
}

/// Everything a patch is, as bits.
fn patch_bits(scene: &Scene) -> Vec<[u32; 8]> {
    scene
        .patches()
        .iter()
        .map(|p| {
            let c = p.center.to_array().map(f32::to_bits);
            let n = p.normal.to_array().map(f32::to_bits);
            [
                c[0],
                c[1],
                c[2],
                n[0],
                n[1],
                n[2],
                (p.area as f32).to_bits(),
                p.polygon,
            ]
        })
        .collect()
}

#[test]
fn one_mesh_in_five_formats_gives_the_same_patches_to_the_bit() {
    let tris = blob_triangles();
    let dir = tempfile::tempdir().unwrap();
    let files = [
        write(dir.path(), "blob.obj", &obj_bytes(&tris)),
        write(dir.path(), "blob_ascii.ply", &ply_bytes(&tris, "ascii")),
        write(
            dir.path(),
            "blob_le.ply",
            &ply_bytes(&tris, "binary_little_endian"),
        ),
        write(
            dir.path(),
            "blob_be.ply",
            &ply_bytes(&tris, "binary_big_endian"),
        ),
        write(dir.path(), "blob_ascii.stl", &stl_bytes(&tris, true)),
        write(dir.path(), "blob_binary.stl", &stl_bytes(&tris, false)),
    ];
    let reference = scene_of(&files[0], &options(0.5));
    assert_eq!(reference.polygons().len(), 3000);
    assert_eq!(reference.patches().len(), 3000);
    for file in &files[1..] {
        let scene = scene_of(file, &options(0.5));
        assert_eq!(scene.polygons().len(), 3000, "{}", file.display());
        for (a, b) in reference.polygons().iter().zip(scene.polygons()) {
            assert_eq!(a.vertices(), b.vertices(), "{}", file.display());
        }
        assert!(
            patch_bits(&scene) == patch_bits(&reference),
            "{}",
            file.display()
        );
        assert_eq!(scene.materials()[0].reflectance.0, [0.5; 3]);
    }
}

#[test]
fn truncated_and_malformed_mesh_files_are_refused_by_name() {
    let tris = blob_triangles()[..50].to_vec();
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("cut.stl", stl_bytes(&tris, false)[..1000].to_vec(), "truncated"),
        ("short.stl", b"abc".to_vec(), "84-byte header"),
        ("cut.ply", ply_bytes(&tris, "binary_little_endian")[..600].to_vec(), "(PLY): element"),
        ("noface.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec(), "no face element"),
        ("badindex.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n".to_vec(), "vertex index 7"),
        ("garbage.ply", b"not a ply file at all".to_vec(), "PLY"),
        // A billion vertices of no properties (the fuzzer's find: 24 GB from 100 bytes).
        ("empty_vertices.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n".to_vec(), "no properties"),
        ("many_vertices.ply", b"ply\nformat ascii 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec(), "more than the file's"),
        ("garbage.gltf", b"{\"asset\": 3}".to_vec(), "glTF"),
        ("garbage.glb", b"glTF\x02\x00\x00\x00\x10".to_vec(), "glTF"),
    ];
    for (name, bytes, expect) in cases {
        let path = write(dir.path(), name, &bytes);
        let msg = match load(&path, &options(1.0)) {
            Ok(l) => match Scene::new(l.desc) {
                Ok(_) => panic!("{name} was accepted"),
                Err(e) => e.to_string(),
            },
            Err(e) => e.to_string(),
        };
        assert!(msg.contains(name) && msg.contains(expect), "{name}: {msg}");
    }
}

#[test]
fn stl_headers_that_fool_a_first_word_test_are_read_right() {
    let tris = blob_triangles()[..20].to_vec();
    let dir = tempfile::tempdir().unwrap();
    let reference = scene_of(
        &write(dir.path(), "r.stl", &stl_bytes(&tris, false)),
        &options(0.5),
    );
    // A binary file whose 80-byte header begins "solid" (some exporters write that).
    let mut binary = stl_bytes(&tris, false);
    binary[..11].copy_from_slice(b"solid exprt");
    // ASCII files opening "solid" with no name, or in capitals.
    let ascii = String::from_utf8(stl_bytes(&tris, true)).unwrap();
    let bare = ascii.replacen("solid blob", "solid", 1);
    let caps = ascii.replacen("solid blob", "SOLID BLOB", 1);
    for (name, bytes) in [
        ("b.stl", binary),
        ("bare.stl", bare.into_bytes()),
        ("caps.stl", caps.into_bytes()),
    ] {
        let scene = scene_of(&write(dir.path(), name, &bytes), &options(0.5));
        assert!(patch_bits(&scene) == patch_bits(&reference), "{name}");
    }
}

#[test]
fn a_mesh_needs_a_patch_size_and_the_error_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "m.stl",
        &stl_bytes(&blob_triangles()[..4], true),
    );
    let desc = load(&path, &LoadConfig::default()).unwrap().desc;
    let msg = Scene::new(desc).unwrap_err().to_string();
    assert!(msg.contains("--patch-size"), "{msg}");
}

/// A two-triangle quad (the xy unit square) as glTF JSON, buffers in a data URI, placed
/// by a node translated by (10, 0, 0) and scaled by -1 in z (mirrored, so the winding
/// must flip), with a material and a camera.
fn gltf_quad(material: &str) -> String {
    let mut bin = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for c in p {
            bin.extend(c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let b64 = base64(&bin);
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0, "translation": [10, 0, 0], "scale": [1, 1, -1]}},
            {{"camera": 0, "translation": [0.5, 0.5, -3], "rotation": [0, 1, 0, 0]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "znear": 0.01}}}}],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{material}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}]
}}"#,
        len = bin.len()
    )
}

pub(crate) fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

#[test]
fn gltf_meshes_are_placed_by_their_nodes_with_materials_and_the_camera() {
    let dir = tempfile::tempdir().unwrap();
    let material = r#"{"name": "glow", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 1.0, 1]},
        "emissiveFactor": [1, 0.5, 0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8}}}"#;
    let path = write(dir.path(), "quad.gltf", gltf_quad(material).as_bytes());
    let loaded = load(&path, &options(0.5)).unwrap();
    assert!(
        loaded.notes.iter().any(|n| n.contains("clamped")),
        "{:?}",
        loaded.notes
    );
    let scene = Scene::new(loaded.desc).unwrap();
    assert_eq!(scene.polygons().len(), 2);
    let m = &scene.materials()[scene.polygons()[0].material() as usize];
    assert_eq!(m.name, "glow");
    assert_eq!(m.reflectance.0, [0.2f32 as f64, 0.4f32 as f64, 0.99]);
    assert_eq!(m.emission.0, [8.0, 4.0, 0.0]);
    for poly in scene.polygons() {
        assert!(poly.vertices().iter().all(|v| v.x >= 10.0 && v.z == 0.0));
        // Mirrored in z, the quad faces -z: the winding was flipped to keep it so.
        assert!(poly.normal().z < -0.99, "{:?}", poly.normal());
    }
    let cam = scene.camera().expect("the camera");
    assert_eq!(cam.position, Vec3::new(0.5, 0.5, -3.0));
    assert!(
        (cam.look_at - cam.position - Vec3::Z).length() < 1e-6,
        "{cam:?}"
    );
    assert!((cam.fov_y - 0.8).abs() < 1e-7);
    // What the gltf crate would trust blindly is refused by name: float indices, a
    // stride shorter than a position, a node reached twice, a GLB header too short.
    for (from, to, expect) in [
        (
            "\"componentType\": 5123",
            "\"componentType\": 5126",
            "indices accessor 1: is F32 Scalar",
        ),
        (
            "\"byteOffset\": 0, \"byteLength\": 48}",
            "\"byteOffset\": 0, \"byteLength\": 48, \"byteStride\": 4}",
            "byteStride 4",
        ),
        ("\"count\": 6", "\"count\": 600", "600 elements do not fit"),
        (
            "\"nodes\": [0, 1]",
            "\"nodes\": [0, 1, 0]",
            "node 0 is reached twice",
        ),
    ] {
        let text = gltf_quad(material).replace(from, to);
        assert_ne!(text, gltf_quad(material), "{from}");
        let bad = write(dir.path(), "bad.gltf", text.as_bytes());
        let msg = load(&bad, &options(0.5)).unwrap_err().to_string();
        assert!(
            msg.contains("bad.gltf") && msg.contains(expect),
            "{expect}: {msg}"
        );
    }
    let glb = write(
        dir.path(),
        "short.glb",
        b"glTF\x02\x00\x00\x00\x05\x00\x00\x00",
    );
    let msg = load(&glb, &options(0.5)).unwrap_err().to_string();
    assert!(msg.contains("GLB header"), "{msg}");
    // Cut short, the buffer is refused by name.
    let text = gltf_quad(material).replace("\"byteLength\": 60", "\"byteLength\": 600");
    let short = write(dir.path(), "short.gltf", text.as_bytes());
    let msg = load(&short, &options(0.5)).unwrap_err().to_string();
    assert!(
        msg.contains("short.gltf") && msg.contains("truncated"),
        "{msg}"
    );
}

#[test]
fn the_material_file_names_emitters_by_box_and_by_face_range() {
    let dir = tempfile::tempdir().unwrap();
    let tris = blob_triangles()[..40].to_vec();
    let path = write(dir.path(), "m.stl", &stl_bytes(&tris, false));
    let lo = tris[7].iter().fold(Vec3::INFINITY, |a, v| a.min(*v)) - 1e-4;
    let hi = tris[7].iter().fold(Vec3::NEG_INFINITY, |a, v| a.max(*v)) + 1e-4;
    let map = format!(
        r#"{{"materials": [{{"name": "lamp", "reflectance": [0, 0, 0], "emission": [5, 5, 5]}},
                         {{"name": "(default)", "reflectance": [0.7, 0.7, 0.7]}}],
            "assign": [{{"material": "lamp", "faces": [0, 3]}},
                       {{"material": "lamp", "inside": {{"min": [{}, {}, {}], "max": [{}, {}, {}]}}}}]}}"#,
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    let map_path = write(dir.path(), "materials.json", map.as_bytes());
    let opts = LoadConfig {
        materials: Some(map_path.clone()),
        ..options(1.0)
    };
    let loaded = load(&path, &opts).unwrap();
    let scene = Scene::new(loaded.desc.clone()).unwrap();
    let lamp = scene
        .materials()
        .iter()
        .position(|m| m.name == "lamp")
        .unwrap() as u32;
    assert_eq!(scene.materials()[0].reflectance.0, [0.7; 3]);
    let lit: Vec<usize> = (0..40)
        .filter(|&k| scene.polygons()[k].material() == lamp)
        .collect();
    // Faces 0-2 by range, face 7 by the box around it.
    assert!(lit.starts_with(&[0, 1, 2]) && lit.contains(&7), "{lit:?}");
    assert!(lit.len() < 10, "{lit:?}");
    assert!(
        loaded.notes.iter().any(|n| n.contains("3 faces")),
        "{:?}",
        loaded.notes
    );
    let miss = r#"{"assign": [{"material": "(default)", "inside": {"min": [100, 100, 100], "max": [101, 101, 101]}}]}"#;
    let miss_path = write(dir.path(), "miss.json", miss.as_bytes());
    let msg = load(
        &path,
        &LoadConfig {
            materials: Some(miss_path),
            ..options(1.0)
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        msg.contains("miss.json") && msg.contains("matches no face"),
        "{msg}"
    );
    let unknown = r#"{"assign": [{"material": "gold", "faces": [0, 1]}]}"#;
    let unknown_path = write(dir.path(), "unknown.json", unknown.as_bytes());
    let msg = load(
        &path,
        &LoadConfig {
            materials: Some(unknown_path),
            ..options(1.0)
        },
    )
    .unwrap_err()
    .to_string();
    assert!(msg.contains("\"gold\""), "{msg}");
}

#[test]
fn triangulate_mends_an_obj_with_a_concave_and_a_degenerate_face() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "o room\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 3 0 0\nf 1 2 3 4 5 6\nf 1 2 7\n";
    let path = write(dir.path(), "ell.obj", obj.as_bytes());
    let msg = match load(&path, &options(0.5)) {
        Ok(l) => Scene::new(l.desc).unwrap_err().to_string(),
        Err(e) => e.to_string(),
    };
    assert!(
        msg.contains("not convex") && msg.contains("--triangulate"),
        "{msg}"
    );
    let opts = LoadConfig {
        triangulate: true,
        ..options(0.5)
    };
    let loaded = load(&path, &opts).unwrap();
    let t = &loaded.triangulation;
    assert_eq!((t.split, t.triangles, t.dropped), (1, 4, 1));
    let scene = Scene::new(loaded.desc).unwrap();
    let area: f64 = scene.patches().iter().map(|p| p.area).sum();
    assert!((area - 3.0).abs() < 1e-6, "{area}");
}
