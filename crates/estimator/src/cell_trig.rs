//! Per-cell trigonometry of a hemisphere, computed once: the directions of the points
//! a splat moves, the cell edges they land between, and the f32 lookups of a
//! direction's cell (the polynomial angles, corrected against the edges).

use rad_hemisphere::Hemisphere;

/// Per-cell trigonometry of a hemisphere and its cell boundaries, computed once: the
/// directions of the source points splatted, and the grid they are splatted into. With
/// a stride s > 1 the grid is s × s times coarser (cells of s × s of the hemisphere's)
/// and the source point of its cell (I, J) is in the direction of the hemisphere's cell
/// (sI, sJ) (see [`splat`]).
#[derive(Clone, Debug)]
pub(crate) struct CellTrig {
    /// Directions of the source points: θ by ring, φ by sector (of this grid).
    pub theta: Vec<f32>,
    pub st: Vec<f32>,
    pub ct: Vec<f32>,
    pub phi: Vec<f32>,
    /// φ by sector in f64 (to turn the source points into another polygon's frame).
    pub phi64: Vec<f64>,
    pub sp: Vec<f32>,
    pub cp: Vec<f32>,
    /// cos² of ring edges: ring k holds cos²θ in (cos2_edge[k + 1], cos2_edge[k]].
    pub cos2_edge: Vec<f32>,
    /// First guess of the ring holding cos²θ = (t + ½) / len, corrected by `cos2_edge`.
    pub ring_of_c2: Vec<u16>,
    /// (cos, sin) of sector edges: sector l spans [edge l, edge l + 1).
    pub phi_edge: Vec<[f32; 2]>,
    pub inv_d_theta: f32,
    pub inv_d_phi: f32,
    /// Δφ of this grid, in f64.
    pub d_phi: f64,
    pub shift: f32,
    pub n_theta: usize,
    pub n_phi: usize,
    /// The source point's position within its cell, in cells (both ways): ½ / s.
    pub src_pos: f32,
    /// The stride s, and the smaller of the cells' angular sizes.
    pub stride: usize,
    pub min_cell: f64,
}

impl CellTrig {
    pub fn new(hemi: &Hemisphere) -> CellTrig {
        CellTrig::strided(hemi, 1)
    }

    /// The tables of the grid s times coarser both ways (`stride` must divide N_θ and
    /// N_φ).
    pub fn strided(hemi: &Hemisphere, stride: usize) -> CellTrig {
        assert!(
            stride >= 1
                && hemi.n_theta().is_multiple_of(stride)
                && hemi.n_phi().is_multiple_of(stride),
            "the stride divides the resolution"
        );
        let (n_theta, n_phi) = (hemi.n_theta() / stride, hemi.n_phi() / stride);
        let (d_theta, d_phi) = (stride as f64 * hemi.d_theta(), stride as f64 * hemi.d_phi());
        let theta: Vec<f64> = (0..n_theta).map(|i| hemi.theta(stride * i)).collect();
        let phi: Vec<f64> = (0..n_phi).map(|j| hemi.phi(stride * j)).collect();
        let f = |v: &[f64], g: fn(f64) -> f64| v.iter().map(|&x| g(x) as f32).collect::<Vec<f32>>();
        // Sector J spans the hemisphere's sectors sJ .. sJ + s: from (sJ + shift) Δφ.
        let shift = hemi.config().phi_shift / stride as f64;
        CellTrig {
            st: f(&theta, f64::sin),
            ct: f(&theta, f64::cos),
            sp: f(&phi, f64::sin),
            cp: f(&phi, f64::cos),
            cos2_edge: (0..=n_theta)
                .map(|k| {
                    if k == n_theta {
                        0.0
                    } else {
                        (k as f64 * d_theta).cos().powi(2) as f32
                    }
                })
                .collect(),
            ring_of_c2: (0..RING_TABLE)
                .map(|t| {
                    let c2 = (t as f64 + 0.5) / RING_TABLE as f64;
                    ((c2.sqrt().acos() / d_theta) as usize).min(n_theta - 1) as u16
                })
                .collect(),
            phi_edge: (0..=n_phi)
                .map(|l| {
                    let a = (l as f64 + shift) * d_phi;
                    [a.cos() as f32, a.sin() as f32]
                })
                .collect(),
            theta: theta.iter().map(|&x| x as f32).collect(),
            phi: phi.iter().map(|&x| x as f32).collect(),
            phi64: phi,
            inv_d_theta: (1.0 / d_theta) as f32,
            inv_d_phi: (1.0 / d_phi) as f32,
            d_phi,
            shift: shift as f32,
            n_theta,
            n_phi,
            src_pos: (0.5 / stride as f64) as f32,
            stride,
            min_cell: d_theta.min(d_phi),
        }
    }

    pub fn n_cells(&self) -> usize {
        self.n_theta * self.n_phi
    }

    /// The sector of azimuth `phi` (any finite angle): without divisions or libm calls
    /// for φ in [0, 6π), the range of the splat's angles.
    #[inline(always)]
    pub fn sector_of(&self, phi: f32) -> usize {
        self.sector_of_x(phi * self.inv_d_phi - self.shift)
    }

