//! Scenes and solutions out to viewers: glTF 2.0 (`.glb`, or `.gltf` with its buffer
//! embedded) and PLY (binary), with the radiosity baked as vertex colours.
//!
//! With a solution, every patch is its own polygon (its clipped cell), and each of its
//! corners takes the smooth shading's value there (`rad_render::smooth_at`: the corner
//! values interpolated bilinearly), times the exposure, clipped to [0, 1]: glTF's COLOR_0
//! is linear, PLY's 8-bit colours are sRGB-encoded. glTF materials are then unlit
//! (`KHR_materials_unlit`, base colour white), so a viewer shows the colours as they are;
//! each keeps the scene's reflectance and emission in `extras.coherad`, which
//! `coherad`'s reader takes back. Without a solution, polygons are exported as they are
//! (fan-triangulated in glTF) with PBR materials: `baseColorFactor` the reflectance,
//! `emissiveFactor` × `KHR_materials_emissive_strength` the emission.
//!
//! One glTF mesh a polygon group (a polygon with none goes to its material's), one
//! primitive a material within it; positions in the scene's units (glTF takes them as
//! metres), face normals; the scene's camera as a perspective camera node.

use crate::output::write_atomic;
use crate::{Error, SceneFile};
use glam::{Mat3, Quat, Vec3};
use rad_geometry::Scene;
use rad_render::{corner_values, smooth_at};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

/// The formats `coherad export` writes, by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// Binary glTF: JSON and buffer in one file.
    Glb,
    /// glTF JSON with its buffer in a base64 data URI.
    Gltf,
    /// Binary little-endian PLY with 8-bit sRGB vertex colours.
    Ply,
}

impl ExportFormat {
    /// The format of `path`'s extension.
    pub fn of_path(path: &Path) -> Result<ExportFormat, Error> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "glb" => Ok(ExportFormat::Glb),
            "gltf" => Ok(ExportFormat::Gltf),
            "ply" => Ok(ExportFormat::Ply),
            _ => Err(Error::Parse {
                what: "export file name",
                input: path.display().to_string(),
                reason: "expected a .glb, .gltf or .ply extension".into(),
            }),
        }
    }
}

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSummary {
    pub format: ExportFormat,
    pub meshes: usize,
    pub vertices: usize,
    pub triangles: usize,
    /// The linear scale applied to the radiosities (2^EV), if a solution was baked.
    pub scale: Option<f64>,
    pub bytes: u64,
}

/// One vertex of the export: position, normal, colour (linear, scaled and clipped).
#[derive(Clone, Copy)]
struct Vertex {
    p: Vec3,
    n: Vec3,
    c: [f32; 3],
}

/// The geometry of one primitive: a polygon list (fans in glTF).
#[derive(Default)]
struct Primitive {
    vertices: Vec<Vertex>,
    /// Each face's first vertex and vertex count.
    faces: Vec<(u32, u32)>,
}

/// The exposure scale used when none is given: 0.8 over the 95th percentile of the
/// patches' luminance (area-blind, as `images::auto_exposure` is pixel-blind), so
/// that lamps and the brightest few per cent saturate; 1 for a black solution.
pub fn auto_scale(b: &[[f64; 3]]) -> f64 {
    let mut l: Vec<f64> = b
        .iter()
        .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
        .filter(|&v| v > 0.0)
        .collect();
    if l.is_empty() {
        return 1.0;
    }
    l.sort_by(f64::total_cmp);
    0.8 / l[((l.len() - 1) as f64 * 0.95) as usize]
}

