//! Parsing of command-line values: resolutions and patch lists.

use crate::Error;
use rad_core::PatchId;

/// `"180x720"` → (180, 720). Both must be ≥ 1; the hemisphere checks the upper limit.
pub fn parse_resolution(s: &str) -> Result<(u32, u32), Error> {
    let bad = |reason: &str| Error::Parse {
        what: "resolution",
        input: s.to_string(),
        reason: reason.to_string(),
    };
    let (a, b) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| bad("expected N_THETAxN_PHI, e.g. 180x720"))?;
    let n = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|e| bad(&format!("{t:?} is not a count ({e})")))
    };
    let (nt, np) = (n(a)?, n(b)?);
    if nt == 0 || np == 0 {
        return Err(bad("both counts must be at least 1"));
    }
    Ok((nt, np))
}

/// `"3,17,40-59"` or `"all"` → sorted, deduplicated patch ids, each below `n_patches`.
pub fn parse_patch_list(s: &str, n_patches: usize) -> Result<Vec<PatchId>, Error> {
    let bad = |reason: String| Error::Parse {
        what: "patch list",
        input: s.to_string(),
        reason,
    };
    if s.trim() == "all" {
        return Ok((0..n_patches as PatchId).collect());
    }
    let num = |t: &str| {
        t.trim()
            .parse::<u64>()
            .map_err(|e| bad(format!("{t:?} is not a patch id ({e})")))
    };
    let mut out = Vec::new();
    for part in s.split(',') {
        let (a, b) = match part.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None => (num(part)?, num(part)?),
        };
        if a > b {
            return Err(bad(format!("range {a}-{b} is empty")));
        }
        if b >= n_patches as u64 {
            return Err(bad(format!(
                "patch {b} is out of range (the scene has {n_patches} patches)"
            )));
        }
        out.extend(a as PatchId..=b as PatchId);
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolutions() {
        assert_eq!(parse_resolution("180x720").unwrap(), (180, 720));
        assert!(parse_resolution("0x720").is_err());
        assert!(parse_resolution("180").is_err());
        assert!(parse_resolution("axb").is_err());
        assert!(parse_resolution("99999999999x2").is_err());
    }

    #[test]
    fn patch_lists() {
        assert_eq!(
            parse_patch_list("3,17,40-42,3", 100).unwrap(),
            vec![3, 17, 40, 41, 42]
        );
        assert_eq!(parse_patch_list("all", 3).unwrap(), vec![0, 1, 2]);
        assert!(parse_patch_list("5-2", 100).is_err());
        assert!(parse_patch_list("100", 100).is_err());
        assert!(parse_patch_list("x", 100).is_err());
    }
}
