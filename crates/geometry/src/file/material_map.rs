//! The material side file (`--materials FILE.json`): materials for mesh formats that
//! have none (PLY, STL), or that override a file's own by name, and rules assigning them
//! to faces by index range or by a box:
//!
//! ```json
//! {
//!   "materials": [
//!     {"name": "lamp", "reflectance": [0, 0, 0], "emission": [20, 20, 20]},
//!     {"name": "(default)", "reflectance": [0.7, 0.7, 0.7]}
//!   ],
//!   "assign": [
//!     {"material": "lamp", "faces": [0, 2]},
//!     {"material": "lamp", "inside": {"min": [-0.2, 0.99, -0.2], "max": [0.2, 1.01, 0.2]}}
//!   ]
//! }
//! ```
//!
//! `faces` is a half-open range of face numbers in file order (before `--triangulate`);
//! `inside` takes every face whose vertices all lie in the box. Later rules win. A rule
//! that matches no face is an error, so a lamp misplaced by a typo is not silently dark.

use crate::error::Error;
use crate::scene::{Material, SceneDesc};
use rad_core::Rgb;
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    #[serde(default)]
    materials: Vec<MapMaterial>,
    #[serde(default)]
    assign: Vec<Rule>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MapMaterial {
    name: String,
    reflectance: [f64; 3],
    #[serde(default)]
    emission: [f64; 3],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Rule {
    material: String,
    #[serde(default)]
    faces: Option<[u64; 2]>,
    #[serde(default)]
    inside: Option<Bounds>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Bounds {
    min: [f64; 3],
    max: [f64; 3],
}

/// Applies the material side file at `map_path` to `desc`; returns one note a rule (how
/// many faces it took).
pub fn apply_material_map(desc: &mut SceneDesc, map_path: &Path) -> Result<Vec<String>, Error> {
    let text = std::fs::read_to_string(map_path).map_err(|source| Error::Io {
        path: map_path.to_path_buf(),
        source,
    })?;
    apply_material_text(desc, &text, map_path)
}

/// A material side file's text (see [`apply_material_map`]); errors name `map_path`.
pub fn apply_material_text(
    desc: &mut SceneDesc,
    text: &str,
    map_path: &Path,
) -> Result<Vec<String>, Error> {
    let fail = |message: String| Error::MaterialFile {
        path: map_path.to_path_buf(),
        message,
    };
    let map: MapFile = serde_json::from_str(text).map_err(|e| Error::Json {
        path: map_path.to_path_buf(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
    })?;
    for m in map.materials {
        let material = Material {
            name: m.name.clone(),
            reflectance: Rgb(m.reflectance),
            emission: Rgb(m.emission),
        };
        match desc.materials.iter_mut().find(|x| x.name == m.name) {
            Some(x) => *x = material,
            None => desc.materials.push(material),
        }
    }
    let mut notes = Vec::new();
    for (k, rule) in map.assign.iter().enumerate() {
        let material = desc
            .materials
            .iter()
            .position(|m| m.name == rule.material)
            .ok_or_else(|| {
                fail(format!(
                    "assign rule {k} names material {:?}, which neither file defines",
                    rule.material
                ))
            })?;
        let n = desc.polygons.len() as u64;
        let mut taken = 0usize;
        match (&rule.faces, &rule.inside) {
            (Some([a, b]), None) => {
                if !(a < b && *b <= n) {
                    return Err(fail(format!("assign rule {k}: faces [{a}, {b}) is not a non-empty range within the {n} faces")));
                }
                for p in &mut desc.polygons[*a as usize..*b as usize] {
                    p.material = material;
                    taken += 1;
                }
            }
            (None, Some(bounds)) => {
                let inside = |v: &glam::DVec3| {
                    (0..3).all(|i| bounds.min[i] <= v[i] && v[i] <= bounds.max[i])
                };
                for p in desc
                    .polygons
                    .iter_mut()
                    .filter(|p| p.vertices.iter().all(inside))
                {
                    p.material = material;
                    taken += 1;
                }
            }
            _ => {
                return Err(fail(format!(
                    "assign rule {k} must give exactly one of \"faces\" and \"inside\""
                )))
            }
        }
        if taken == 0 {
            return Err(fail(format!(
                "assign rule {k} (material {:?}) matches no face",
                rule.material
            )));
        }
        notes.push(format!(
            "material {:?} given to {taken} faces (assign rule {k})",
            rule.material
        ));
    }
    Ok(notes)
}