/// Writes `scene` (with radiosities `b`, one RGB a patch, if given) to `path`, in the
/// format its extension names; `exposure` in stops (the colours are B × 2^EV), else
/// [`auto_scale`]. Atomic: all or nothing.
pub fn export(
    scene: &SceneFile,
    b: Option<&[[f64; 3]]>,
    exposure: Option<f64>,
    path: &Path,
) -> Result<ExportSummary, Error> {
    let format = ExportFormat::of_path(path)?;
    if let Some(ev) = exposure {
        if !ev.is_finite() {
            return Err(Error::Parse {
                what: "exposure",
                input: ev.to_string(),
                reason: "must be a finite number of stops".into(),
            });
        }
    }
    if let Some(b) = b {
        if b.len() != scene.scene.patches().len() {
            return Err(Error::Solution {
                path: path.to_path_buf(),
                reason: format!(
                    "has {} radiosities for a scene of {} patches",
                    b.len(),
                    scene.scene.patches().len()
                ),
            });
        }
    }
    let scale = b.map(|b| exposure.map_or_else(|| auto_scale(b), |ev| 2f64.powf(ev)));
    if let Some(s) = scale.filter(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::Parse {
            what: "exposure",
            input: format!("{}", exposure.unwrap_or(f64::NAN)),
            reason: format!("gives a colour scale of {s:e}; keep 2^EV within f64's range"),
        });
    }
    let meshes = build_meshes(&scene.scene, b, scale.unwrap_or(1.0));
    let vertices = meshes
        .values()
        .flat_map(|m| m.values())
        .map(|p| p.vertices.len())
        .sum();
    let triangles = match format {
        ExportFormat::Ply => meshes
            .values()
            .flat_map(|m| m.values())
            .flat_map(|p| &p.faces)
            .map(|&(_, n)| n as usize - 2)
            .sum(),
        _ => meshes
            .values()
            .flat_map(|m| m.values())
            .map(|p| fan_indices(p).len() / 3)
            .sum(),
    };
    let bytes = match format {
        ExportFormat::Ply => ply_bytes(&meshes, b.is_some()),
        ExportFormat::Glb | ExportFormat::Gltf => {
            let (doc, bin) = gltf_document(&scene.scene, &meshes, b.is_some());
            if format == ExportFormat::Glb {
                glb_bytes(&doc, &bin)?
            } else {
                let mut doc = doc;
                doc["buffers"][0]["uri"] = Value::String(format!(
                    "data:application/octet-stream;base64,{}",
                    base64(&bin)
                ));
                serde_json::to_vec_pretty(&doc).expect("JSON values serialise")
            }
        }
    };
    write_atomic(path, |w| w.write_all(&bytes))?;
    Ok(ExportSummary {
        format,
        meshes: meshes.len(),
        vertices,
        triangles,
        scale,
        bytes: bytes.len() as u64,
    })
}

/// Mesh name → material index → primitive.
type Meshes = BTreeMap<String, BTreeMap<u32, Primitive>>;

fn build_meshes(scene: &Scene, b: Option<&[[f64; 3]]>, scale: f64) -> Meshes {
    let corners = b.map(|b| corner_values(scene, b));
    let mut meshes = Meshes::new();
    let patches = scene.patches();
    for (k, poly) in scene.polygons().iter().enumerate() {
        let material = poly.material();
        let name = scene
            .group(k)
            .map(str::to_string)
            .unwrap_or_else(|| scene.materials()[material as usize].name.clone());
        let prim = meshes.entry(name).or_default().entry(material).or_default();
        let n = poly.normal();
        let mut face = |points: &mut dyn Iterator<Item = (Vec3, [f32; 3])>| {
            let first = prim.vertices.len() as u32;
            prim.vertices
                .extend(points.map(|(p, c)| Vertex { p, n, c }));
            let count = prim.vertices.len() as u32 - first;
            prim.faces.push((first, count));
        };
        match &corners {
            None => face(&mut poly.vertices().iter().map(|&p| (p, [1.0; 3]))),
            Some(corners) => {
                let (first, last) = patch_range(scene, k);
                for patch in &patches[first..last] {
                    face(&mut patch.corners.iter().map(|&p| {
                        let (u, v) = poly.uv(p);
                        let value = smooth_at(poly, &corners[k], u, v);
                        (p, value.map(|c| (c * scale).clamp(0.0, 1.0) as f32))
                    }));
                }
            }
        }
    }
    meshes
}

