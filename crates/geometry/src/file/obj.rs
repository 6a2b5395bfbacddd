//! OBJ/MTL scenes through tobj: each face is a polygon, Kd is the reflectance and Ke the
//! emission; the patch grid comes from a target patch size.

use crate::error::Error;
use crate::scene::{Material, PatchGrid, PolygonDesc, SceneDesc};
use glam::DVec3;
use rad_core::Rgb;
use std::path::Path;

/// Reads an OBJ file and its MTL libraries. Faces are kept as polygons (not triangulated);
/// faces with no material take the default one (`reflectance`, else 0.5 grey).
pub fn load_obj(
    path: &Path,
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let obj_err = |message: String| Error::Obj {
        path: path.to_path_buf(),
        message,
    };
    if let Err(source) = std::fs::metadata(path) {
        return Err(Error::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ..Default::default()
    };
    let (models, mtl) =
        tobj::load_obj(path, &options).map_err(|e| obj_err(format!("cannot parse OBJ: {e}")))?;
    obj_desc(path, &models, mtl, patch_size, reflectance)
}

/// OBJ text in memory (no MTL library is read: a `mtllib` line is an error), for
/// in-memory callers and the fuzz harness; errors name `path`.
pub fn obj_from_bytes(
    path: &Path,
    bytes: &[u8],
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let options = tobj::LoadOptions {
        triangulate: false,
        single_index: false,
        ..Default::default()
    };
    let mut reader = std::io::Cursor::new(bytes);
    let (models, mtl) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| Error::Obj {
        path: path.to_path_buf(),
        message: format!("cannot parse OBJ: {e}"),
    })?;
    obj_desc(path, &models, mtl, patch_size, reflectance)
}

/// The scene of tobj's models and materials.
fn obj_desc(
    path: &Path,
    models: &[tobj::Model],
    mtl: Result<Vec<tobj::Material>, tobj::LoadError>,
    patch_size: f64,
    reflectance: Option<Rgb>,
) -> Result<SceneDesc, Error> {
    let obj_err = |message: String| Error::Obj {
        path: path.to_path_buf(),
        message,
    };
    let obj_materials = mtl.map_err(|e| obj_err(format!("cannot load its MTL: {e}")))?;
    let mut materials: Vec<Material> = obj_materials
        .iter()
        .map(|m| Material {
            name: m.name.clone(),
            reflectance: Rgb(m.diffuse.unwrap_or([0.5; 3]).map(f64::from)),
            emission: Rgb(m.emissive.unwrap_or([0.0; 3]).map(f64::from)),
        })
        .collect();
    let mut default_material = None;
    let mut polygons = Vec::new();
    for model in models {
        let mesh = &model.mesh;
        let n_faces = if mesh.face_arities.is_empty() {
            mesh.indices.len() / 3
        } else {
            mesh.face_arities.len()
        };
        let material = match mesh.material_id {
            Some(id) if id < materials.len() => id,
            Some(id) => {
                return Err(Error::IndexOutOfRange {
                    index_kind: "material",
                    index: id as i64,
                    len: materials.len(),
                    place: format!("object {:?}", model.name),
                })
            }
            None => *default_material.get_or_insert_with(|| {
                materials.push(super::mesh::default_material(reflectance));
                materials.len() - 1
            }),
        };
        let mut start = 0usize;
        for face in 0..n_faces {
            let arity = if mesh.face_arities.is_empty() {
                3
            } else {
                mesh.face_arities[face] as usize
            };
            let idx = mesh
                .indices
                .get(start..start + arity)
                .ok_or_else(|| obj_err("truncated face list".into()))?;
            let vertices = idx
                .iter()
                .map(|&i| {
                    let i = i as usize;
                    mesh.positions
                        .get(3 * i..3 * i + 3)
                        .map(|p| DVec3::new(p[0], p[1], p[2]))
                        .ok_or_else(|| Error::IndexOutOfRange {
                            index_kind: "vertex",
                            index: i as i64,
                            len: mesh.positions.len() / 3,
                            place: format!("object {:?} face {face}", model.name),
                        })
                })
                .collect::<Result<Vec<_>, _>>()?;
            polygons.push(PolygonDesc {
                name: format!("{}/face {face}", model.name),
                vertices,
                material,
                grid: PatchGrid::Size(patch_size),
                group: Some(model.name.clone()),
                obstruction: false,
                two_sided: false,
            });
            start += arity;
        }
    }
    Ok(SceneDesc {
        materials,
        polygons,
        camera: None,
    })
}
