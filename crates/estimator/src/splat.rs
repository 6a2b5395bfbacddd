//! The splat: every point of H1 moved to H2 (first order where far enough, exact
//! elsewhere: `ring_pass`, one branch-free pass a ring, compiled for each instruction
//! set) and z-buffered into its destination cell.

use crate::cell_trig::{atan2_approx, CellTrig};
use crate::config::{EstimatorConfig, Reprojection, ThresholdTest};
use crate::reproject::Motion;
use crate::source::SourceHemisphere;
use crate::zbuffer::{put_ring, ZBuffer, EMPTY, NOWHERE};
use rad_core::{with_isa, Isa, PatchId, HOLE};

/// What a ring's pass needs besides the ring's distances.
pub(crate) struct RingParams {
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
pub(crate) struct SectorTerms<'a> {
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
pub(crate) struct RingOut<'a> {
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
pub(crate) fn ring_pass_body<const ROUGH: bool, const FIRST: bool, const FUSED: bool>(
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
pub(crate) fn exact_path_cell(
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

/// [`ring_pass_body`] compiled for `isa` (checked against the CPU), `first` telling
/// whether any point may take the first-order path (`false` only where none is beyond
/// `p.near_limit`). The AVX2 and AVX-512 builds (8 and 16 lanes) perform the same IEEE
/// operations in the same order (no contraction into FMA), but for the fused angle
/// polynomial without `rough`, so the same answers as the baseline build (the same bits
/// in rough mode; the same cells once corrected otherwise).
#[allow(clippy::too_many_arguments)]
pub(crate) fn ring_pass(
    isa: Isa,
    rough: bool,
    first: bool,
    r: &[f32],
    t: &SectorTerms,
    p: &RingParams,
    ring: u32,
    out: RingOut,
) {
    with_isa!(isa, |ISA| fn(
        rough: bool = rough,
        first: bool = first,
        r: &[f32] = r,
        t: &SectorTerms<'_> = t,
        p: &RingParams = p,
        ring: u32 = ring,
        out: RingOut<'_> = out,
    ) {
        // Faithful mode's angle polynomial is fused where the set has FMA.
        let fused = ISA != Isa::Base;
        match (rough, first, fused) {
            (true, true, _) => ring_pass_body::<true, true, false>(r, t, p, ring, out),
            (true, false, _) => ring_pass_body::<true, false, false>(r, t, p, ring, out),
            (false, true, false) => ring_pass_body::<false, true, false>(r, t, p, ring, out),
            (false, false, false) => ring_pass_body::<false, false, false>(r, t, p, ring, out),
            (false, true, true) => ring_pass_body::<false, true, true>(r, t, p, ring, out),
            (false, false, true) => ring_pass_body::<false, false, true>(r, t, p, ring, out),
        }
    })
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
pub(crate) fn splat(
    job: Splat,
    value: impl Fn(PatchId) -> PatchId,
    ids: &mut Vec<PatchId>,
    dist: Option<&mut Vec<f32>>,
    z: &mut ZBuffer,
    extras: &mut Vec<(u32, PatchId)>,
) {
    // (Its own passes compiled for the CPU's widest set: the ring pass is chosen apart.)
    with_isa!(Isa::detect(), |ISA| fn(
        job: Splat<'_> = job,
        value: impl Fn(PatchId) -> PatchId = value,
        ids: &mut Vec<PatchId> = ids,
        dist: Option<&mut Vec<f32>> = dist,
        z: &mut ZBuffer = z,
        extras: &mut Vec<(u32, PatchId)> = extras,
    ) {
        splat_body(ISA, job, value, ids, dist, z, extras)
    })
}

/// What a splat moves, and how: the points of `src` on the grid `trig`, by the motion
/// `m`, with `config`'s reprojection; with `rough`, every near point takes its rough
/// cell (improved mode's guesses), else unsure ones are corrected by the exact path.
pub(crate) struct Splat<'a> {
    pub trig: &'a CellTrig,
    pub src: &'a SourceHemisphere,
    /// The motion, in the destination's frame.
    pub m: &'a Motion,
    /// The source points' azimuths in the destination's frame, where it is another
    /// polygon's, turned about the shared normal (`None`: the source's own frame).
    pub turned: Option<&'a Turned>,
    pub config: &'a EstimatorConfig,
    pub rough: bool,
    pub points: Points<'a>,
}

#[inline(always)]
fn splat_body(
    isa: Isa,
    job: Splat,
    value: impl Fn(PatchId) -> PatchId,
    ids: &mut Vec<PatchId>,
    dist: Option<&mut Vec<f32>>,
    z: &mut ZBuffer,
    extras: &mut Vec<(u32, PatchId)>,
) {
    let Splat {
        trig,
        src,
        m,
        turned,
        config,
        rough,
        points,
    } = job;
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
    let sectors = Sectors::new(trig, turned, d);
    let (threshold, lateral) = first_order_test(config);
    // Two passes a ring: destinations (independent, so the CPU overlaps them), then the
    // z-buffered writes. The z-buffer holds squared distances until the end.
    let mut dest = vec![NOWHERE; n_phi];
    let mut dist2 = vec![0.0f32; n_phi];
    let list_point = ListPoint {
        trig,
        cp: sectors.cp,
        sp: sectors.sp,
        phi: sectors.phi,
        inf: turned.map(|t| &t.inf[..]),
        a: &sectors.a,
        b: &sectors.b,
        d,
        far: threshold * len,
        lateral,
    };
    let terms = sectors.terms();
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
        let params = RingParams::new(trig, i, d, threshold * len, lateral);
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
        if let Some(t) = turned {
            // Points at infinity stay in their direction: their sector, turned.
            for (j, d) in dest.iter_mut().enumerate() {
                if !r[j].is_finite() {
                    *d = (ring as u32) + t.inf[j];
                }
            }
        }
        // The z-buffered writes; the few points near cell edges (unsure) are corrected
        // by the exact path first.
        correct_unsure(trig, r, &terms, &params, dest);
        put_ring(isa, keys, dest, dist2, src_values);
        if has_lists {
            for j in 0..n {
                for &(id, r) in src.list(src_cell(j)) {
                    let (cell, r2) = list_point.project(i, j, r);
                    put(keys, n_cells, cell, r2, value(id));
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
    write_out(&keys[..n_cells], ids, dist);
}

/// Keeps the smaller of `keys[cell]` and the point's key (branch-free); `NOWHERE` goes
/// to the last key, `keys[n_cells]`.
fn put(keys: &mut [u64], n_cells: usize, cell: u32, r2: f32, value: PatchId) {
    debug_assert!(
        (cell as usize) < n_cells || cell == NOWHERE,
        "cell {cell:#x}"
    );
    let slot = (cell as usize).min(n_cells);
    let key = (u64::from(r2.to_bits()) << 32) | u64::from(value);
    keys[slot] = keys[slot].min(key);
}

/// A boundary-list point's destination (scalar: the lists are off by default).
struct ListPoint<'a> {
    trig: &'a CellTrig,
    /// The source points' azimuths (cos, sin, φ) in the destination's frame, and where
    /// a turned one at infinity lands (`None`: not turned, its own sector).
    cp: &'a [f32],
    sp: &'a [f32],
    phi: &'a [f32],
    inf: Option<&'a [u32]>,
    /// Per sector: d·(cosφ, sinφ, 0) and d·(−sinφ, cosφ, 0).
    a: &'a [f32],
    b: &'a [f32],
    d: [f32; 3],
    /// The first-order threshold times |d|, against R sinθ if `lateral`, else R.
    far: f32,
    lateral: bool,
}

/// The per-sector inputs of a splat: the source points' azimuths (the grid's own, or
/// turned into the destination's frame) and the motion's terms along them.
struct Sectors<'a> {
    cp: &'a [f32],
    sp: &'a [f32],
    phi: &'a [f32],
    a: Vec<f32>,
    b: Vec<f32>,
    ka: Vec<f32>,
    kb: Vec<f32>,
    jc: Vec<f32>,
}

impl<'a> Sectors<'a> {
    fn new(trig: &'a CellTrig, turned: Option<&'a Turned>, d: [f32; 3]) -> Sectors<'a> {
        let (cp, sp, phi) = match turned {
            None => (&trig.cp[..], &trig.sp[..], &trig.phi[..]),
            Some(t) => (&t.cp[..], &t.sp[..], &t.phi[..]),
        };
        let (a, b) = sector_motion(cp, sp, d);
        let ka = a.iter().map(|&x| x * trig.inv_d_theta).collect();
        let kb = b.iter().map(|&x| x * trig.inv_d_phi).collect();
        let jc = match turned {
            None => (0..trig.n_phi).map(|j| j as f32 + trig.src_pos).collect(),
            Some(t) => t.jc.clone(),
        };
        Sectors {
            cp,
            sp,
            phi,
            a,
            b,
            ka,
            kb,
            jc,
        }
    }

    fn terms(&self) -> SectorTerms<'_> {
        SectorTerms {
            ka: &self.ka,
            kb: &self.kb,
            jc: &self.jc,
            a: &self.a,
            cp: self.cp,
            sp: self.sp,
        }
    }
}

/// Per sector, of the source points' azimuths (`cp`, `sp`): d·(cosφ, sinφ, 0) and
/// d·(−sinφ, cosφ, 0), for the first-order formulas.
fn sector_motion(cp: &[f32], sp: &[f32], d: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
    let a = cp
        .iter()
        .zip(sp)
        .map(|(&c, &s)| d[0] * c + d[1] * s)
        .collect();
    let b = cp
        .iter()
        .zip(sp)
        .map(|(&c, &s)| -d[0] * s + d[1] * c)
        .collect();
    (a, b)
}

/// The source points' azimuths in the frame of a destination on another polygon of the
/// same plane, whose frame is the source's turned about the normal: a source point at
/// azimuth φ in its own frame is at φ + α in the destination's (`α` as
/// [`crate::frame_turn`] gives it).
#[derive(Clone, Debug)]
pub(crate) struct Turned {
    /// cos, sin and φ + α of each sector's source point.
    pub cp: Vec<f32>,
    pub sp: Vec<f32>,
    pub phi: Vec<f32>,
    /// Its sector coordinate `(φ + α) / Δφ − shift` of the destination grid, in [0, N_φ).
    pub jc: Vec<f32>,
    /// The sector a point at infinity in that direction lands in.
    pub inf: Vec<u32>,
}

impl Turned {
    /// The azimuths of `trig`'s source points turned by `alpha` (radians).
    pub(crate) fn new(trig: &CellTrig, alpha: f64) -> Turned {
        let n = trig.n_phi;
        let phi: Vec<f64> = trig.phi64.iter().map(|&p| p + alpha).collect();
        let jc: Vec<f64> = (0..n)
            .map(|j| (j as f64 + trig.src_pos as f64 + alpha / trig.d_phi).rem_euclid(n as f64))
            .collect();
        Turned {
            cp: phi.iter().map(|p| p.cos() as f32).collect(),
            sp: phi.iter().map(|p| p.sin() as f32).collect(),
            phi: phi
                .iter()
                .map(|p| p.rem_euclid(std::f64::consts::TAU) as f32)
                .collect(),
            jc: jc.iter().map(|&x| x as f32).collect(),
            inf: jc.iter().map(|&x| (x as u32).min(n as u32 - 1)).collect(),
        }
    }
}

/// The first-order threshold of `config` and whether it applies to R sinθ (else to R).
fn first_order_test(config: &EstimatorConfig) -> (f32, bool) {
    match config.reprojection {
        Reprojection::Exact => (f32::INFINITY, true),
        Reprojection::FirstOrder { test, threshold } => {
            (threshold as f32, test == ThresholdTest::Lateral)
        }
    }
}

impl ListPoint<'_> {
    /// The cell and squared distance in H2 of the point at distance `r` in cell (i, j)
    /// of H1's grid.
    fn project(&self, i: usize, j: usize, r: f32) -> (u32, f32) {
        let (trig, a, b, d) = (self.trig, self.a, self.b, self.d);
        let n_phi = trig.n_phi;
        let (st, ct) = (trig.st[i], trig.ct[i]);
        let far_scale = if self.lateral {
            st
        } else if st >= 0.05 {
            1.0
        } else {
            0.0
        };
        if !r.is_finite() {
            let l = self.inf.map_or(j as u32, |inf| inf[j]);
            ((i * n_phi) as u32 + l, f32::INFINITY)
        } else if r * far_scale > self.far {
            // First order (1), Δ = −d: θ' = θ + Δ·e_θ / R, φ' = φ + Δ·e_φ / (R sinθ).
            let mut t2 = trig.theta[i] - (ct * a[j] - st * d[2]) / r;
            let mut p2 = self.phi[j] - b[j] / (r * st);
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
                r * st * self.cp[j] - d[0],
                r * st * self.sp[j] - d[1],
                r * ct - d[2],
            ];
            let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            (trig.cell_of_vector(q, r2).map_or(NOWHERE, |c| c as u32), r2)
        }
    }
}

