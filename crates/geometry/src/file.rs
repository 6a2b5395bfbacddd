//! Scene files: the project's JSON format (read and written), OBJ/MTL through tobj,
//! View3D's `.vs3`, PLY and STL meshes, and glTF/GLB; a material side file for formats
//! without materials; `--triangulate` for concave and warped faces; `--repair` for
//! meshes' defects.
//! This module is the only place in the workspace that reads scene files.

mod gltf;
mod json;
mod material_map;
mod mesh;
mod obj;
mod vs3;

pub use self::gltf::{
    gltf_from_bytes, gltf_motion, gltf_motion_from_bytes, load_gltf, MAX_GLTF_REFLECTANCE,
};
pub use json::{scene_desc_from_json, scene_desc_to_json, scene_desc_to_json_indexed};
pub use material_map::{apply_material_map, apply_material_text};
pub use mesh::{
    load_ply, load_stl, ply_from_bytes, stl_from_bytes, DEFAULT_MATERIAL, DEFAULT_REFLECTANCE,
};
pub use obj::{load_obj, obj_from_bytes};
pub use vs3::{load_vs3, vs3_from_text, View3dControl, VS3_DEFAULT_GRID};

use crate::error::Error;
use crate::repair::{repair, survey, Repair};
use crate::scene::{Scene, SceneDesc};
use crate::triangulate::{triangulate, Triangulation};
use rad_core::Rgb;
use std::path::{Path, PathBuf};

/// A motion file: a glTF file's node animations (`.gltf`, `.glb`: [`gltf_motion`]), else
/// the JSON motion format ([`crate::Motion::read`]).
pub fn read_motion(path: &Path) -> Result<crate::Motion, Error> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf" | "glb") => gltf_motion(path),
        _ => crate::Motion::read(path),
    }
}

/// The extensions [`load`] reads.
pub const SCENE_EXTENSIONS: &[&str] = &["json", "obj", "vs3", "ply", "stl", "gltf", "glb"];

/// The extensions of mesh files, whose defects a load surveys (see [`Loaded::repair`]).
pub const MESH_EXTENSIONS: &[&str] = &["obj", "ply", "stl", "gltf", "glb"];

/// How a scene file is read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadConfig {
    /// Target patch size of polygons whose file gives no grid (required for OBJ, PLY,
    /// STL and glTF files).
    pub patch_size: Option<f64>,
    /// Split concave and warped faces into triangles, drop degenerate ones.
    pub triangulate: bool,
    /// Reflectance of the default material, for faces that name none.
    pub reflectance: Option<Rgb>,
    /// A material side file ([`apply_material_map`]).
    pub materials: Option<PathBuf>,
    /// Repair the mesh ([`repair`]): weld, drop collapsed, duplicate and folded faces,
    /// orient each piece.
    pub repair: bool,
    /// The welding distance of `repair`, in scene units (default: [`WELD_RELATIVE`] of
    /// the bounding-box diagonal).
    pub weld: Option<f64>,
}

/// A scene file as read, before validation.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub desc: SceneDesc,
    /// A View3D file's control options.
    pub view3d: Option<View3dControl>,
    /// What `--triangulate` did (all zero without it).
    pub triangulation: Triangulation,
    /// With `repair`, what it changed; without, for a mesh file (OBJ, PLY, STL, glTF),
    /// what it would change ([`survey`]); empty otherwise.
    pub repair: Repair,
    /// What was read with a change worth a warning, and what the material file did.
    pub notes: Vec<String>,
}

/// Reads a scene file, by extension (see [`SCENE_EXTENSIONS`]), into a description:
/// the side file's materials applied, then faces triangulated and the mesh repaired if
/// asked.
pub fn load(path: &Path, options: &LoadConfig) -> Result<Loaded, Error> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if !SCENE_EXTENSIONS.contains(&ext.as_str()) {
        return Err(Error::UnknownFormat {
            path: path.to_path_buf(),
            ext,
        });
    }
    if let Err(source) = std::fs::metadata(path) {
        return Err(Error::Io {
            path: path.to_path_buf(),
            source,
        });
    }
    let size = options.patch_size.unwrap_or(PATCH_SIZE_REQUIRED);
    let reflectance = options.reflectance;
    let mut notes = Vec::new();
    let mut view3d = None;
    let mut desc = match ext.as_str() {
        "json" => load_json(path, options.patch_size)?,
        "obj" => load_obj(path, size, reflectance)?,
        "vs3" => {
            let (desc, control) = load_vs3(path, options.patch_size)?;
            view3d = Some(control);
            desc
        }
        "ply" => load_ply(path, size, reflectance)?,
        "stl" => load_stl(path, size, reflectance)?,
        _ => load_gltf(path, size, reflectance, &mut notes)?,
    };
    if let Some(map) = &options.materials {
        notes.extend(apply_material_map(&mut desc, map)?);
    }
    let triangulation = if options.triangulate {
        triangulate(&mut desc)
    } else {
        Triangulation::default()
    };
    let repair = if options.repair {
        repair(&mut desc, options.weld)
    } else if MESH_EXTENSIONS.contains(&ext.as_str()) {
        survey(&desc, options.weld)
    } else {
        Repair::default()
    };
    Ok(Loaded {
        desc,
        view3d,
        triangulation,
        repair,
        notes,
    })
}

/// Reads and validates a scene file with only a patch size (see [`load`]).
pub fn load_scene(path: &Path, patch_size: Option<f64>) -> Result<Scene, Error> {
    let desc = load_scene_desc(path, patch_size)?;
    Scene::new(desc).map_err(|e| Error::InFile {
        path: path.to_path_buf(),
        source: Box::new(e),
    })
}

/// Reads a scene file into an unvalidated description, with only a patch size.
pub fn load_scene_desc(path: &Path, patch_size: Option<f64>) -> Result<SceneDesc, Error> {
    let options = LoadConfig {
        patch_size,
        ..LoadConfig::default()
    };
    load(path, &options).map(|l| l.desc)
}

fn load_json(path: &Path, patch_size: Option<f64>) -> Result<SceneDesc, Error> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    scene_desc_from_json(&text, patch_size).map_err(|e| match e {
        Error::Json {
            line,
            column,
            message,
            ..
        } => Error::Json {
            path: path.to_path_buf(),
            line,
            column,
            message,
        },
        e => Error::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        },
    })
}

/// Patch size used for mesh files when none is given: NaN, which scene validation
/// rejects with a message asking for `--patch-size`.
const PATCH_SIZE_REQUIRED: f64 = f64::NAN;
