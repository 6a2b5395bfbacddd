//! The report's estimation: reproject every point of H1 to H2 (z-buffered), then fill
//! the holes.

use crate::config::{EstimatorConfig, HoleFill, Reprojection, ThresholdTest};
use crate::reproject::Motion;
use crate::source::SourceHemisphere;
use rad_core::{with_isa, Isa, PatchId, HOLE};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, ItemBuffer};

/// An estimated hemisphere: what each cell of H2 sees, with the holes that were filled.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    pub items: ItemBuffer,
    /// Cells nothing landed in (before filling), and their share of the form factor.
    pub holes: usize,
    pub hole_ff: f64,
}

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
            inv_d_theta: (1.0 / d_theta) as f32,
            inv_d_phi: (1.0 / d_phi) as f32,
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
const RING_TABLE: usize = 1 << 14;

/// atan2 in [0, 2π) to about 1.3e-7 rad from the polynomial (a near-minimax fit by
/// Chebyshev interpolation of atan(√t)/√t on [0, 1], degree 7 in t = z², by octant),
/// plus the f32 roundings of the octant arithmetic (under 1e-6 rad in all), without
/// branches, so that a ring's worth vectorises; 0 for (0, 0).
///
/// `FUSED` evaluates the polynomial by fused multiply-adds (`mul_add`: for the builds with
/// an FMA instruction), else by separate products and sums.
#[inline(always)]
fn atan2_approx<const FUSED: bool>(y: f32, x: f32) -> f32 {
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

/// What a ring's pass needs besides the ring's distances.
struct RingParams {
    st: f32,
    ct: f32,
    near_limit: f32,
    fi0: f32,
    kd: f32,
    inv_st: f32,
    d: [f32; 3],
    n: usize,
    n_theta: usize,
    inv_d_theta: f32,
    inv_d_phi: f32,
    shift: f32,
    /// Whether the rough fast path may be used, and its margins in cells (θ, φ).
    fast: bool,
    margin_k: f32,
    margin_l: f32,
    /// `COT_MARGIN` in cells of θ: the θ margin grows by it times cot θ.
    cot_k: f32,
}

/// Per-sector inputs of a ring's pass (motion-dependent, the same for every ring).
struct SectorTerms<'a> {
    ka: &'a [f32],
    kb: &'a [f32],
    jc: &'a [f32],
    a: &'a [f32],
    cp: &'a [f32],
    sp: &'a [f32],
}

/// A ring's pass output: each point's cell (or `NOWHERE`, or its rough cell with the
/// `UNSURE` bit where the exact path must correct it) and the squared distance the
/// z-buffer compares.
struct RingOut<'a> {
    dest: &'a mut [u32],
    dist2: &'a mut [f32],
}

