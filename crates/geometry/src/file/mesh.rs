//! Triangle and polygon meshes without materials of their own: PLY (ASCII and binary,
//! through `ply-rs-bw`) and STL (ASCII and binary, through `stl_io`). Every face is a
//! polygon of the default material (`LoadConfig::reflectance`, else 0.5 grey); a
//! material side file (`--materials`) names emitters and other materials.

use crate::error::Error;
use crate::scene::{Material, PatchGrid, PolygonDesc, SceneDesc};
use glam::{DVec3, Vec3};
use rad_core::Rgb;
use std::path::Path;

/// Name of the material given to faces with none.
pub const DEFAULT_MATERIAL: &str = "(default)";

/// Reflectance of [`DEFAULT_MATERIAL`] when `--reflectance` gives none.
pub const DEFAULT_REFLECTANCE: f64 = 0.5;

/// A scene of faces of one default material, grouped by `group`.
pub(crate) struct MeshBuilder {
    pub desc: SceneDesc,
    patch_size: f64,
}

impl MeshBuilder {
    pub fn new(patch_size: f64, reflectance: Option<Rgb>) -> MeshBuilder {
        MeshBuilder {
            desc: SceneDesc {
                materials: vec![default_material(reflectance)],
                polygons: Vec::new(),
                camera: None,
            },
            patch_size,
        }
    }

    pub fn face(&mut self, name: String, vertices: Vec<DVec3>, material: usize, group: &str) {
        self.desc.polygons.push(PolygonDesc {
            name,
            vertices,
            material,
            grid: PatchGrid::Size(self.patch_size),
            group: Some(group.to_string()),
            obstruction: false,
            two_sided: false,
        });
    }
}

/// The material of faces that name none.
pub(crate) fn default_material(reflectance: Option<Rgb>) -> Material {
    Material {
        name: DEFAULT_MATERIAL.to_string(),
        reflectance: reflectance.unwrap_or(Rgb([DEFAULT_REFLECTANCE; 3])),
        emission: Rgb::BLACK,
    }
}

fn mesh_err(path: &Path, format: &'static str, message: impl Into<String>) -> Error {
    Error::Mesh {
        path: path.to_path_buf(),
        format,
        message: message.into(),
    }
}

/// Reads an STL file (ASCII or binary): each facet a triangle, in the file's vertex
/// order (the facet normal is not read: the winding gives the front side).
pub fn load_stl(
    path: &Path,
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    stl_from_bytes(path, &bytes, patch_size, reflectance)
}

/// An STL file in memory (see [`load_stl`]); errors name `path`.
pub fn stl_from_bytes(
    path: &Path,
    bytes: &[u8],
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let len = bytes.len() as u64;
    let declared = (bytes.len() >= 84).then(|| {
        u64::from(u32::from_le_bytes([
            bytes[80], bytes[81], bytes[82], bytes[83],
        ]))
    });
    let binary_size = declared.map(|n| 84 + 50 * n);
    let ascii =
        bytes.len() >= 5 && bytes[..5].eq_ignore_ascii_case(b"solid") && binary_size != Some(len);
    if !ascii {
        let Some(size) = binary_size else {
            return Err(mesh_err(
                path,
                "STL",
                format!("is {len} bytes long: a binary STL file has an 84-byte header"),
            ));
        };
        if size != len {
            return Err(mesh_err(
                path,
                "STL",
                format!(
                    "binary STL header gives {} facets, which take {size} bytes, but the file has {len} (truncated, or not an STL file)",
                    declared.unwrap_or(0)
                ),
            ));
        }
    }
    let mut mesh = MeshBuilder::new(patch_size, reflectance);
    let group = stem(path);
    if !ascii {
        // Binary: 50 bytes a facet (normal, three vertices, attribute), the size checked.
        for (k, rec) in bytes[84..].chunks_exact(50).enumerate() {
            let f = |i: usize| f32::from_le_bytes([rec[i], rec[i + 1], rec[i + 2], rec[i + 3]]);
            let vertices = (0..3)
                .map(|v| Vec3::new(f(12 + 12 * v), f(16 + 12 * v), f(20 + 12 * v)).as_dvec3())
                .collect();
            mesh.face(format!("{group}/facet {k}"), vertices, 0, &group);
        }
        return Ok(mesh.desc);
    }
    // ASCII, through stl_io, whose reader wants the file to open with "solid " exactly:
    // give it that whatever the case and spacing of ours.
    let mut text = b"solid ".to_vec();
    text.extend_from_slice(&bytes[5..]);
    let mut reader = std::io::Cursor::new(text);
    let triangles = stl_io::create_stl_reader(&mut reader)
        .map_err(|e| mesh_err(path, "STL", format!("cannot parse ASCII STL: {e}")))?;
    for (k, tri) in triangles.enumerate() {
        let tri = tri.map_err(|e| mesh_err(path, "STL", format!("facet {k}: {e}")))?;
        let vertices = tri
            .vertices
            .iter()
            .map(|v| Vec3::from_array(v.0).as_dvec3())
            .collect();
        mesh.face(format!("{group}/facet {k}"), vertices, 0, &group);
    }
    Ok(mesh.desc)
}

/// The file name without its extension, as the group of a mesh's faces.
pub(crate) fn stem(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("mesh")
        .to_string()
}

/// A PLY vertex: its position (float or double `x`, `y`, `z`; every other property
/// ignored).
#[derive(Default)]
struct PlyVertex {
    p: [f64; 3],
    set: u8,
}