impl RingParams {
    /// The parameters of ring `i` of `trig` for the motion `d`, with points beyond
    /// `far` (the first-order threshold times |d|; by R sinθ if `lateral`, else by R)
    /// far enough for first order.
    #[inline(always)]
    fn new(trig: &CellTrig, i: usize, d: [f32; 3], far: f32, lateral: bool) -> RingParams {
        let (st, ct) = (trig.st[i], trig.ct[i]);
        RingParams {
            st,
            ct,
            near_limit: if lateral {
                far / st
            } else if st >= 0.05 {
                far
            } else {
                f32::INFINITY
            },
            fi0: i as f32 + trig.src_pos,
            kd: st * d[2] * trig.inv_d_theta,
            inv_st: 1.0 / st,
            d,
            n: trig.n_phi,
            n_theta: trig.n_theta,
            inv_d_theta: trig.inv_d_theta,
            inv_d_phi: trig.inv_d_phi,
            shift: trig.shift,
            fast: trig.min_cell >= FAST_PATH_MIN_CELL,
            margin_k: EDGE_MARGIN * trig.inv_d_theta,
            margin_l: EDGE_MARGIN * trig.inv_d_phi,
            cot_k: COT_MARGIN * trig.inv_d_theta,
        }
    }
}

/// Corrects the ring's `UNSURE` destinations by the exact path (found 64 at a time
/// from a bit mask, so that the test vectorises).
#[inline(always)]
fn correct_unsure(
    trig: &CellTrig,
    r: &[f32],
    terms: &SectorTerms,
    params: &RingParams,
    dest: &mut [u32],
) {
    let n = dest.len();
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
            dest[j] = exact_path_cell(trig, r[j], terms, params, j, rough);
        }
    }
}