/// Destinations of a ring's points, branch-free so that it vectorises. First order:
/// θ index `i + ½ − (cosθ a_j − sinθ d_z) / (R Δθ)`, φ index `j + ½ − b_j / (R sinθ Δφ)`;
/// a point that fails the threshold test, crosses the pole or moves over half a turn
/// takes the exact path, `q = R ω − d`: its rough cell, from the polynomial angles
/// alone, is off by one cell for points within about 1e-6 rad of a cell edge. A point
/// at infinity stays in its cell, `ring + j`.
///
/// With `ROUGH` every point gets its rough cell on the exact path. Without, only where
/// both angles lie over `EDGE_MARGIN` rad from every edge (ten times the polynomial's
/// error; never at resolutions finer than `FAST_PATH_MIN_CELL`); the other points get
/// their rough cell with the `UNSURE` bit, for [`exact_path_cell`] to correct.
///
/// Without `FIRST` no point takes the first-order path (for rings where none is far
/// enough): the same answers, without computing it.
///
/// `FUSED` evaluates the angle polynomial by fused multiply-adds (in the builds with an
/// FMA instruction, and only without `ROUGH`): a rough cell's last bits change, but not
/// which cells are sure (the polynomial's error stays far inside `EDGE_MARGIN`) nor, after
/// [`exact_path_cell`], any answer; rough mode's answers are its rough cells, so it
/// never fuses, and every build gives it the same bits.
#[inline(always)]
fn ring_pass_body<const ROUGH: bool, const FIRST: bool, const FUSED: bool>(
    r: &[f32],
    t: &SectorTerms,
    p: &RingParams,
    ring: u32,
    out: RingOut,
) {
    let n = p.n;
    let (r, ka, kb, jc, a, cp, sp) = (
        &r[..n],
        &t.ka[..n],
        &t.kb[..n],
        &t.jc[..n],
        &t.a[..n],
        &t.cp[..n],
        &t.sp[..n],
    );
    let (dest, dist2) = (&mut out.dest[..n], &mut out.dist2[..n]);
    let (nf, ntf) = (n as f32, p.n_theta as f32);
    let d = p.d;
    for j in 0..n {
        let r = r[j];
        let inv_r = 1.0 / r;
        let fi = p.fi0 - (p.ct * ka[j] - p.kd) * inv_r;
        let fj = jc[j] - kb[j] * p.inv_st * inv_r;
        let r1 = r - (p.st * a[j] + p.ct * d[2]);
        let ok = FIRST && (r > p.near_limit) & (fi >= 0.0) & (fj > -0.5 * nf) & (fj < 1.5 * nf);
        let below = fi >= ntf;
        // Clamped in f32 (`max` drops NaN) so that truncation is in range; cells out
        // of range are already marked by `ok` and `below`.
        let fi_c = fi.max(-1.0).min(ntf);
        let fj_c = (fj + nf).max(0.0).min(3.0 * nf);
        // SAFETY: both are finite and within i32's range.
        let ki = unsafe { fi_c.to_int_unchecked::<i32>() };
        let mut kj = unsafe { fj_c.to_int_unchecked::<i32>() } - n as i32;
        kj += if kj < 0 { n as i32 } else { 0 };
        kj -= if kj >= n as i32 { n as i32 } else { 0 };
        let cell = (ki as u32).wrapping_mul(n as u32).wrapping_add(kj as u32);
        // Exact: q = R ω − d (as `exact_path_cell` computes it).
        let rs = r * p.st;
        let q0 = rs * cp[j] - d[0];
        let q1 = rs * sp[j] - d[1];
        let q2 = r * p.ct - d[2];
        let r2 = q0 * q0 + q1 * q1 + q2 * q2;
        let x = atan2_approx::<FUSED>(q1, q0) * p.inv_d_phi - p.shift;
        // Rough cell: θ = atan2(|q_xy|, q_z), sector from x (wrapped once each way).
        let rho = (q0 * q0 + q1 * q1).sqrt();
        let th = atan2_approx::<FUSED>(rho, q2) * p.inv_d_theta;
        let th_c = th.max(0.0).min(ntf - 1.0);
        let x_c = (x + nf).max(0.0).min(3.0 * nf);
        // SAFETY: finite and in range after the clamps (`max` drops NaN).
        let rk = unsafe { th_c.to_int_unchecked::<i32>() };
        let mut rl = unsafe { x_c.to_int_unchecked::<i32>() } - n as i32;
        rl += if rl < 0 { n as i32 } else { 0 };
        rl -= if rl >= n as i32 { n as i32 } else { 0 };
        let rough_cell = if q2 > 0.0 {
            (rk as u32).wrapping_mul(n as u32).wrapping_add(rl as u32)
        } else {
            NOWHERE
        };
        let sure = ROUGH || {
            // SAFETY: x_c is finite and in range (as above); `as` would saturate, which
            // does not vectorise.
            let xl = unsafe { x_c.to_int_unchecked::<i32>() };
            let (fk, fl) = (th_c - rk as f32, x_c - xl as f32);
            // θ clear of both ring edges by margin_k + cot_k cot θ, cot θ = q2 / ρ
            // (multiplied out: false at the pole, ρ = 0).
            let kq = p.cot_k * q2;
            p.fast
                & ((fk - p.margin_k) * rho > kq)
                & ((1.0 - fk - p.margin_k) * rho > kq)
                & (fl > p.margin_l)
                & (fl < 1.0 - p.margin_l)
                & (th < ntf - 1.0)
        };
        let first_order = if below { NOWHERE } else { cell };
        let finite = r.is_finite();
        dest[j] = match (ok, finite, sure) {
            (true, _, _) => first_order,
            (false, true, true) => rough_cell,
            (false, true, false) => {
                if rough_cell == NOWHERE {
                    NOWHERE
                } else {
                    rough_cell | UNSURE
                }
            }
            (false, false, _) => ring + j as u32,
        };
        dist2[j] = match (ok, finite) {
            (true, _) => r1 * r1,
            (false, true) => r2,
            (false, false) => f32::INFINITY,
        };
    }
}

/// The exact cell of point `j` of a ring that [`ring_pass_body`] left `UNSURE` with
/// its rough cell `rough` (so q is above the plane): the same `q` (to the bit), the
/// rough cell (at most a cell off each way) corrected against the cell edges.
#[inline]
fn exact_path_cell(
    trig: &CellTrig,
    r: f32,
    t: &SectorTerms,
    p: &RingParams,
    j: usize,
    rough: u32,
) -> u32 {
    let rs = r * p.st;
    let q0 = rs * t.cp[j] - p.d[0];
    let q1 = rs * t.sp[j] - p.d[1];
    let q2 = r * p.ct - p.d[2];
    let r2 = q0 * q0 + q1 * q1 + q2 * q2;
    let rough = rough as usize;
    let (k, l) = (rough / trig.n_phi, rough % trig.n_phi);
    trig.cell_near([q0, q1, q2], q2 * q2 / r2, k, l) as u32
}

