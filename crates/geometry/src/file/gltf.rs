//! glTF 2.0 scenes (`.gltf` with embedded or external buffers, and `.glb`) through the
//! `gltf` crate: every triangle of the default scene's meshes, placed by its nodes'
//! transforms, is a polygon; materials from `baseColorFactor` (reflectance) and
//! `emissiveFactor` × `KHR_materials_emissive_strength` (emission), or from the
//! `extras.coherad` that `coherad export` writes; the first perspective camera.

use super::mesh::default_material;
use crate::error::Error;
use crate::scene::{Camera, Material, PatchGrid, PolygonDesc, SceneDesc};
use glam::{Mat4, Vec3};
use rad_core::Rgb;
use std::path::Path;

/// Largest reflectance taken from a `baseColorFactor` (the scene's reflectances must be
/// under 1; glTF's default white is 1).
pub const MAX_GLTF_REFLECTANCE: f64 = 0.99;

/// Deepest node hierarchy followed (a cycle is refused before it).
const MAX_NODE_DEPTH: usize = 256;

mod motion;
pub use motion::{gltf_motion, gltf_motion_from_bytes};

fn err(path: &Path, message: impl Into<String>) -> Error {
    Error::Mesh {
        path: path.to_path_buf(),
        format: "glTF",
        message: message.into(),
    }
}

/// The `extras.coherad` object of an exported material.
#[derive(serde::Deserialize)]
struct CoheradExtras {
    coherad: CoheradMaterial,
}

#[derive(serde::Deserialize)]
struct CoheradMaterial {
    reflectance: [f64; 3],
    emission: [f64; 3],
}

/// Reads a glTF or GLB file; `notes` collects what was read with a change worth a
/// warning (a clamped reflectance, textures and primitives ignored).
pub fn load_gltf(
    path: &Path,
    patch_size: f64,
    reflectance: Option<Rgb>,
    notes: &mut Vec<String>,
) -> Result<SceneDesc, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    gltf_from_bytes(path, &bytes, patch_size, reflectance, notes)
}

/// A glTF or GLB file in memory (see [`load_gltf`]); external buffers are read beside
/// `path`, and errors name it.
pub fn gltf_from_bytes(
    path: &Path,
    bytes: &[u8],
    patch_size: f64,
    reflectance: Option<Rgb>,
    notes: &mut Vec<String>,
) -> Result<SceneDesc, Error> {
    let gltf = parse_document(path, bytes)?;
    let buffers = load_buffers(path, &gltf)?;
    let doc = &gltf.document;
    let mut materials = Vec::new();
    let mut names = std::collections::HashSet::new();
    for (k, m) in doc.materials().enumerate() {
        let mut name = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material {k}"));
        if !names.insert(name.clone()) {
            name = format!("{name} ({k})");
            names.insert(name.clone());
        }
        materials.push(material_of(&m, name, notes)?);
    }
    let default = materials.len();
    materials.push(default_material(reflectance));
    let mut desc = SceneDesc {
        materials,
        polygons: Vec::new(),
        camera: None,
    };
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err(path, "has no scene"))?;
    let mut stack: Vec<(gltf::Node, Mat4, usize)> =
        scene.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    stack.reverse();
    let mut visited = vec![false; doc.nodes().len()];
    while let Some((node, parent, depth)) = stack.pop() {
        first_visit(path, &mut visited, node.index())?;
        if depth > MAX_NODE_DEPTH {
            return Err(err(
                path,
                format!("node hierarchy deeper than {MAX_NODE_DEPTH} (a cycle?)"),
            ));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(err(
                path,
                format!("node {} has a non-finite transform", node.index()),
            ));
        }
        if let (Some(cam), None) = (node.camera(), desc.camera) {
            if let gltf::camera::Projection::Perspective(p) = cam.projection() {
                let position = world.transform_point3(Vec3::ZERO);
                desc.camera = Some(Camera {
                    position,
                    look_at: position + world.transform_vector3(-Vec3::Z),
                    up: world.transform_vector3(Vec3::Y),
                    fov_y: p.yfov(),
                });
            }
        }
        if let Some(mesh) = node.mesh() {
            add_mesh(
                path, &mesh, world, &buffers, default, patch_size, &mut desc, notes,
            )?;
        }
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world, depth + 1)));
    }
    if desc.polygons.is_empty() {
        return Err(err(path, "its scene has no triangles"));
    }
    Ok(desc)
}

