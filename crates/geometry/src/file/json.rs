//! The project's JSON scene format (documented in the README).

use crate::error::{Error, PolygonProblem};
use crate::scene::{Camera, Material, PatchGrid, PolygonDesc, SceneDesc};
use glam::{DVec3, Vec3};
use rad_core::Rgb;
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileScene {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    description: Option<String>,
    /// Default target patch size for polygons that give no grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    patch_size: Option<f64>,
    materials: Vec<FileMaterial>,
    /// Shared vertex list, for polygons given by `indices`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    vertices: Vec<[f64; 3]>,
    polygons: Vec<FilePolygon>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    camera: Option<FileCamera>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMaterial {
    name: String,
    reflectance: [f64; 3],
    #[serde(default)]
    emission: [f64; 3],
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePolygon {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    material: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    vertices: Option<Vec<[f64; 3]>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    indices: Option<Vec<i64>>,
    /// Patch grid `[nu, nv]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    patches: Option<[u64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    patch_size: Option<f64>,
    /// The surface it belongs to (`coherad viewfactors --by group`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    group: Option<String>,
    /// Blocks rays but gets no view factors (`coherad viewfactors`: no row, no column).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    obstruction: bool,
    /// Seen, lit and shading from both sides: two back-to-back polygons, the second
    /// named `NAME:back` (see [`PolygonDesc::two_sided`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    two_sided: bool,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileCamera {
    position: [f64; 3],
    look_at: [f64; 3],
    up: [f64; 3],
    fov_y_deg: f64,
}

fn vec3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn arr(v: DVec3) -> [f64; 3] {
    v.to_array().map(|c| {
        // A value that is an f32 (as a scene built in f32 gives) through its shortest
        // decimal form as an f32, which reads back as that f32; any other as an f64's:
        // both round-trip exactly.
        let f = c as f32;
        if f64::from(f) == c {
            f.to_string()
                .parse::<f64>()
                .expect("a float formats as a float")
        } else {
            c
        }
    })
}

/// Parses our JSON scene format. `default_patch_size` applies to polygons that give no
/// grid when the file gives no `patch_size` either.
///
/// Syntax errors (and truncated files) come back as [`Error::Json`] with the line and
/// column; the path is filled in by the caller.
pub fn scene_desc_from_json(
    text: &str,
    default_patch_size: Option<f64>,
) -> Result<SceneDesc, Error> {
    let file: FileScene = serde_json::from_str(text).map_err(|e| Error::Json {
        path: Default::default(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    let materials: Vec<Material> = file
        .materials
        .iter()
        .map(|m| Material {
            name: m.name.clone(),
            reflectance: Rgb(m.reflectance),
            emission: Rgb(m.emission),
        })
        .collect();
    let mut polygons = Vec::with_capacity(file.polygons.len());
    for (idx, p) in file.polygons.into_iter().enumerate() {
        let name = p.name.clone().unwrap_or_else(|| format!("polygon {idx}"));
        let fail = |problem| Error::Polygon {
            polygon: idx,
            name: name.clone(),
            problem,
        };
        let material = materials
            .iter()
            .position(|m| m.name == p.material)
            .ok_or_else(|| {
                fail(PolygonProblem::UnknownMaterial {
                    name: p.material.clone(),
                })
            })?;
        let vertices: Vec<DVec3> = match (&p.vertices, &p.indices) {
            (Some(v), None) => v.iter().copied().map(DVec3::from_array).collect(),
            (None, Some(ix)) => ix
                .iter()
                .map(|&i| {
                    usize::try_from(i)
                        .ok()
                        .and_then(|u| file.vertices.get(u))
                        .copied()
                        .map(DVec3::from_array)
                        .ok_or_else(|| Error::IndexOutOfRange {
                            index_kind: "vertex",
                            index: i,
                            len: file.vertices.len(),
                            place: format!("polygon {idx} ({name:?})"),
                        })
                })
                .collect::<Result<_, _>>()?,
            _ => {
                return Err(Error::Json {
                    path: Default::default(),
                    line: 0,
                    column: 0,
                    message: format!(
                    "polygon {idx} ({name:?}) must give exactly one of \"vertices\" or \"indices\""
                ),
                })
            }
        };
        let grid = match (p.patches, p.patch_size.or(file.patch_size).or(default_patch_size)) {
            (Some([nu, nv]), _) => PatchGrid::Cells { nu, nv },
            (None, Some(size)) => PatchGrid::Size(size),
            (None, None) => {
                return Err(Error::Json {
                    path: Default::default(),
                    line: 0,
                    column: 0,
                    message: format!(
                        "polygon {idx} ({name:?}) has no patch grid: give \"patches\": [nu, nv] or \"patch_size\" (or --patch-size)"
                    ),
                })
            }
        };
        polygons.push(PolygonDesc {
            name,
            vertices,
            material,
            grid,
            group: p.group,
            obstruction: p.obstruction,
            two_sided: p.two_sided,
        });
    }
    let camera = file.camera.map(|c| Camera {
        position: vec3(c.position),
        look_at: vec3(c.look_at),
        up: vec3(c.up),
        fov_y: c.fov_y_deg.to_radians() as f32,
    });
    Ok(SceneDesc {
        materials,
        polygons,
        camera,
    })
}

/// Writes a description in our JSON format (vertices inline, grids as given).
pub fn scene_desc_to_json(desc: &SceneDesc, description: Option<&str>) -> String {
    let file = FileScene {
        description: description.map(str::to_string),
        patch_size: None,
        materials: file_materials(desc),
        vertices: Vec::new(),
        polygons: desc
            .polygons
            .iter()
            .map(|p| {
                let (patches, patch_size) = match p.grid {
                    PatchGrid::Cells { nu, nv } => (Some([nu, nv]), None),
                    PatchGrid::Size(s) => (None, Some(s)),
                };
                FilePolygon {
                    name: Some(p.name.clone()),
                    material: desc.materials[p.material].name.clone(),
                    vertices: Some(p.vertices.iter().copied().map(arr).collect()),
                    indices: None,
                    patches,
                    patch_size,
                    group: p.group.clone(),
                    obstruction: p.obstruction,
                    two_sided: p.two_sided,
                }
            })
            .collect(),
        camera: file_camera(desc),
    };
    let mut s = serde_json::to_string_pretty(&file).expect("a scene always serialises");
    s.push('\n');
    s
}

/// Writes a description of many small polygons compactly in our JSON format: one
/// shared vertex list (each distinct vertex once) with polygons by `indices`, without
/// names (a polygon is then named by its index), one vertex or polygon a line.
pub fn scene_desc_to_json_indexed(desc: &SceneDesc, description: Option<&str>) -> String {
    let mut index: std::collections::HashMap<[u64; 3], usize> = Default::default();
    let mut vertices: Vec<[f64; 3]> = Vec::new();
    let mut polygons = Vec::with_capacity(desc.polygons.len());
    for p in &desc.polygons {
        let indices = p
            .vertices
            .iter()
            .map(|v| {
                *index
                    .entry(v.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        vertices.push(arr(*v));
                        vertices.len() - 1
                    }) as i64
            })
            .collect();
        let (patches, patch_size) = match p.grid {
            PatchGrid::Cells { nu, nv } => (Some([nu, nv]), None),
            PatchGrid::Size(s) => (None, Some(s)),
        };
        polygons.push(FilePolygon {
            name: None,
            material: desc.materials[p.material].name.clone(),
            vertices: None,
            indices: Some(indices),
            patches,
            patch_size,
            group: p.group.clone(),
            obstruction: p.obstruction,
            two_sided: p.two_sided,
        });
    }
    let mut s = String::from("{\n");
    if let Some(d) = description {
        s += &format!("\"description\": {},\n", line(d));
    }
    s += &format!("\"materials\": {},\n", line(&file_materials(desc)));
    let list = |items: Vec<String>| items.join(",\n");
    s += &format!(
        "\"vertices\": [\n{}\n],\n",
        list(vertices.iter().map(|v| line(v)).collect())
    );
    s += &format!(
        "\"polygons\": [\n{}\n]",
        list(polygons.iter().map(|p| line(p)).collect())
    );
    if let Some(camera) = file_camera(desc) {
        s += &format!(",\n\"camera\": {}", line(&camera));
    }
    s += "\n}\n";
    s
}

/// One value as compact JSON.
fn line<T: Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).expect("a scene always serialises")
}

fn file_materials(desc: &SceneDesc) -> Vec<FileMaterial> {
    desc.materials
        .iter()
        .map(|m| FileMaterial {
            name: m.name.clone(),
            reflectance: m.reflectance.0,
            emission: m.emission.0,
        })
        .collect()
}

fn file_camera(desc: &SceneDesc) -> Option<FileCamera> {
    desc.camera.map(|c| FileCamera {
        position: arr(c.position.as_dvec3()),
        look_at: arr(c.look_at.as_dvec3()),
        up: arr(c.up.as_dvec3()),
        fov_y_deg: (c.fov_y as f64).to_degrees(),
    })
}