/// The patches of polygon `k` (numbered polygon by polygon).
fn patch_range(scene: &Scene, k: usize) -> (usize, usize) {
    let polys = scene.polygons();
    let first = polys[k].first_patch() as usize;
    let last = polys
        .get(k + 1)
        .map_or(scene.patches().len(), |p| p.first_patch() as usize);
    (first, last)
}

/// A primitive's faces as triangle fans from their first vertex, leaving out the
/// triangles no scene would take (collinear corners, slivers of clipping): they cover
/// nothing, and an export reads back as a valid scene.
fn fan_indices(prim: &Primitive) -> Vec<u32> {
    let mut out = Vec::with_capacity(3 * prim.vertices.len());
    for &(first, n) in &prim.faces {
        for k in 1..n - 1 {
            let t = [first, first + k, first + k + 1];
            let corners = t.map(|i| prim.vertices[i as usize].p);
            if rad_geometry::vertices_problem(&corners).is_none() {
                out.extend(t);
            }
        }
    }
    out
}

/// The glTF JSON (its one buffer's URI left out) and the binary buffer.
fn gltf_document(scene: &Scene, meshes: &Meshes, baked: bool) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        views.len() - 1
    };
    let mut gltf_meshes = Vec::new();
    for (name, prims) in meshes {
        let mut primitives = Vec::new();
        for (&material, prim) in prims {
            let floats = |f: &dyn Fn(&Vertex) -> [f32; 3]| -> Vec<u8> {
                prim.vertices
                    .iter()
                    .flat_map(|v| f(v))
                    .flat_map(f32::to_le_bytes)
                    .collect()
            };
            let (lo, hi) = prim.vertices.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), v| (lo.min(v.p), hi.max(v.p)),
            );
            let count = prim.vertices.len();
            let pos = view(&mut bin, &floats(&|v| v.p.to_array()), 34962);
            accessors.push(
                json!({"bufferView": pos, "componentType": 5126, "count": count, "type": "VEC3",
                "min": lo.to_array(), "max": hi.to_array()}),
            );
            let mut attributes = json!({"POSITION": accessors.len() - 1});
            let nrm = view(&mut bin, &floats(&|v| v.n.to_array()), 34962);
            accessors.push(
                json!({"bufferView": nrm, "componentType": 5126, "count": count, "type": "VEC3"}),
            );
            attributes["NORMAL"] = json!(accessors.len() - 1);
            if baked {
                let col = view(&mut bin, &floats(&|v| v.c), 34962);
                accessors.push(json!({"bufferView": col, "componentType": 5126, "count": count, "type": "VEC3"}));
                attributes["COLOR_0"] = json!(accessors.len() - 1);
            }
            let indices = fan_indices(prim);
            let idx_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
            let idx = view(&mut bin, &idx_bytes, 34963);
            accessors.push(json!({"bufferView": idx, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}));
            primitives.push(
                json!({"attributes": attributes, "indices": accessors.len() - 1,
                "material": material, "mode": 4}),
            );
        }
        gltf_meshes.push(json!({"name": name, "primitives": primitives}));
    }
    let materials: Vec<Value> = scene
        .materials()
        .iter()
        .map(|m| gltf_material(m, baked))
        .collect();
    let mut nodes: Vec<Value> = (0..gltf_meshes.len())
        .zip(meshes.keys())
        .map(|(k, name)| json!({"mesh": k, "name": name}))
        .collect();
    let mut cameras = Vec::new();
    if let Some(cam) = scene.camera() {
        let (lo, hi) = scene.bounds();
        let forward = (cam.look_at - cam.position).normalize();
        let right = forward.cross(cam.up).normalize();
        let up = right.cross(forward);
        let rotation = Quat::from_mat3(&Mat3::from_cols(right, up, -forward)).normalize();
        cameras.push(json!({"type": "perspective", "name": "camera",
            "perspective": {"yfov": cam.fov_y, "znear": (1e-4 * (hi - lo).length()).max(1e-6)}}));
        nodes.push(
            json!({"name": "camera", "camera": 0, "translation": cam.position.to_array(),
            "rotation": rotation.to_array()}),
        );
    }
    let mut extensions = Vec::new();
    if baked {
        extensions.push("KHR_materials_unlit");
    } else if scene
        .materials()
        .iter()
        .any(|m| m.emission.0.iter().any(|&e| e > 1.0))
    {
        extensions.push("KHR_materials_emissive_strength");
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": concat!("coherad ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": gltf_meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    if !cameras.is_empty() {
        doc["cameras"] = Value::Array(cameras);
    }
    if !extensions.is_empty() {
        doc["extensionsUsed"] = json!(extensions);
    }
    (doc, bin)
}