impl ply_rs_bw::ply::PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex::default()
    }
    fn set_property(
        &mut self,
        key: &str,
        property: ply_rs_bw::ply::Property,
    ) -> ply_rs_bw::ply::PropertyAccessResult {
        use ply_rs_bw::ply::{Property as P, PropertyAccessResult as R};
        let axis = match key {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return R::Ignored,
        };
        self.p[axis] = match property {
            P::Float(v) => f64::from(v),
            P::Double(v) => v,
            P::Char(v) => f64::from(v),
            P::UChar(v) => f64::from(v),
            P::Short(v) => f64::from(v),
            P::UShort(v) => f64::from(v),
            P::Int(v) => f64::from(v),
            P::UInt(v) => f64::from(v),
            _ => return R::UnsupportedType,
        };
        self.set |= 1 << axis;
        R::Set
    }
}

/// A PLY face: its vertex indices (`vertex_indices` or `vertex_index`, a list of any
/// integer type).
#[derive(Default)]
struct PlyFace {
    indices: Vec<i64>,
    set: bool,
}

impl ply_rs_bw::ply::PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace::default()
    }
    fn set_property(
        &mut self,
        key: &str,
        property: ply_rs_bw::ply::Property,
    ) -> ply_rs_bw::ply::PropertyAccessResult {
        use ply_rs_bw::ply::{Property as P, PropertyAccessResult as R};
        if key != "vertex_indices" && key != "vertex_index" {
            return R::Ignored;
        }
        self.indices = match property {
            P::ListChar(v) => v.into_iter().map(i64::from).collect(),
            P::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            P::ListShort(v) => v.into_iter().map(i64::from).collect(),
            P::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            P::ListInt(v) => v.into_iter().map(i64::from).collect(),
            P::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return R::UnsupportedType,
        };
        self.set = true;
        R::Set
    }
}

/// Any other PLY element: read past, nothing kept.
struct PlyIgnored;

impl ply_rs_bw::ply::PropertyAccess for PlyIgnored {
    fn new() -> Self {
        PlyIgnored
    }
}

/// Reads a PLY file (ASCII or binary, either byte order): its `vertex` element's `x`,
/// `y`, `z` and its `face` element's vertex lists, each face a polygon.
pub fn load_ply(
    path: &Path,
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    ply_from_bytes(path, &bytes, patch_size, reflectance)
}

/// Refuses element counts the file cannot hold: every element takes at least a byte a
/// property (a binary one its scalars' and list counts' bytes), and an element with no
/// property takes none, so a count of it would make that many values out of nothing
/// (a 100-byte file asking for 10^9 vertices).
fn check_ply_counts(header: &ply_rs_bw::ply::Header, bytes: usize) -> Result<(), String> {
    use ply_rs_bw::ply::{Encoding, PropertyType, ScalarType};
    let size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    let binary = !matches!(header.encoding, Encoding::Ascii);
    let mut total = 0usize;
    for (_, e) in &header.elements {
        if e.count > 0 && e.properties.is_empty() {
            return Err(format!(
                "element {:?} has {} entries but no properties",
                e.name, e.count
            ));
        }
        let per: usize = e
            .properties
            .iter()
            .map(|(_, p)| match &p.data_type {
                _ if !binary => 1,
                PropertyType::Scalar(t) => size(t),
                PropertyType::List(count, _) => size(count),
            })
            .sum();
        total = total.saturating_add(e.count.saturating_mul(per));
        if total > bytes {
            return Err(format!(
                "element {:?} has {} entries, more than the file's {bytes} bytes can hold",
                e.name, e.count
            ));
        }
    }
    Ok(())
}

/// A PLY file in memory (see [`load_ply`]); errors name `path`.
pub fn ply_from_bytes(
    path: &Path,
    bytes: &[u8],
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let bytes_hint = bytes.len();
    let source = bytes;
    use ply_rs_bw::parser::{Parser, Reader};
    let err = |m: String| mesh_err(path, "PLY", m);
    let mut reader = Reader::new(std::io::BufReader::new(source));
    let header = Parser::<PlyIgnored>::new()
        .read_header(&mut reader)
        .map_err(|e| err(format!("cannot parse the PLY header: {e}")))?;
    check_ply_counts(&header, bytes_hint).map_err(err)?;
    let mut vertices: Option<Vec<PlyVertex>> = None;
    let mut faces: Option<Vec<PlyFace>> = None;
    for (_, element) in &header.elements {
        let what =
            |e: ply_rs_bw::parser::ParseError| err(format!("element {:?}: {e}", element.name));
        match element.name.as_str() {
            "vertex" => {
                vertices = Some(
                    Parser::<PlyVertex>::new()
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(what)?,
                )
            }
            "face" => {
                faces = Some(
                    Parser::<PlyFace>::new()
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(what)?,
                )
            }
            _ => {
                Parser::<PlyIgnored>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(what)?;
            }
        }
    }
    let vertices = vertices.ok_or_else(|| err("has no vertex element".into()))?;
    let faces =
        faces.ok_or_else(|| err("has no face element (a point cloud is not a scene)".into()))?;
    if let Some(k) = vertices.iter().position(|v| v.set != 0b111) {
        return Err(err(format!("vertex {k} lacks one of x, y, z")));
    }
    let mut mesh = MeshBuilder::new(patch_size, reflectance);
    let group = stem(path);
    for (k, face) in faces.iter().enumerate() {
        if !face.set {
            return Err(err(format!("face {k} has no vertex_indices list")));
        }
        let polygon = face
            .indices
            .iter()
            .map(|&i| {
                usize::try_from(i)
                    .ok()
                    .and_then(|i| vertices.get(i))
                    .map(|v| DVec3::from_array(v.p))
                    .ok_or(Error::IndexOutOfRange {
                        index_kind: "vertex",
                        index: i,
                        len: vertices.len(),
                        place: format!("{} face {k}", path.display()),
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        mesh.face(format!("{group}/face {k}"), polygon, 0, &group);
    }
    Ok(mesh.desc)
}
