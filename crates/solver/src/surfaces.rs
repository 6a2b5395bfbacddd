//! What the solvers know of each patch: area, emission and reflectance.

use crate::Error;
use rad_core::PatchId;

/// What the solvers need to know of each patch: area, emission (radiosity units) and
/// reflectance, per RGB channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Surfaces {
    pub area: Vec<f64>,
    pub emission: Vec<[f64; 3]>,
    pub reflectance: Vec<[f64; 3]>,
}

impl Surfaces {
    /// Checks the lengths against `n` and the values: areas finite and > 0, emission
    /// finite and >= 0, reflectance in [0, 1).
    pub fn validate(&self, n: usize) -> Result<(), Error> {
        check_areas(&self.area, n)?;
        for (what, len) in [
            ("emissions", self.emission.len()),
            ("reflectances", self.reflectance.len()),
        ] {
            if len != n {
                return Err(Error::LengthMismatch {
                    what,
                    len,
                    n_patches: n,
                });
            }
        }
        for i in 0..n {
            let e = self.emission[i];
            if !e.iter().all(|c| c.is_finite() && *c >= 0.0) {
                return Err(Error::BadSurface {
                    patch: i as PatchId,
                    what: "emission",
                    value: e,
                    rule: "each channel finite and >= 0",
                });
            }
            let r = self.reflectance[i];
            if !r.iter().all(|c| c.is_finite() && (0.0..1.0).contains(c)) {
                return Err(Error::BadSurface {
                    patch: i as PatchId,
                    what: "reflectance",
                    value: r,
                    rule: "each channel in [0, 1)",
                });
            }
        }
        Ok(())
    }
}

/// Checks one finite area > 0 a patch, `n` patches.
pub(crate) fn check_areas(area: &[f64], n: usize) -> Result<(), Error> {
    if area.len() != n {
        return Err(Error::LengthMismatch {
            what: "areas",
            len: area.len(),
            n_patches: n,
        });
    }
    if let Some((i, &a)) = area
        .iter()
        .enumerate()
        .find(|(_, a)| !(a.is_finite() && **a > 0.0))
    {
        return Err(Error::BadSurface {
            patch: i as PatchId,
            what: "area",
            value: [a; 3],
            rule: "must be finite and > 0",
        });
    }
    Ok(())
}