/// Marks node `index` visited; refuses a node reached twice (nodes must form trees,
/// and a cycle would never end).
fn first_visit(path: &Path, visited: &mut [bool], index: usize) -> Result<(), Error> {
    if std::mem::replace(&mut visited[index], true) {
        return Err(err(
            path,
            format!("node {index} is reached twice (nodes must form trees)"),
        ));
    }
    Ok(())
}

/// The glTF document of `bytes` (JSON or GLB), validated by the `gltf` crate after
/// the checks its validation skips.
fn parse_document(path: &Path, bytes: &[u8]) -> Result<gltf::Gltf, Error> {
    if bytes.starts_with(b"glTF") {
        let word = |k: usize| {
            bytes
                .get(k..k + 4)
                .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        };
        match (word(4), word(8)) {
            (Some(2), Some(n)) if n as usize >= 20 && n as usize <= bytes.len() => {}
            (Some(2), n) => {
                return Err(err(
                    path,
                    format!(
                    "GLB header gives a length of {n:?} bytes, but the file has {} (truncated?)",
                    bytes.len()
                ),
                ))
            }
            (v, _) => {
                return Err(err(
                    path,
                    format!("GLB version {v:?}: only version 2 is read"),
                ))
            }
        }
    }
    let parse = |e: gltf::Error| err(path, format!("cannot parse glTF: {e}"));
    let raw = gltf::Gltf::from_slice_without_validation(bytes).map_err(parse)?;
    // gltf-json's validation indexes the accessors by every POSITION attribute before
    // checking that index (a panic on a bad file): check it first.
    let json = raw.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (k, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, index) in &prim.attributes {
                if index.value() >= json.accessors.len() {
                    return Err(err(
                        path,
                        format!(
                            "mesh {m} primitive {k}: attribute {semantic:?} names accessor {}, but there are {}",
                            index.value(),
                            json.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    let gltf = gltf::Gltf {
        document: gltf::Document::from_json(raw.document.into_json()).map_err(parse)?,
        blob: raw.blob,
    };
    Ok(gltf)
}

/// The scene material of a glTF material.
fn material_of(
    m: &gltf::Material,
    name: String,
    notes: &mut Vec<String>,
) -> Result<Material, Error> {
    if let Some(raw) = m.extras() {
        if let Ok(x) = serde_json::from_str::<CoheradExtras>(raw.get()) {
            return Ok(Material {
                name,
                reflectance: Rgb(x.coherad.reflectance),
                emission: Rgb(x.coherad.emission),
            });
        }
    }
    let pbr = m.pbr_metallic_roughness();
    let base = pbr.base_color_factor();
    let mut reflectance = [base[0], base[1], base[2]].map(f64::from);
    if reflectance.iter().any(|&c| c > MAX_GLTF_REFLECTANCE) {
        notes.push(format!(
            "material {name:?}: baseColorFactor {reflectance:?} clamped to {MAX_GLTF_REFLECTANCE} (reflectances must be under 1)"
        ));
        reflectance = reflectance.map(|c| c.min(MAX_GLTF_REFLECTANCE));
    }
    if pbr.base_color_texture().is_some() {
        notes.push(format!(
            "material {name:?}: its baseColorTexture is ignored (one reflectance a material)"
        ));
    }
    let strength = f64::from(m.emissive_strength().unwrap_or(1.0));
    let emission = m.emissive_factor().map(|c| f64::from(c) * strength);
    Ok(Material {
        name,
        reflectance: Rgb(reflectance),
        emission: Rgb(emission),
    })
}

/// A triangle primitive's positions (untransformed) and triangles (vertex indices),
/// strips and fans unrolled.
fn primitive_triangles(
    path: &Path,
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    place: &str,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), Error> {
    use gltf::mesh::Mode;
    let mode = prim.mode();
    let positions_acc = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| err(path, format!("{place} has no POSITION")))?;
    check_accessor(
        path,
        &positions_acc,
        buffers,
        place,
        "POSITION",
        Want::Positions,
    )?;
    if let Some(acc) = prim.indices() {
        check_accessor(path, &acc, buffers, place, "indices", Want::Indices)?;
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
    let expected = positions_acc.count();
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| {
            err(
                path,
                format!("{place}: its POSITION data lies outside its buffer"),
            )
        })?
        .map(Vec3::from_array)
        .collect();
    if positions.len() != expected {
        return Err(err(
            path,
            format!(
                "{place}: POSITION has {} of its {expected} vertices (buffer too short)",
                positions.len()
            ),
        ));
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(ix) => {
            let expected = prim.indices().map_or(0, |a| a.count());
            let ix: Vec<u32> = ix.into_u32().collect();
            if ix.len() != expected {
                return Err(err(
                    path,
                    format!(
                        "{place}: its indices have {} of {expected} entries (buffer too short)",
                        ix.len()
                    ),
                ));
            }
            ix
        }
        None if prim.indices().is_some() => {
            return Err(err(
                path,
                format!("{place}: its index data lies outside its buffer"),
            ))
        }
        None => (0..positions.len() as u32).collect(),
    };
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::Triangles if indices.len() % 3 != 0 => {
            return Err(err(
                path,
                format!(
                    "{place}: {} indices do not make whole triangles",
                    indices.len()
                ),
            ))
        }
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        Mode::TriangleStrip => strip_triangles(&indices),
        _ => (2..indices.len())
            .map(|k| [indices[0], indices[k - 1], indices[k]])
            .collect(),
    };
    Ok((positions, triangles))
}

/// What an accessor must hold.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Want {
    /// Float VEC3, not normalised (POSITION, and translations and scales of animations).
    Positions,
    /// Unsigned byte, short or int scalars.
    Indices,
    /// Float scalars, not normalised (an animation's times).
    Times,
    /// VEC4: float, or normalised signed or unsigned byte or short (an animation's
    /// rotations).
    Rotations,
}

/// Checks that an accessor can be read as what it must be ([`Want`]), and that every
/// element lies inside its buffer view and the view inside its buffer (the `gltf`
/// crate's reader trusts both).
fn check_accessor(
    path: &Path,
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
    place: &str,
    what: &str,
    want: Want,
) -> Result<(), Error> {
    use gltf::accessor::{DataType, Dimensions};
    let fail = |m: String| {
        Err(err(
            path,
            format!("{place}: {what} accessor {}: {m}", acc.index()),
        ))
    };
    if acc.sparse().is_some() {
        return fail("sparse accessors are not supported".into());
    }
    let (dt, dims) = (acc.data_type(), acc.dimensions());
    let ok = match want {
        Want::Positions => dt == DataType::F32 && dims == Dimensions::Vec3 && !acc.normalized(),
        Want::Indices => {
            matches!(dt, DataType::U8 | DataType::U16 | DataType::U32) && dims == Dimensions::Scalar
        }
        Want::Times => dt == DataType::F32 && dims == Dimensions::Scalar && !acc.normalized(),
        Want::Rotations => {
            dims == Dimensions::Vec4
                && (dt == DataType::F32
                    || (acc.normalized()
                        && matches!(
                            dt,
                            DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
                        )))
        }
    };
    if !ok {
        return fail(format!(
            "is {dt:?} {dims:?}, not what the glTF specification allows here"
        ));
    }
    let Some(view) = acc.view() else {
        return fail("has no bufferView".into());
    };
    let count = acc.count();
    if count == 0 {
        return fail("has no elements".into());
    }
    let elem = dt.size() * dims.multiplicity();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return fail(format!(
            "byteStride {stride} is under its element's {elem} bytes"
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(acc.offset()))
        .and_then(|x| x.checked_add(elem));
    if end.is_none_or(|e| e > view.length()) {
        return fail(format!(
            "{count} elements do not fit its bufferView of {} bytes",
            view.length()
        ));
    }
    let data = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    if view
        .offset()
        .checked_add(view.length())
        .is_none_or(|e| e > data)
    {
        return fail(format!(
            "its bufferView {} lies outside its buffer of {data} bytes",
            view.index()
        ));
    }
    Ok(())
}

/// Every triangle of `mesh`'s primitives, transformed by `world`.
#[allow(clippy::too_many_arguments)]
fn add_mesh(
    path: &Path,
    mesh: &gltf::Mesh,
    world: Mat4,
    buffers: &[Vec<u8>],
    default: usize,
    patch_size: f64,
    desc: &mut SceneDesc,
    notes: &mut Vec<String>,
) -> Result<(), Error> {
    use gltf::mesh::Mode;
    let group = mesh
        .name()
        .map(str::to_string)
        .unwrap_or_else(|| format!("mesh {}", mesh.index()));
    let flip = world.determinant() < 0.0;
    for prim in mesh.primitives() {
        let place = format!("mesh {group:?} primitive {}", prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            notes.push(format!(
                "{place}: {mode:?} ignored (only triangles make surfaces)"
            ));
            continue;
        }
        let (positions, triangles) = primitive_triangles(path, &prim, buffers, &place)?;
        let positions: Vec<Vec3> = positions
            .into_iter()
            .map(|p| world.transform_point3(p))
            .collect();
        let material = match prim.material().index() {
            Some(m) => m,
            None => default,
        };
        for (k, t) in triangles.iter().enumerate() {
            let mut vertices =
                t.iter()
                    .map(|&i| {
                        positions.get(i as usize).map(|p| p.as_dvec3()).ok_or(
                            Error::IndexOutOfRange {
                                index_kind: "vertex",
                                index: i64::from(i),
                                len: positions.len(),
                                place: format!("{} {place} triangle {k}", path.display()),
                            },
                        )
                    })
                    .collect::<Result<Vec<_>, _>>()?;
            if flip {
                vertices.swap(1, 2);
            }
            desc.polygons.push(PolygonDesc {
                name: format!("{group}/prim {}/tri {k}", prim.index()),
                vertices,
                material,
                grid: PatchGrid::Size(patch_size),
                group: Some(group.clone()),
                obstruction: false,
                two_sided: false,
            });
        }
    }
    Ok(())
}

/// A triangle strip's triangles: the i-th is (v_i, v_i+1, v_i+2), its odd ones turned
/// (v_i+1, v_i, v_i+2), so that all keep the strip's winding (glTF 2.0, 3.7.2.1).
fn strip_triangles(indices: &[u32]) -> Vec<[u32; 3]> {
    (2..indices.len())
        .map(|k| {
            let (a, b, c) = (indices[k - 2], indices[k - 1], indices[k]);
            if k % 2 == 1 {
                [b, a, c]
            } else {
                [a, b, c]
            }
        })
        .collect()
}

/// The bytes of every buffer: the GLB's BIN chunk, a `data:` URI (base64) or a file
/// beside the glTF.
fn load_buffers(path: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>, Error> {
    let mut out = Vec::new();
    for buffer in gltf.document.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                err(
                    path,
                    format!("buffer {} names a BIN chunk the file lacks", buffer.index()),
                )
            })?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                let (_, b64) = uri.split_once(";base64,").ok_or_else(|| {
                    err(
                        path,
                        format!("buffer {}: a data URI that is not base64", buffer.index()),
                    )
                })?;
                decode_base64(b64).ok_or_else(|| {
                    err(
                        path,
                        format!("buffer {}: bad base64 in its data URI", buffer.index()),
                    )
                })?
            }
            gltf::buffer::Source::Uri(uri) => {
                if uri.contains("://") || uri.contains("..") || uri.starts_with('/') {
                    return Err(err(
                        path,
                        format!(
                            "buffer {}: {uri:?} is not a relative file beside the glTF",
                            buffer.index()
                        ),
                    ));
                }
                let file = path
                    .parent()
                    .unwrap_or(Path::new("."))
                    .join(percent_decode(uri));
                std::fs::read(&file).map_err(|source| Error::Io { path: file, source })?
            }
        };
        if data.len() < buffer.length() {
            return Err(err(
                path,
                format!(
                    "buffer {} has {} bytes of the {} it declares (truncated)",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// A URI's %XX escapes decoded (an invalid escape is kept as it is).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut k = 0;
    while k < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match (
            b[k],
            b.get(k + 1).copied().and_then(hex),
            b.get(k + 2).copied().and_then(hex),
        ) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                k += 3;
            }
            (c, _, _) => {
                out.push(c);
                k += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648, with or without padding); `None` on any other character.
pub(crate) fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let text = text.trim_end_matches('=');
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_strip_keeps_its_winding() {
        // A quad strip: (0,0) (1,0) (0,1) (1,1); both triangles counter-clockwise.
        let p = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let tris = strip_triangles(&[0, 1, 2, 3]);
        assert_eq!(tris.len(), 2);
        for [a, b, c] in tris {
            let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
            let z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            assert!(z > 0.0, "{a:?} {b:?} {c:?}");
        }
    }

    #[test]
    fn base64_and_percent_escapes_decode() {
        assert_eq!(decode_base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(decode_base64("aGVsbG8").unwrap(), b"hello");
        assert!(decode_base64("a$b").is_none());
        assert_eq!(percent_decode("my%20mesh.bin"), "my mesh.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }
}