fn gltf_material(m: &rad_geometry::Material, baked: bool) -> Value {
    let extras = json!({"coherad": {"reflectance": m.reflectance.0, "emission": m.emission.0}});
    if baked {
        return json!({"name": m.name, "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_unlit": {}}, "extras": extras});
    }
    let r = m.reflectance.0;
    let mut out = json!({"name": m.name, "pbrMetallicRoughness": {"baseColorFactor": [r[0], r[1], r[2], 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}, "extras": extras});
    let e = m.emission.0;
    let peak = e.iter().copied().fold(0.0, f64::max);
    if peak > 0.0 {
        let strength = peak.max(1.0);
        out["emissiveFactor"] = json!(e.map(|c| c / strength));
        if strength > 1.0 {
            out["extensions"] =
                json!({"KHR_materials_emissive_strength": {"emissiveStrength": strength}});
        }
    }
    out
}

/// A GLB container: 12-byte header, the JSON chunk (padded with spaces), the BIN chunk
/// (padded with zeros), each to 4 bytes.
fn glb_bytes(doc: &Value, bin: &[u8]) -> Result<Vec<u8>, Error> {
    let mut json = serde_json::to_vec(doc).expect("JSON values serialise");
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    if total > u32::MAX as usize {
        return Err(Error::Encode {
            what: "glb",
            reason: format!("{total} bytes, over GLB's 4 GiB; write .gltf, or fewer patches"),
        });
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

/// Most vertices a PLY face is written with (its count is a uchar); a larger face (a
/// polygon of over 255 vertices, or a patch clipped by one) is written as a fan.
const MAX_PLY_FACE: u32 = 255;

/// Binary little-endian PLY: float position and normal, with a solution 8-bit sRGB
/// colour; each patch (or polygon) one face.
fn ply_bytes(meshes: &Meshes, baked: bool) -> Vec<u8> {
    let prims: Vec<&Primitive> = meshes.values().flat_map(|m| m.values()).collect();
    let n_vertices: usize = prims.iter().map(|p| p.vertices.len()).sum();
    let n_faces: usize = prims
        .iter()
        .flat_map(|p| &p.faces)
        .map(|&(_, n)| if n <= MAX_PLY_FACE { 1 } else { n as usize - 2 })
        .sum();
    let mut out = Vec::new();
    let colour = if baked {
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    } else {
        ""
    };
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\ncomment coherad {}\nelement vertex {n_vertices}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n{colour}element face {n_faces}\nproperty list uchar int vertex_indices\nend_header\n",
        env!("CARGO_PKG_VERSION")
    )
    .expect("writing to memory");
    for v in prims.iter().flat_map(|p| &p.vertices) {
        for c in v.p.to_array().into_iter().chain(v.n.to_array()) {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if baked {
            out.extend(v.c.map(crate::images::srgb8));
        }
    }
    let mut base = 0u32;
    for p in &prims {
        for &(first, n) in &p.faces {
            let first = base + first;
            if n <= MAX_PLY_FACE {
                out.push(n as u8);
                for k in 0..n {
                    out.extend_from_slice(&((first + k) as i32).to_le_bytes());
                }
            } else {
                for k in 1..n - 1 {
                    out.push(3);
                    for i in [first, first + k, first + k + 1] {
                        out.extend_from_slice(&(i as i32).to_le_bytes());
                    }
                }
            }
        }
        base += p.vertices.len() as u32;
    }
    out
}

/// Standard base64 with padding (RFC 4648).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            s.push(if k <= c.len() {
                A[((n >> (18 - 6 * k)) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}