/// [`ring_pass_body`] compiled for `isa` (checked against the CPU). The AVX2 and
/// AVX-512 builds (8 and 16 lanes) perform the same IEEE operations in the same order
/// (no contraction into FMA), but for the fused angle polynomial without `ROUGH`, so
/// the same answers as the baseline build (the same bits in rough mode; the same cells
/// once corrected otherwise).
fn ring_pass_with<const ROUGH: bool, const FIRST: bool>(
    isa: Isa,
    r: &[f32],
    t: &SectorTerms,
    p: &RingParams,
    ring: u32,
    out: RingOut,
) {
    with_isa!(isa, |ISA| if ROUGH || ISA == Isa::Base {
        ring_pass_body::<ROUGH, FIRST, false>(r, t, p, ring, out)
    } else {
        ring_pass_body::<ROUGH, FIRST, true>(r, t, p, ring, out)
    })
}

/// [`ring_pass_body`] compiled for `isa` (one this CPU has), `first` telling whether any
/// point may take the first-order path (`false` only where none is beyond
/// `p.near_limit`).
#[allow(clippy::too_many_arguments)]
fn ring_pass(
    isa: Isa,
    rough: bool,
    first: bool,
    r: &[f32],
    t: &SectorTerms,
    p: &RingParams,
    ring: u32,
    out: RingOut,
) {
    match (rough, first) {
        (true, true) => ring_pass_with::<true, true>(isa, r, t, p, ring, out),
        (true, false) => ring_pass_with::<true, false>(isa, r, t, p, ring, out),
        (false, true) => ring_pass_with::<false, true>(isa, r, t, p, ring, out),
        (false, false) => ring_pass_with::<false, false>(isa, r, t, p, ring, out),
    }
}

/// The motion from `from`'s centre to `to`'s, in their polygon's frame.
pub(crate) fn motion(scene: &Scene, from: PatchId, to: PatchId) -> Motion {
    let (a, b) = (
        &scene.patches()[from as usize],
        &scene.patches()[to as usize],
    );
    let frame = scene.polygons()[a.polygon as usize].frame();
    let d = frame.local_from_world(b.center - a.center);
    Motion::new([d.x as f64, d.y as f64, d.z as f64])
}

/// The points a splat moves, one per cell of its grid (see [`splat`]).
pub(crate) struct Points<'a> {
    pub dist: &'a [f32],
    /// What a cell records for each point.
    pub values: &'a [PatchId],
    /// H1's cell of each point, whose boundary list goes with it (empty: the same cell).
    pub cells: &'a [u32],
    /// (point, value): values that go where a point goes, not z-buffered, by point.
    pub extras: &'a [(u32, PatchId)],
    /// The largest of `dist` in each ring of the grid.
    pub ring_max: &'a [f32],
}

