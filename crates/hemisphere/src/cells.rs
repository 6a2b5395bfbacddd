//! Hemisphere cells: uniform in θ and φ, with their delta form factors and ray directions.

use crate::Error;
use glam::Vec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Largest number of cells (N_θ · N_φ) a hemisphere may have: 2²⁶ cells already need
/// 512 MiB of item buffer per thread.
pub const MAX_CELLS: u64 = 1 << 26;

/// How a cell's delta form factor is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeltaRule {
    /// The exact integral of `cosθ sinθ dθ dφ / π` over the cell (sums to 1 exactly).
    Exact,
    /// The report's midpoint form `cosθ sinθ ΔθΔφ / π` (sums to 1 only to O(Δθ²)).
    Midpoint,
}

/// Settings of a hemisphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HemisphereConfig {
    pub n_theta: u32,
    pub n_phi: u32,
    pub delta: DeltaRule,
    /// Turns the φ grid by this fraction of a sector (0 for the standard grid; 0.5 gives
    /// an equally valid second hemisphere, used to measure sampling noise).
    pub phi_shift: f64,
}

impl HemisphereConfig {
    /// The standard grid: exact delta form factors, no shift.
    pub fn exact(n_theta: u32, n_phi: u32) -> HemisphereConfig {
        HemisphereConfig {
            n_theta,
            n_phi,
            delta: DeltaRule::Exact,
            phi_shift: 0.0,
        }
    }
}

/// A discretised hemisphere: cell `(i, j)` spans θ ∈ [iΔθ, (i+1)Δθ), φ ∈ [(j+s)Δφ,
/// (j+1+s)Δφ) with s the φ shift; its ray goes through the cell's centre. Cells are
/// stored ring by ring: index `i·N_φ + j`.
#[derive(Clone, Debug)]
pub struct Hemisphere {
    config: HemisphereConfig,
    /// Local direction of each cell's ray (x along the patch's t axis, z along n).
    dirs: Vec<Vec3>,
    /// Delta form factor of each ring (every cell of a ring has the same one).
    ring_ff: Vec<f64>,
}

impl Hemisphere {
    pub fn new(config: HemisphereConfig) -> Result<Hemisphere, Error> {
        let (nt, np) = (config.n_theta as u64, config.n_phi as u64);
        if nt == 0 || np == 0 {
            return Err(Error::Resolution {
                n_theta: nt,
                n_phi: np,
                reason: "both counts must be at least 1".into(),
            });
        }
        if nt * np > MAX_CELLS {
            return Err(Error::Resolution {
                n_theta: nt,
                n_phi: np,
                reason: format!("{} cells is over the limit of {MAX_CELLS}", nt * np),
            });
        }
        if !(config.phi_shift.is_finite() && (0.0..1.0).contains(&config.phi_shift)) {
            return Err(Error::PhiShift {
                shift: config.phi_shift,
            });
        }
        let d_theta = FRAC_PI_2 / nt as f64;
        let d_phi = 2.0 * PI / np as f64;
        let ring_ff = delta_form_factors(config.n_theta, config.n_phi, config.delta);
        let mut dirs = Vec::with_capacity((nt * np) as usize);
        for i in 0..nt {
            let theta = (i as f64 + 0.5) * d_theta;
            let (st, ct) = theta.sin_cos();
            for j in 0..np {
                let phi = (j as f64 + 0.5 + config.phi_shift) * d_phi;
                let (sp, cp) = phi.sin_cos();
                dirs.push(Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32));
            }
        }
        Ok(Hemisphere {
            config,
            dirs,
            ring_ff,
        })
    }

    pub fn config(&self) -> &HemisphereConfig {
        &self.config
    }
    pub fn n_theta(&self) -> usize {
        self.config.n_theta as usize
    }
    pub fn n_phi(&self) -> usize {
        self.config.n_phi as usize
    }
    pub fn n_cells(&self) -> usize {
        self.dirs.len()
    }
    /// Local ray directions, ring by ring.
    pub fn directions(&self) -> &[Vec3] {
        &self.dirs
    }
    /// Delta form factor of one cell of ring `i`.
    pub fn ring_form_factors(&self) -> &[f64] {
        &self.ring_ff
    }
    /// Δθ = (π/2) / N_θ.
    pub fn d_theta(&self) -> f64 {
        FRAC_PI_2 / self.config.n_theta as f64
    }
    /// Δφ = 2π / N_φ.
    pub fn d_phi(&self) -> f64 {
        2.0 * PI / self.config.n_phi as f64
    }
    /// Polar angle of the centre of ring `i`.
    pub fn theta(&self, i: usize) -> f64 {
        (i as f64 + 0.5) * self.d_theta()
    }
    /// Azimuth of the centre of sector `j` (with the φ shift).
    pub fn phi(&self, j: usize) -> f64 {
        (j as f64 + 0.5 + self.config.phi_shift) * self.d_phi()
    }
    /// The cell containing direction (θ, φ), or None if θ is outside [0, π/2).
    /// φ may be any angle (it is wrapped).
    #[inline]
    pub fn cell_of(&self, theta: f64, phi: f64) -> Option<usize> {
        if !(theta >= 0.0 && theta < FRAC_PI_2) {
            return None;
        }
        let k = ((theta / self.d_theta()) as usize).min(self.n_theta() - 1);
        let l = (phi / self.d_phi() - self.config.phi_shift)
            .floor()
            .rem_euclid(self.n_phi() as f64) as usize;
        Some(k * self.n_phi() + l.min(self.n_phi() - 1))
    }
}

/// Delta form factor of a cell of each ring, for `n_theta` rings of `n_phi` cells.
///
/// With [`DeltaRule::Exact`], `ΔF_i = (sin²θ_{i+1} − sin²θ_i) / N_φ`, which sums to
/// exactly 1 over the hemisphere (the sum over rings telescopes to sin²(π/2) = 1).
pub fn delta_form_factors(n_theta: u32, n_phi: u32, rule: DeltaRule) -> Vec<f64> {
    let d_theta = FRAC_PI_2 / n_theta as f64;
    let d_phi = 2.0 * PI / n_phi as f64;
    (0..n_theta)
        .map(|i| match rule {
            DeltaRule::Exact => {
                let s0 = (i as f64 * d_theta).sin();
                // sin²θ_{i+1}: the last edge is exactly π/2.
                let s1 = if i + 1 == n_theta {
                    1.0
                } else {
                    ((i + 1) as f64 * d_theta).sin()
                };
                (s1 * s1 - s0 * s0) / n_phi as f64
            }
            DeltaRule::Midpoint => {
                let t = (i as f64 + 0.5) * d_theta;
                t.cos() * t.sin() * d_theta * d_phi / PI
            }
        })
        .collect()
}
