//! A scene as loaded from its file, with a fingerprint of what it was made from, so
//! that a solution is only ever read back against the very scene it was made for.

use crate::Error;
use rad_geometry::file::load_scene;
use rad_geometry::Scene;
use std::path::{Path, PathBuf};

/// A scene file, loaded and fingerprinted.
#[derive(Debug)]
pub struct SceneFile {
    pub path: PathBuf,
    pub scene: Scene,
    /// FNV-1a (64 bits) of the file's bytes, then of the patch size it was loaded with
    /// (its bits; nothing when none was given).
    pub hash: u64,
}

impl SceneFile {
    /// Loads `path` (JSON or OBJ), with `patch_size` for polygons that give no grid.
    pub fn load(path: &Path, patch_size: Option<f64>) -> Result<SceneFile, Error> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            action: "read",
            path: path.to_path_buf(),
            source,
        })?;
        let scene = load_scene(path, patch_size)?;
        let mut hash = fnv1a(FNV_OFFSET, &bytes);
        if let Some(s) = patch_size {
            hash = fnv1a(hash, &s.to_bits().to_le_bytes());
        }
        Ok(SceneFile {
            path: path.to_path_buf(),
            scene,
            hash,
        })
    }

    /// The fingerprint as solution files store it: `fnv1a64:` and 16 hex digits.
    pub fn hash_text(&self) -> String {
        format!("fnv1a64:{:016x}", self.hash)
    }
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a over `bytes`, from the state `h`.
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_its_published_values() {
        // The reference vectors of the FNV authors.
        assert_eq!(fnv1a(FNV_OFFSET, b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(FNV_OFFSET, b"foobar"), 0x8594_4171_f739_67e8);
    }
}