/// Splats `points` (and the boundary lists of `src` that go with them) into `ids` (and
/// their distances into `dist`, where given), cells of `trig`'s grid, as seen from
/// C1 + `m`, the nearest winning (the lower value on ties); cells nothing lands in are
/// `HOLE` (at distance ∞). `z` is working memory. The point of cell c is in the
/// direction of the grid's cell c as seen from H1 (with a stride s, that of H1's cell
/// (sI, sJ)) at `points.dist[c]`; its cell records `points.values[c]`, and a
/// boundary-list entry `id` records `value(id)`.
/// `extras` gets each of `points.extras` with the cell its point lands in. Points at
/// infinity (escaped rays) do not move.
#[allow(clippy::too_many_arguments)]
pub(crate) fn splat(
    trig: &CellTrig,
    src: &SourceHemisphere,
    m: &Motion,
    config: &EstimatorConfig,
    rough: bool,
    points: Points,
    value: impl Fn(PatchId) -> PatchId,
    ids: &mut Vec<PatchId>,
    dist: Option<&mut Vec<f32>>,
    z: &mut ZBuffer,
    extras: &mut Vec<(u32, PatchId)>,
) {
    // (Its own passes compiled for the CPU's widest set: the ring pass is chosen apart.)
    with_isa!(Isa::detect(), |ISA| splat_body(
        ISA, trig, src, m, config, rough, points, value, ids, dist, z, extras,
    ))
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn splat_body(
    isa: Isa,
    trig: &CellTrig,
    src: &SourceHemisphere,
    m: &Motion,
    config: &EstimatorConfig,
    rough: bool,
    points: Points,
    value: impl Fn(PatchId) -> PatchId,
    ids: &mut Vec<PatchId>,
    dist: Option<&mut Vec<f32>>,
    z: &mut ZBuffer,
    extras: &mut Vec<(u32, PatchId)>,
) {
    extras.clear();
    let n_phi = trig.n_phi;
    let n_cells = trig.n_cells();
    // The z-buffer, a key a cell (and a last one, where points that leave the hemisphere
    // go): the squared distance's bits (ordered as the non-negative f32 are) above the
    // value the cell records, so that the smallest key is the nearest point, the lower
    // value on ties (which makes the answer independent of the order of the writes).
    let keys = &mut z.keys;
    keys.clear();
    keys.resize(n_cells + 1, EMPTY);
    let d = [m.d[0] as f32, m.d[1] as f32, m.d[2] as f32];
    let len = m.len as f32;
    // Per sector: d·(cosφ, sinφ, 0) and d·(−sinφ, cosφ, 0), for the first-order formulas.
    let a: Vec<f32> = (0..n_phi)
        .map(|j| d[0] * trig.cp[j] + d[1] * trig.sp[j])
        .collect();
    let b: Vec<f32> = (0..n_phi)
        .map(|j| -d[0] * trig.sp[j] + d[1] * trig.cp[j])
        .collect();
    let (threshold, lateral) = match config.reprojection {
        Reprojection::Exact => (f32::INFINITY, true),
        Reprojection::FirstOrder { test, threshold } => {
            (threshold as f32, test == ThresholdTest::Lateral)
        }
    };
    // Two passes a ring: destinations (independent, so the CPU overlaps them), then the
    // z-buffered writes. The z-buffer holds squared distances until the end.
    let mut dest = vec![NOWHERE; n_phi];
    let mut dist2 = vec![0.0f32; n_phi];
    let project = |i: usize, j: usize, r: f32| -> (u32, f32) {
        let (st, ct) = (trig.st[i], trig.ct[i]);
        let far_scale = if lateral {
            st
        } else if st >= 0.05 {
            1.0
        } else {
            0.0
        };
        if !r.is_finite() {
            ((i * n_phi + j) as u32, f32::INFINITY)
        } else if r * far_scale > threshold * len {
            // First order (1), Δ = −d: θ' = θ + Δ·e_θ / R, φ' = φ + Δ·e_φ / (R sinθ).
            let mut t2 = trig.theta[i] - (ct * a[j] - st * d[2]) / r;
            let mut p2 = trig.phi[j] - b[j] / (r * st);
            if t2 < 0.0 {
                t2 = -t2;
                p2 += std::f32::consts::PI;
            }
            let r2 = r - (st * a[j] + ct * d[2]);
            if t2 < std::f32::consts::FRAC_PI_2 {
                let k = ((t2 * trig.inv_d_theta) as usize).min(trig.n_theta - 1);
                ((k * n_phi + trig.sector_of(p2)) as u32, r2 * r2)
            } else {
                (NOWHERE, 0.0)
            }
        } else {
            let q = [
                r * st * trig.cp[j] - d[0],
                r * st * trig.sp[j] - d[1],
                r * ct - d[2],
            ];
            let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            (trig.cell_of_vector(q, r2).map_or(NOWHERE, |c| c as u32), r2)
        }
    };
    // Keeps the smaller key (branch-free); `NOWHERE` goes to the last key.
    let put = |keys: &mut [u64], cell: u32, r2: f32, value: PatchId| {
        debug_assert!(
            (cell as usize) < n_cells || cell == NOWHERE,
            "cell {cell:#x}"
        );
        let slot = (cell as usize).min(n_cells);
        let key = (u64::from(r2.to_bits()) << 32) | u64::from(value);
        keys[slot] = keys[slot].min(key);
    };
    let ka: Vec<f32> = a.iter().map(|&x| x * trig.inv_d_theta).collect();
    let kb: Vec<f32> = b.iter().map(|&x| x * trig.inv_d_phi).collect();
    let jc: Vec<f32> = (0..n_phi).map(|j| j as f32 + trig.src_pos).collect();
    let terms = SectorTerms {
        ka: &ka,
        kb: &kb,
        jc: &jc,
        a: &a,
        cp: &trig.cp,
        sp: &trig.sp,
    };
    let has_lists = src.has_lists();
    // Cursor in the extras (by cell).
    let mut extra = 0;
    for i in 0..trig.n_theta {
        let ring = i * n_phi;
        let (r, src_values) = (
            &points.dist[ring..ring + n_phi],
            &points.values[ring..ring + n_phi],
        );
        let src_cells = if points.cells.is_empty() {
            &[][..]
        } else {
            &points.cells[ring..ring + n_phi]
        };
        let first_extra = extra;
        while extra < points.extras.len() && (points.extras[extra].0 as usize) < ring + n_phi {
            extra += 1;
        }
        let ring_extras = &points.extras[first_extra..extra];
        // H1's cell of this grid's sector j (whose boundary list goes with its point).
        let src_cell = |j: usize| {
            if src_cells.is_empty() {
                ring + j
            } else {
                src_cells[j] as usize
            }
        };
        let (st, ct) = (trig.st[i], trig.ct[i]);
        let params = RingParams {
            st,
            ct,
            near_limit: if lateral {
                threshold * len / st
            } else if st >= 0.05 {
                threshold * len
            } else {
                f32::INFINITY
            },
            fi0: i as f32 + trig.src_pos,
            kd: st * d[2] * trig.inv_d_theta,
            inv_st: 1.0 / st,
            d,
            n: n_phi,
            n_theta: trig.n_theta,
            inv_d_theta: trig.inv_d_theta,
            inv_d_phi: trig.inv_d_phi,
            shift: trig.shift,
            fast: trig.min_cell >= FAST_PATH_MIN_CELL,
            margin_k: EDGE_MARGIN * trig.inv_d_theta,
            margin_l: EDGE_MARGIN * trig.inv_d_phi,
            cot_k: COT_MARGIN * trig.inv_d_theta,
        };
        let out = RingOut {
            dest: &mut dest,
            dist2: &mut dist2,
        };
        let n = n_phi;
        // Every point's cell and distance from the branch-free pass (rough cells need no
        // corrections); `first` tells whether any point is far enough for first order.
        let first = points.ring_max[i] > params.near_limit;
        debug_assert!(
            first || !r.iter().any(|&r| r > params.near_limit),
            "a stale ring_max"
        );
        ring_pass(isa, rough, first, r, &terms, &params, ring as u32, out);
        let (dest, dist2) = (&mut dest[..n], &dist2[..n]);
        // The z-buffered writes; the few points near cell edges (unsure) are corrected
        // by the exact path first.
        // (Found 64 at a time from a bit mask, so that the test vectorises.)
        let unsure = |c: u32| c & UNSURE != 0 && c != NOWHERE;
        for w in 0..n.div_ceil(64) {
            let chunk = &dest[64 * w..n.min(64 * w + 64)];
            let mut m = chunk
                .iter()
                .enumerate()
                .fold(0u64, |m, (t, &c)| m | u64::from(unsure(c)) << t);
            while m != 0 {
                let j = 64 * w + m.trailing_zeros() as usize;
                m &= m - 1;
                let rough = dest[j] & !UNSURE;
                dest[j] = exact_path_cell(trig, r[j], &terms, &params, j, rough);
            }
        }
        put_ring(isa, keys, dest, dist2, src_values);
        if has_lists {
            for j in 0..n {
                for &(id, r) in src.list(src_cell(j)) {
                    let (cell, r2) = project(i, j, r);
                    put(keys, cell, r2, value(id));
                }
            }
        }
        extras.extend(
            ring_extras
                .iter()
                .map(|&(c, v)| (dest[c as usize - ring], v))
                .filter(|e| e.0 != NOWHERE),
        );
    }
    // What each cell records (`HOLE` where nothing landed), and how far (a hole's squared
    // distance bits, all ones, go to ∞ by `min`). Both vectorise.
    let keys = &keys[..n_cells];
    ids.clear();
    ids.extend(
        keys.iter()
            .map(|&k| if k == EMPTY { HOLE } else { k as PatchId }),
    );
    if let Some(dist) = dist {
        dist.clear();
        let inf = f32::INFINITY.to_bits();
        dist.extend(
            keys.iter()
                .map(|&k| f32::from_bits(((k >> 32) as u32).min(inf)).sqrt()),
        );
    }
}

/// The z-buffered writes of a ring's points: `keys[c]` (the last key for `NOWHERE`)
/// keeps the smaller of itself and the point's key (its squared distance's bits above
/// its value). Vectorised where the CPU has AVX-512; the same keys in every build, the
/// minimum not depending on the order of the writes.
fn put_ring(isa: Isa, keys: &mut [u64], dest: &[u32], dist2: &[f32], values: &[PatchId]) {
    let n = dest.len();
    assert!(dist2.len() == n && values.len() == n && !keys.is_empty());
    assert!(
        isa <= Isa::supported(),
        "{isa:?} is not available on this CPU"
    );
    let last = keys.len() - 1;
    debug_assert!(
        dest.iter().all(|&c| (c as usize) < last || c == NOWHERE),
        "a cell out of range"
    );
    let done = match isa {
        // SAFETY: the CPU has the instruction set (asserted).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { put_ring_avx512(keys, dest, dist2, values) },
        _ => 0,
    };
    for j in done..n {
        let slot = (dest[j] as usize).min(last);
        let key = (u64::from(dist2[j].to_bits()) << 32) | u64::from(values[j]);
        keys[slot] = keys[slot].min(key);
    }
}

/// [`put_ring`]'s points in groups of eight, as far as they go (returns how many): the
/// eight keys are gathered, each lane takes the minimum of its key and the keys of the
/// earlier lanes bound for the same cell, and the results are scattered. Of lanes bound
/// for one cell the last holds the minimum of all, and a scatter's later lanes overwrite
/// its earlier ones (Intel SDM, VPSCATTERDQ), so each cell gets the minimum.
///
/// # Safety
/// The CPU has AVX-512 (F, VL, DQ, BW) and FMA; `dist2` and `values` are as long as
/// `dest`, and `keys` is not empty.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
unsafe fn put_ring_avx512(
    keys: &mut [u64],
    dest: &[u32],
    dist2: &[f32],
    values: &[PatchId],
) -> usize {
    use std::arch::x86_64::*;
    let n = dest.len();
    // Slots are at most `last` (below 2^26 + 1: see `UNSURE`), within i32's range.
    let last = keys.len() - 1;
    assert!(last < i32::MAX as usize);
    let cap = _mm256_set1_epi32(last as i32);
    // A slot no lane has, shifted into the lanes before the first.
    let none = _mm512_set1_epi64(-1);
    let base = keys.as_mut_ptr() as *mut i64;
    let groups = n / 8;
    for g in 0..groups {
        let o = 8 * g;
        // SAFETY: o + 8 ≤ n, the length of all three.
        let (d, r, v) = unsafe {
            (
                _mm256_loadu_si256(dest.as_ptr().add(o) as *const __m256i),
                _mm256_loadu_si256(dist2.as_ptr().add(o) as *const __m256i),
                _mm256_loadu_si256(values.as_ptr().add(o) as *const __m256i),
            )
        };
        let slot32 = _mm256_min_epu32(d, cap);
        let slot = _mm512_cvtepu32_epi64(slot32);
        let key = _mm512_or_si512(
            _mm512_slli_epi64::<32>(_mm512_cvtepu32_epi64(r)),
            _mm512_cvtepu32_epi64(v),
        );
        // Lane i against lane i − s, for s = 1 ..= 7 (the original keys: each lane
        // meets every earlier one directly).
        let mut m = key;
        macro_rules! step {
            ($s:literal) => {
                let ss = _mm512_alignr_epi64::<{ 8 - $s }>(slot, none);
                let ks = _mm512_alignr_epi64::<{ 8 - $s }>(key, none);
                m = _mm512_mask_min_epu64(m, _mm512_cmpeq_epi64_mask(slot, ss), m, ks);
            };
        }
        step!(1);
        step!(2);
        step!(3);
        step!(4);
        step!(5);
        step!(6);
        step!(7);
        // SAFETY: every slot is at most `last`, within `keys`.
        unsafe {
            let old = _mm512_i32gather_epi64::<8>(slot32, base as *const i64);
            _mm512_i32scatter_epi64::<8>(base, slot32, _mm512_min_epu64(old, m));
        }
    }
    8 * groups
}

/// Working memory of [`splat`]: the z-buffer's keys.
#[derive(Default)]
pub(crate) struct ZBuffer {
    keys: Vec<u64>,
}

/// The key of a cell nothing landed in: above every point's (whose distance bits are at
/// most ∞'s); all ones, so that the z-buffer is cleared by `memset`.
const EMPTY: u64 = u64::MAX;

/// No destination: the point left the hemisphere.
const NOWHERE: u32 = u32::MAX;
/// Distance from a cell edge, in radians, beyond which a rough cell is exact: ten times
/// the polynomial angles' error (under 1e-6 rad: see [`atan2_approx`]). About 0.5 % of
/// the points at 180 × 720 fall within it of an edge.
const EDGE_MARGIN: f32 = 1e-5;
/// Added to the θ margin, times cot θ. The exact path's own ring test (cos²θ of the f32
/// vector against the f32 edges) is ill-conditioned next to the pole: cos²θ near 1 carries
/// about three roundings and the edge one, about 3e-7 in all, which is 1.5e-7 cot θ rad
/// of θ. Twice that is added, so that a rough cell is trusted only where both paths give
/// the same cell (a review found 360 × 1440 and 785 × 3,140 disagreeing without it).
const COT_MARGIN: f32 = 3e-7;
/// The rough fast path is used only where cells span at least this many radians both
/// ways (up to about 785 × 3,141 cells): it is tested there.
const FAST_PATH_MIN_CELL: f64 = 2e-3;
/// Marks a rough cell the exact path must correct (cells are below 2^26: see
/// `rad_hemisphere::MAX_CELLS`).
pub(crate) const UNSURE: u32 = 1 << 31;

/// Fills holes in `ids` (marked `HOLE`) by `fill`; `source(c)` is H1's entry of cell
/// `c`. Returns the number of holes and their form factor.
pub(crate) fn fill_holes(
    hemi: &Hemisphere,
    ids: &mut [PatchId],
    fill: HoleFill,
    source: impl Fn(usize) -> PatchId,
) -> (usize, f64) {
    fill_holes_with(Isa::detect(), hemi, ids, fill, source)
}

/// [`fill_holes`] compiled for `isa` (integer work only: the same answers in every
/// build).
pub(crate) fn fill_holes_with(
    isa: Isa,
    hemi: &Hemisphere,
    ids: &mut [PatchId],
    fill: HoleFill,
    source: impl Fn(usize) -> PatchId,
) -> (usize, f64) {
    with_isa!(isa, |ISA| fill_holes_body(hemi, ids, fill, source))
}

#[inline(always)]
fn fill_holes_body(
    hemi: &Hemisphere,
    ids: &mut [PatchId],
    fill: HoleFill,
    source: impl Fn(usize) -> PatchId,
) -> (usize, f64) {
    let n = hemi.n_phi();
    // Holes of a slice, counted so that it vectorises.
    let count = |x: &[PatchId]| x.iter().map(|&id| u32::from(id == HOLE)).sum::<u32>() as usize;
    let (mut holes, mut hole_ff) = (0, 0.0);
    // How far the first, branch-free pass looks each way (see below).
    const REACH: usize = 3;
    // A ring as it was before the first filling pass (with `REACH` cells of wrap each
    // side), and the runs of holes left after.
    let mut before: Vec<PatchId> = Vec::with_capacity(n + 2 * REACH);
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (i, ff) in hemi.ring_form_factors().iter().enumerate() {
        let ring = &mut ids[i * n..(i + 1) * n];
        let n_holes = count(ring);
        if n_holes == 0 {
            continue;
        }
        holes += n_holes;
        hole_ff += n_holes as f64 * ff;
        if fill == HoleFill::KeepSource || n_holes == n {
            for (j, id) in ring.iter_mut().enumerate() {
                if *id == HOLE {
                    *id = source(i * n + j);
                }
            }
            continue;
        }
        // Each run of holes takes, cell by cell, the nearer of the written cells that
        // bound it (wrapping round the ring); the lower φ (left) wins ties, as a search
        // alternating left first would: of a run of L holes the first ⌈L / 2⌉ take the
        // left one, the others the right one.
        //
        // First, branch-free (most runs are short): a hole whose nearest written cell
        // either way is within `REACH` cells takes the nearer of the nearest written cells
        // each way within `REACH`, the left on ties (none within `REACH` one way counts as
        // farther). That fills runs of up to 2 `REACH` holes, and the `REACH` cells at
        // each end of longer ones as the rule does; what is left of a longer run is a run
        // of L − 2 `REACH` between the values its ends took, which the rule splits as it
        // would have split the whole.
        before.clear();
        before.extend((0..REACH).map(|t| ring[(REACH * n + t - REACH) % n]));
        before.extend_from_slice(ring);
        before.extend((0..REACH).map(|t| ring[t % n]));
        // (As masks, so that it vectorises without blends.)
        let written = |x: PatchId| 0u32.wrapping_sub(u32::from(x != HOLE));
        let sel = |m: u32, a: u32, b: u32| (a & m) | (b & !m);
        // Cells at distance k + 1 left and right, and the cell itself.
        let left: [&[PatchId]; REACH] = std::array::from_fn(|k| &before[REACH - 1 - k..][..n]);
        let right: [&[PatchId]; REACH] = std::array::from_fn(|k| &before[REACH + 1 + k..][..n]);
        let c = &before[REACH..][..n];
        for (j, x) in ring.iter_mut().enumerate() {
            // The value and distance of the nearest written cell each way within
            // `REACH` (`HOLE` and `REACH + 1` if none): farthest first, nearer ones
            // taking over.
            let (mut vl, mut dl) = (HOLE, REACH as u32 + 1);
            let (mut vr, mut dr) = (HOLE, REACH as u32 + 1);
            for k in (0..REACH).rev() {
                let (l, r) = (left[k][j], right[k][j]);
                let (wl, wr) = (written(l), written(r));
                vl = sel(wl, l, vl);
                dl = sel(wl, k as u32 + 1, dl);
                vr = sel(wr, r, vr);
                dr = sel(wr, k as u32 + 1, dr);
            }
            let side = sel(0u32.wrapping_sub(u32::from(dl <= dr)), vl, vr);
            *x = sel(written(c[j]), c[j], side);
        }
        if count(ring) == 0 {
            continue;
        }
        // Then the rest of the longer runs: (first, length), found 64 cells at a time
        // from a bit mask of the holes; the run that wraps round joined.
        runs.clear();
        for (w, chunk) in ring.chunks(64).enumerate() {
            let mut m = chunk
                .iter()
                .enumerate()
                .fold(0u64, |m, (t, &id)| m | u64::from(id == HOLE) << t);
            while m != 0 {
                let a = m.trailing_zeros() as usize;
                let len = (!(m >> a)).trailing_zeros() as usize;
                let j = 64 * w + a;
                match runs.last_mut() {
                    Some((h, l)) if *h + *l == j => *l += len,
                    _ => runs.push((j, len)),
                }
                // Clear the run's bits (a + len ≤ 64).
                m &= if a + len == 64 { 0 } else { !0u64 << (a + len) };
            }
        }
        if runs.len() > 1 && runs[0].0 == 0 {
            let (h, len) = runs[runs.len() - 1];
            if h + len == n {
                runs[0] = (h, len + runs[0].1);
                runs.pop();
            }
        }
        // Cells h .. h + len (wrapping) take `v`.
        let put = |ring: &mut [PatchId], h: usize, len: usize, v: PatchId| {
            let first = (n - h).min(len);
            ring[h..h + first].fill(v);
            ring[..len - first].fill(v);
        };
        for &(h, len) in &runs {
            let (lv, rv) = (ring[(h + n - 1) % n], ring[(h + len) % n]);
            let left = len.div_ceil(2);
            put(ring, h, left, lv);
            put(ring, (h + left) % n, len - left, rv);
        }
    }
    (holes, hole_ff)
}

thread_local! {
    /// Faithful mode's z-buffer, kept between estimates.
    static Z: std::cell::RefCell<ZBuffer> = std::cell::RefCell::new(ZBuffer::default());
}

/// Estimates hemispheres of one resolution: holds the per-cell tables.
#[derive(Clone, Debug)]
pub struct Estimator<'h> {
    pub(crate) hemi: &'h Hemisphere,
    pub(crate) trig: CellTrig,
    /// The tables of strides 2 ..= `MAX_GUESS_STRIDE`, made on first use.
    strided: [std::sync::OnceLock<CellTrig>; crate::config::MAX_GUESS_STRIDE as usize - 1],
}