/// What each cell records (`HOLE` where nothing landed), and how far (a hole's squared
/// distance bits, all ones, go to ∞ by `min`), from the z-buffer's `keys`. Both
/// vectorise.
#[inline(always)]
fn write_out(keys: &[u64], ids: &mut Vec<PatchId>, dist: Option<&mut Vec<f32>>) {
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

/// Distance from a cell edge, in radians, beyond which a rough cell is exact: ten times
/// the polynomial angles' error (under 1e-6 rad: see [`atan2_approx`]). About 0.5 % of
/// the points at 180 × 720 fall within it of an edge.
pub(crate) const EDGE_MARGIN: f32 = 1e-5;
/// Added to the θ margin, times cot θ. The exact path's own ring test (cos²θ of the f32
/// vector against the f32 edges) is ill-conditioned next to the pole: cos²θ near 1 carries
/// about three roundings and the edge one, about 3e-7 in all, which is 1.5e-7 cot θ rad
/// of θ. Twice that is added, so that a rough cell is trusted only where both paths give
/// the same cell (360 × 1440 and 785 × 3,140 disagreed without it).
pub(crate) const COT_MARGIN: f32 = 3e-7;
/// The rough fast path is used only where cells span at least this many radians both
/// ways (up to about 785 × 3,141 cells): it is tested there.
pub(crate) const FAST_PATH_MIN_CELL: f64 = 2e-3;
/// Marks a rough cell the exact path must correct (cells are below 2^26: see
/// `rad_hemisphere::MAX_CELLS`).
pub(crate) const UNSURE: u32 = 1 << 31;

#[cfg(test)]
mod tests;
