//! A scene as loaded from its file, with a fingerprint of what it is, so that a
//! solution is only ever read back against the very scene it was made for.

use crate::Error;
use rad_geometry::file::{load, LoadConfig, View3dControl};
use rad_geometry::{Repair, Scene, SceneDesc, Triangulation};
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
    /// What `--repair` changed (`repaired`), or for a mesh file without it what it
    /// would change.
    pub repair: Repair,
    pub repaired: bool,
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
            repair: Repair::default(),
            repaired: false,
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
        SceneFile::load_keeping(path, config, false).map(|(s, _)| s)
    }

    /// [`SceneFile::load_with`], and the description the scene was built from where
    /// `keep` says so (what a motion moves).
    pub fn load_keeping(
        path: &Path,
        config: &LoadConfig,
        keep: bool,
    ) -> Result<(SceneFile, Option<SceneDesc>), Error> {
        if let Err(source) = std::fs::metadata(path) {
            return Err(Error::Io {
                action: "read",
                path: path.to_path_buf(),
                source,
            });
        }
        if let Some(weld) = config.weld.filter(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(Error::Setting(format!(
                "weld distance {weld}: give a finite distance >= 0 (--weld)"
            )));
        }
        if config.weld.is_some() && !config.repair {
            return Err(Error::Setting(
                "a weld distance (--weld) is a setting of --repair, which is off".into(),
            ));
        }
        let loaded = load(path, config)?;
        let kept = keep.then(|| loaded.desc.clone());
        let scene = Scene::new(loaded.desc).map_err(|e| rad_geometry::Error::InFile {
            path: path.to_path_buf(),
            source: Box::new(e),
        })?;
        let hash = fingerprint(&scene);
        let file = SceneFile {
            path: path.to_path_buf(),
            scene,
            hash,
            view3d: loaded.view3d,
            triangulation: loaded.triangulation,
            repair: loaded.repair,
            repaired: config.repair,
            notes: loaded.notes,
        };
        Ok((file, kept))
    }

    /// What loading did that a person should hear of, in order: what `--triangulate`
    /// split and dropped, what `--repair` changed (or, without it, the defects it would
    /// mend, as a warning naming the flag), and the readers' notes.
    pub fn load_notes(&self) -> Vec<LoadNote> {
        let note = |text: String| LoadNote {
            warning: false,
            text,
        };
        let warn = |text: String| LoadNote {
            warning: true,
            text,
        };
        let mut out = Vec::new();
        let t = &self.triangulation;
        if t.split > 0 {
            out.push(note(format!(
                "split {} concave or warped faces into {} triangles",
                t.split, t.triangles
            )));
        }
        if t.dropped > 0 {
            out.push(warn(format!(
                "dropped {} degenerate faces or pieces (first: {})",
                t.dropped,
                t.first_dropped.as_deref().unwrap_or("?")
            )));
        }
        out.extend(
            repair_notes(&self.repair, self.repaired)
                .into_iter()
                .map(|(warning, text)| LoadNote { warning, text }),
        );
        out.extend(self.notes.iter().cloned().map(note));
        out
    }

    /// The fingerprint as solution files store it: `fnv1a64:` and 16 hex digits.
    pub fn hash_text(&self) -> String {
        format!("fnv1a64:{:016x}", self.hash)
    }
}

/// One thing loading did, for a note or a warning.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadNote {
    pub warning: bool,
    pub text: String,
}

/// The notes of a repair (`repaired`) or of a survey: (is a warning, text).
fn repair_notes(r: &Repair, repaired: bool) -> Vec<(bool, String)> {
    let first = if r.examples.is_empty() {
        String::new()
    } else {
        format!("; first: {}", r.examples.join("; "))
    };
    let counts = [
        (r.flipped, "turned over"),
        (r.duplicates, "dropped as duplicates"),
        (r.folded, "dropped as folded onto a coplanar neighbour"),
        (r.collapsed, "dropped as collapsed by welding"),
    ]
    .iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, what)| format!("{} {what}", count(*n, "face")))
    .collect::<Vec<_>>()
    .join(", ");
    let mut out = Vec::new();
    if repaired {
        let mut pieces = format!("{}, {} closed", count(r.pieces, "piece"), r.closed);
        if r.enclosures > 0 {
            pieces += &format!(" ({} enclosing the scene, so facing inward)", r.enclosures);
        }
        let welded = if r.welded > 0 {
            format!(
                "; {} welded (within {:.3e})",
                count(r.welded, "vertex position"),
                r.weld_tolerance
            )
        } else {
            String::new()
        };
        let changed = if counts.is_empty() {
            "no face changed".to_string()
        } else {
            counts
        };
        out.push((
            false,
            format!("repaired: {changed}{welded}; {pieces}{first}"),
        ));
    } else if r.flipped + r.dropped() > 0 {
        out.push((
            true,
            format!("--repair would mend this mesh: {counts}{first}"),
        ));
    }
    if r.unorientable > 0 {
        out.push((
            true,
            format!(
                "{} joined faces that no orientation makes consistent (a one-sided piece, such as a Möbius band): some faces show their backs",
                count(r.unorientable, "shared edge")
            ),
        ));
    }
    out
}

/// `n` and `what`, plural unless `n` is 1.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
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
