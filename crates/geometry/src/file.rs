//! Scene files: the project's JSON format (read and written) and OBJ/MTL through tobj.
//! This module is the only place in the workspace that reads scene files.

mod json;
mod obj;
mod vs3;

pub use json::{scene_desc_from_json, scene_desc_to_json, scene_desc_to_json_indexed};
pub use obj::load_obj;
pub use vs3::{load_vs3, vs3_from_text, View3dControl, VS3_DEFAULT_GRID};

use crate::error::Error;
use crate::scene::{Scene, SceneDesc};
use std::path::Path;

/// Reads a scene file, by extension: `.json` (our format), `.obj` (with its MTL) or
/// `.vs3` (View3D's input).
///
/// `patch_size` sets the patch grid of OBJ polygons, and of JSON polygons that give
/// neither `patches` nor `patch_size` (nor a file-wide `patch_size`).
pub fn load_scene(path: &Path, patch_size: Option<f64>) -> Result<Scene, Error> {
    let desc = load_scene_desc(path, patch_size)?;
    Scene::new(desc).map_err(|e| Error::InFile {
        path: path.to_path_buf(),
        source: Box::new(e),
    })
}

/// Reads a scene file into an unvalidated description (see [`load_scene`]).
pub fn load_scene_desc(path: &Path, patch_size: Option<f64>) -> Result<SceneDesc, Error> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "json" => {
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
        "obj" => {
            let size = patch_size.unwrap_or(DEFAULT_OBJ_PATCH_SIZE_HINT);
            load_obj(path, size)
        }
        "vs3" => load_vs3(path, patch_size).map(|(desc, _)| desc),
        _ => Err(Error::UnknownFormat {
            path: path.to_path_buf(),
            ext,
        }),
    }
}

/// Patch size used for OBJ files when none is given: NaN, which scene validation
/// rejects with a message asking for `--patch-size`.
const DEFAULT_OBJ_PATCH_SIZE_HINT: f64 = f64::NAN;