impl<'h> Estimator<'h> {
    pub fn new(hemi: &'h Hemisphere) -> Estimator<'h> {
        Estimator {
            hemi,
            trig: CellTrig::new(hemi),
            strided: Default::default(),
        }
    }

    /// The tables of the grid s times coarser, s the largest stride up to `stride`
    /// (and `MAX_GUESS_STRIDE`) that divides the resolution both ways.
    pub(crate) fn trig_strided(&self, stride: usize) -> &CellTrig {
        let h = self.hemi;
        let max = stride.min(self.strided.len() + 1);
        match (2..=max)
            .rev()
            .find(|&s| h.n_theta().is_multiple_of(s) && h.n_phi().is_multiple_of(s))
        {
            Some(s) => self.strided[s - 2].get_or_init(|| CellTrig::strided(h, s)),
            None => &self.trig,
        }
    }

    pub fn hemisphere(&self) -> &'h Hemisphere {
        self.hemi
    }

    /// Estimates H2 at patch `to` from `src`, the report's way (no rays), into `out`
    /// (reusing its buffers).
    pub fn faithful(
        &self,
        scene: &Scene,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        out: &mut Estimate,
    ) {
        let m = motion(scene, src.patch(), to);
        let points = Points {
            dist: &src.items().dist,
            values: &src.items().patch,
            cells: &[],
            extras: &[],
            ring_max: src.ring_max(self.hemi),
        };
        let items = &mut out.items;
        let splat_into = |z: &mut ZBuffer| {
            let (ids, dist) = (&mut items.patch, Some(&mut items.dist));
            let t = &self.trig;
            splat(
                t,
                src,
                &m,
                config,
                false,
                points,
                |id| id,
                ids,
                dist,
                z,
                &mut Vec::new(),
            );
        };
        // (A fresh z-buffer if this thread's is in use.)
        Z.with(|z| match z.try_borrow_mut() {
            Ok(mut z) => splat_into(&mut z),
            Err(_) => splat_into(&mut ZBuffer::default()),
        });
        let (holes, hole_ff) = fill_holes(self.hemi, &mut out.items.patch, config.fill, |c| {
            src.items().patch[c]
        });
        out.holes = holes;
        out.hole_ff = hole_ff;
    }
}

#[cfg(test)]
mod tests;
