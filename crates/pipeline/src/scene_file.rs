//! A scene as loaded from its file, with a fingerprint of what it is, so that a
//! solution is only ever read back against the very scene it was made for.

use crate::Error;
use rad_geometry::file::{load, LoadConfig, View3dControl};
use rad_geometry::{Scene, Triangulation};
use std::path::{Path, PathBuf};

/// A scene file, loaded and fingerprinted.
#[derive(Debug)]
pub struct SceneFile {
    pub path: PathBuf,
    pub scene: Scene,
    /// [`fingerprint`] of the scene as loaded.
    pub hash: u64,
    /// A View3D file's control options (title, `encl`, `emit`, those ignored).
    pub view3d: Option<View3dControl>,
    /// What `--triangulate` did (all zero without it): for a warning.
    pub triangulation: Triangulation,
    /// What was read with a change worth a warning (a clamped glTF reflectance, an
    /// ignored texture), and what the material file assigned.
    pub notes: Vec<String>,
}

impl SceneFile {
    /// A scene built in code, as if loaded from `path` (fingerprinted; no notes).
    pub fn of_scene(path: impl Into<PathBuf>, scene: Scene) -> SceneFile {
        let hash = fingerprint(&scene);
        SceneFile {
            path: path.into(),
            scene,
            hash,
            view3d: None,
            triangulation: Triangulation::default(),
            notes: Vec::new(),
        }
    }

    /// Loads `path` with `patch_size` for polygons that give no grid.
    pub fn load(path: &Path, patch_size: Option<f64>) -> Result<SceneFile, Error> {
        let config = LoadConfig {
            patch_size,
            ..LoadConfig::default()
        };
        SceneFile::load_with(path, &config)
    }

    /// Loads `path` (any format of `rad_geometry::file::SCENE_EXTENSIONS`) as `config`
    /// says, and validates it.
    pub fn load_with(path: &Path, config: &LoadConfig) -> Result<SceneFile, Error> {
        if let Err(source) = std::fs::metadata(path) {
            return Err(Error::Io {
                action: "read",
                path: path.to_path_buf(),
                source,
            });
        }
        let loaded = load(path, config)?;
        let scene = Scene::new(loaded.desc).map_err(|e| rad_geometry::Error::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        })?;
        let hash = fingerprint(&scene);
        Ok(SceneFile {
            path: path.to_path_buf(),
            scene,
            hash,
            view3d: loaded.view3d,
            triangulation: loaded.triangulation,
            notes: loaded.notes,
        })
    }

    /// The fingerprint as solution files store it: `fnv1a64:` and 16 hex digits.
    pub fn hash_text(&self) -> String {
        format!("fnv1a64:{:016x}", self.hash)
    }
}

/// FNV-1a (64 bits) of what a solution depends on: every polygon's vertices (their
/// f32 bits), patch grid and material, every material's reflectance and emission, the
/// patch count. Whatever file it came from (JSON, OBJ and its MTL files) and whatever
/// its names and descriptions say: the same scene gives the same fingerprint, and any
/// change a solution would see (a vertex, a grid from `--patch-size`, a reflectance in
/// an MTL file) gives another.
pub fn fingerprint(scene: &Scene) -> u64 {
    let mut h = FNV_OFFSET;
    let mut put = |bytes: &[u8]| h = fnv1a(h, bytes);
    put(&(scene.patches().len() as u64).to_le_bytes());
    for poly in scene.polygons() {
        put(&(poly.vertices().len() as u32).to_le_bytes());
        for v in poly.vertices() {
            for c in v.to_array() {
                put(&c.to_bits().to_le_bytes());
            }
        }
        let (nu, nv) = poly.grid();
        put(&nu.to_le_bytes());
        put(&nv.to_le_bytes());
        put(&poly.material().to_le_bytes());
    }
    for m in scene.materials() {
        for c in m.reflectance.0.into_iter().chain(m.emission.0) {
            put(&c.to_bits().to_le_bytes());
        }
    }
    h
}

pub(crate) const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a over `bytes`, from the state `h`.
pub(crate) fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use rad_geometry::scenes::cube;

    #[test]
    fn fnv1a_matches_its_published_values() {
        // The reference vectors of the FNV authors.
        assert_eq!(fnv1a(FNV_OFFSET, b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(FNV_OFFSET, b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn the_fingerprint_sees_what_a_solution_depends_on() {
        let base = fingerprint(&Scene::new(cube(2)).unwrap());
        assert_eq!(base, fingerprint(&Scene::new(cube(2)).unwrap()));
        let mut named = cube(2);
        named.polygons[0].name = "another name".into();
        named.materials[0].name = "another material".into();
        assert_eq!(
            base,
            fingerprint(&Scene::new(named).unwrap()),
            "names do not count"
        );
        assert_ne!(
            base,
            fingerprint(&Scene::new(cube(3)).unwrap()),
            "patch grids"
        );
        let mut grey = cube(2);
        grey.materials[0].reflectance.0[1] += 0.01;
        assert_ne!(base, fingerprint(&Scene::new(grey).unwrap()), "reflectance");
        let mut lit = cube(2);
        lit.materials[0].emission.0[0] += 1.0;
        assert_ne!(base, fingerprint(&Scene::new(lit).unwrap()), "emission");
        let mut moved = cube(2);
        for v in &mut moved.polygons[0].vertices {
            *v += glam::DVec3::splat(1e-3);
        }
        assert_ne!(base, fingerprint(&Scene::new(moved).unwrap()), "vertices");
    }
}