    /// The sector of coordinate `x = φ / Δφ − shift`.
    #[inline(always)]
    pub fn sector_of_x(&self, x: f32) -> usize {
        let n = self.n_phi;
        if x >= 0.0 && x < (3 * n) as f32 {
            // Truncation is floor here; at most two turns to take off.
            // SAFETY: x is finite and in [0, 3n), within u32's range.
            let mut l = unsafe { x.to_int_unchecked::<u32>() } as usize;
            for _ in 0..2 {
                l = if l >= n { l - n } else { l };
            }
            l.min(n - 1)
        } else {
            // Rare (a first-order move of over a turn, or φ just below 0 with a shift).
            ((x.floor() as i64).rem_euclid(n as i64) as usize).min(n - 1)
        }
    }

    /// The cell holding direction `q`, exactly (table and polynomial first guesses,
    /// corrected against the cell edges), with `r2 = |q|²`; None if `q` is not above the
    /// plane.
    #[inline(always)]
    pub fn cell_of_vector(&self, q: [f32; 3], r2: f32) -> Option<usize> {
        if !(q[2] > 0.0) {
            return None;
        }
        let c2 = q[2] * q[2] / r2;
        // (Unfused: this runs outside the kernels compiled with FMA, where `mul_add` is a
        // libm call, and its first guess is corrected against the cell edges whatever its
        // last bits.)
        let x = atan2_approx::<false>(q[1], q[0]) * self.inv_d_phi - self.shift;
        Some(self.cell_from_parts(q, c2, x))
    }

    /// The cell of direction `q` (above the plane) from `c2 = cos²θ` and a first guess
    /// `x` of its sector coordinate `φ / Δφ − shift`: ring by table, sector by `x`, each
    /// corrected against the cell edges.
    #[inline(always)]
    pub fn cell_from_parts(&self, q: [f32; 3], c2: f32, x: f32) -> usize {
        // c2 is in [0, 1] (a NaN, from a point at C2 itself, goes to 0 by `max`).
        let t = (c2 * RING_TABLE as f32)
            .max(0.0)
            .min((RING_TABLE - 1) as f32);
        // SAFETY: t is finite and in [0, RING_TABLE − 1].
        let k = self.ring_of_c2[unsafe { t.to_int_unchecked::<u32>() } as usize] as usize;
        self.cell_near(q, c2, k, self.sector_of_x(x))
    }

    /// The cell of direction `q` (above the plane), with `c2 = cos²θ`, from a first
    /// guess (ring `k`, sector `l`) a few sectors off at most, corrected against the
    /// cell edges: ring k holds cos²θ in (cos2_edge[k + 1], cos2_edge[k]], sector l
    /// the directions on or after edge l and before edge l + 1.
    #[inline(always)]
    pub fn cell_near(&self, q: [f32; 3], c2: f32, mut k: usize, mut l: usize) -> usize {
        while k > 0 && c2 > self.cos2_edge[k] {
            k -= 1;
        }
        while k + 1 < self.n_theta && c2 <= self.cos2_edge[k + 1] {
            k += 1;
        }
        // Corrections: q must lie on or after edge l and before edge l + 1.
        let cross = |e: [f32; 2]| e[0] * q[1] - e[1] * q[0];
        for _ in 0..4 {
            if cross(self.phi_edge[l]) < 0.0 {
                l = if l == 0 { self.n_phi - 1 } else { l - 1 };
            } else if cross(self.phi_edge[l + 1]) >= 0.0 {
                l = if l + 1 == self.n_phi { 0 } else { l + 1 };
            } else {
                break;
            }
        }
        k * self.n_phi + l
    }
}

/// Size of [`CellTrig::ring_of_c2`].
pub(crate) const RING_TABLE: usize = 1 << 14;

/// atan2 in [0, 2π) to about 1.3e-7 rad from the polynomial (a near-minimax fit by
/// Chebyshev interpolation of atan(√t)/√t on [0, 1], degree 7 in t = z², by octant),
/// plus the f32 roundings of the octant arithmetic (under 1e-6 rad in all), without
/// branches, so that a ring's worth vectorises; 0 for (0, 0).
///
/// `FUSED` evaluates the polynomial by fused multiply-adds (`mul_add`: for the builds with
/// an FMA instruction), else by separate products and sums.
#[inline(always)]
pub(crate) fn atan2_approx<const FUSED: bool>(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI, TAU};
    let (ax, ay) = (x.abs(), y.abs());
    // (Compares rather than `min`/`max`, whose NaN rules cost three instructions each:
    // a NaN gives a NaN or an angle, either way a rough cell its callers discard.)
    let lo = if ax < ay { ax } else { ay };
    let hi = if ax < ay { ay } else { ax };
    let z = if hi > 0.0 { lo / hi } else { 0.0 };
    let z2 = z * z;
    const C: [f32; 8] = [
        -0.004_559_792,
        0.023_780_52,
        -0.058_829_75,
        0.098_688_65,
        -0.140_032_9,
        0.199_669_62,
        -0.333_318_13,
        0.999_999_9,
    ];
    let mut p = C[0];
    for &c in &C[1..] {
        p = if FUSED { p.mul_add(z2, c) } else { p * z2 + c };
    }
    let mut a = z * p;
    a = if ay > ax { FRAC_PI_2 - a } else { a };
    a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 {
        TAU - a
    } else {
        a
    }
}

#[cfg(test)]
mod tests;
