//! Parsing of command-line values: resolutions, patch lists, reflectances and sizes.

use crate::Error;
use rad_core::{PatchId, Rgb};

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

/// A reflectance of one value (grey) or three (R, G, B), each in [0, 1).
pub fn reflectance_of(values: &[f64]) -> Result<Rgb, Error> {
    checked_reflectance(values, &format!("{values:?}"))
}

/// `"0.5"` or `"0.1,0.2,0.3"` → [`reflectance_of`] those numbers.
pub fn parse_reflectance(text: &str) -> Result<Rgb, Error> {
    let values: Vec<f64> = text
        .split(',')
        .map(|c| c.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            Error::Setting(format!(
                "--reflectance {text:?}: expected R or R,G,B (numbers)"
            ))
        })?;
    checked_reflectance(&values, &format!("{text:?}"))
}

/// [`reflectance_of`], its errors showing the value as `shown`.
fn checked_reflectance(values: &[f64], shown: &str) -> Result<Rgb, Error> {
    let rgb = match *values {
        [r] => [r; 3],
        [r, g, b] => [r, g, b],
        _ => {
            return Err(Error::Setting(format!(
                "--reflectance {shown}: expected 1 or 3 numbers"
            )))
        }
    };
    if !rgb.iter().all(|c| (0.0..1.0).contains(c)) {
        return Err(Error::Setting(format!(
            "--reflectance {shown}: each value must be in [0, 1)"
        )));
    }
    Ok(Rgb(rgb))
}

/// Bytes from `"123"`, `"900M"`, `"1.5G"` (suffixes K, M, G, T: powers of 1024; a
/// trailing `B` or `iB` allowed), for `--memory-limit`.
pub fn parse_size(text: &str) -> Result<usize, Error> {
    let t = text.trim();
    let (num, unit) = match t.char_indices().find(|(_, c)| c.is_ascii_alphabetic()) {
        Some((k, _)) => (&t[..k], t[k..].to_ascii_uppercase()),
        None => (t, String::new()),
    };
    let scale: f64 = match unit.trim_end_matches("IB").trim_end_matches('B') {
        "" => 1.0,
        "K" => 1024.0,
        "M" => 1024.0 * 1024.0,
        "G" => 1024.0 * 1024.0 * 1024.0,
        "T" => 1024.0f64.powi(4),
        _ => {
            return Err(Error::Setting(format!(
                "--memory-limit {text:?}: unknown unit (use K, M, G or T)"
            )))
        }
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * scale < usize::MAX as f64 => {
            Ok((v * scale) as usize)
        }
        _ => Err(Error::Setting(format!(
            "--memory-limit {text:?}: not a positive size (say 900M or 1.5G)"
        ))),
    }
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

    #[test]
    fn reflectances_parse_or_are_refused_by_value() {
        assert_eq!(parse_reflectance("0.25").unwrap().0, [0.25; 3]);
        assert_eq!(
            parse_reflectance("0.1, 0.2,0.3").unwrap().0,
            [0.1, 0.2, 0.3]
        );
        for bad in ["1", "-0.1", "0.1,0.2", "x", "nan"] {
            let e = parse_reflectance(bad).unwrap_err().to_string();
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
        assert!(reflectance_of(&[0.2, 0.3]).is_err());
        assert_eq!(reflectance_of(&[0.5]).unwrap().0, [0.5; 3]);
    }

    #[test]
    fn sizes_parse_in_powers_of_1024() {
        assert_eq!(parse_size("900M").unwrap(), 900 << 20);
        assert_eq!(parse_size("1.5G").unwrap(), 1536 << 20);
        assert_eq!(parse_size("2 GiB").unwrap(), 2 << 30);
        assert_eq!(parse_size("4096").unwrap(), 4096);
        for bad in ["0", "-1G", "1X", "G", "nan"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
