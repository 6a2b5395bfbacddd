//! The ring pass: every instruction set's build against the baseline's, and rough cells against the exact path.

use crate::cell_trig::CellTrig;
use crate::splat::UNSURE;
use crate::test_rng as rng;
use crate::zbuffer::NOWHERE;
use rad_hemisphere::{Hemisphere, HemisphereConfig};

/// A ring of random sector terms and distances of every kind (near, far, infinite).
struct RandomRing {
    ka: Vec<f32>,
    kb: Vec<f32>,
    a: Vec<f32>,
    jc: Vec<f32>,
    cp: Vec<f32>,
    sp: Vec<f32>,
    r: Vec<f32>,
}

impl RandomRing {
    fn new(n: usize, mut seed: u64) -> RandomRing {
        let mut v = |lo: f64, hi: f64| (lo + (hi - lo) * rng(&mut seed)) as f32;
        let (ka, kb, a) = (
            (0..n).map(|_| v(-50.0, 50.0)).collect(),
            (0..n).map(|_| v(-50.0, 50.0)).collect(),
            (0..n).map(|_| v(-0.3, 0.3)).collect(),
        );
        let r = (0..n)
            .map(|j| match j % 7 {
                0 => f32::INFINITY,
                1 => v(0.001, 0.05),
                _ => v(0.05, 20.0),
            })
            .collect();
        let phi: Vec<f32> = (0..n)
            .map(|j| (j as f32 + 0.5) * std::f32::consts::TAU / n as f32)
            .collect();
        RandomRing {
            ka,
            kb,
            a,
            jc: (0..n).map(|j| j as f32 + 0.5).collect(),
            cp: phi.iter().map(|p| p.cos()).collect(),
            sp: phi.iter().map(|p| p.sin()).collect(),
            r,
        }
    }

    fn terms(&self) -> super::SectorTerms<'_> {
        super::SectorTerms {
            ka: &self.ka,
            kb: &self.kb,
            jc: &self.jc,
            a: &self.a,
            cp: &self.cp,
            sp: &self.sp,
        }
    }

    /// A ring at sinθ = `st`, cosθ = `ct` of a 180 × `n` hemisphere, motion (0.1,
    /// −0.05, 0), points beyond 2 far.
    fn params(st: f32, ct: f32, n: usize) -> super::RingParams {
        super::RingParams {
            st,
            ct,
            near_limit: 2.0,
            fi0: 40.5,
            kd: 0.001,
            inv_st: 1.0 / st,
            d: [0.1, -0.05, 0.0],
            n,
            n_theta: 180,
            inv_d_theta: 180.0 / std::f32::consts::FRAC_PI_2,
            inv_d_phi: n as f32 / std::f32::consts::TAU,
            shift: 0.0,
            fast: true,
            margin_k: 0.0115,
            margin_l: 0.0115,
            cot_k: 0.001,
        }
    }
}

/// The sector terms of no motion, for rings of `n` sectors.
struct ZeroMotion {
    zeros: Vec<f32>,
    jc: Vec<f32>,
}

impl ZeroMotion {
    fn new(n: usize) -> ZeroMotion {
        ZeroMotion {
            zeros: vec![0.0; n],
            jc: (0..n).map(|j| j as f32 + 0.5).collect(),
        }
    }

    fn terms<'a>(&'a self, trig: &'a CellTrig) -> super::SectorTerms<'a> {
        super::SectorTerms {
            ka: &self.zeros,
            kb: &self.zeros,
            jc: &self.jc,
            a: &self.zeros,
            cp: &trig.cp,
            sp: &trig.sp,
        }
    }
}

#[test]
fn the_vector_ring_passes_give_the_baseline_answers_bit_for_bit() {
    use super::{exact_path_cell, ring_pass, RingOut, RingParams};
    use rad_core::Isa;
    let trig = CellTrig::new(&Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap());
    // (On a CPU with only the baseline there is nothing to compare.)
    let n = 720;
    let ring_data = RandomRing::new(n, 0x1234_5678_9abc_def1);
    let (terms, r) = (ring_data.terms(), &ring_data.r);
    for (st, ct) in [(0.01f32, 0.99995f32), (0.7, 0.714), (0.99995, 0.01)] {
        let params = RandomRing::params(st, ct, n);
        let ring = 7 * n as u32;
        let run = |isa: Isa, rough: bool| {
            let (mut dest, mut d2) = (vec![0u32; n], vec![0f32; n]);
            let out = RingOut {
                dest: &mut dest,
                dist2: &mut d2,
            };
            ring_pass(isa, rough, true, r, &terms, &params, ring, out);
            (dest, d2.iter().map(|f| f.to_bits()).collect::<Vec<u32>>())
        };
        // The answers: rough mode's as they are; otherwise unsure cells corrected, as the
        // splat does (the builds with FMA fuse the angle polynomial there, which may move
        // a rough cell, never a corrected one).
        let answers = |isa: Isa, rough: bool| {
            let (mut dest, d2) = run(isa, rough);
            let mut unsure = 0;
            if !rough {
                for (j, c) in dest.iter_mut().enumerate() {
                    if *c != NOWHERE && *c & UNSURE != 0 {
                        unsure += 1;
                        *c = exact_path_cell(&trig, r[j], &terms, &params, j, *c & !UNSURE);
                    }
                }
            }
            (dest, d2, unsure)
        };
        for rough in [false, true] {
            let (base, base_d2, base_unsure) = answers(Isa::Base, rough);
            assert!(rough || base_unsure > 0, "no unsure point at sinθ = {st}");
            for isa in Isa::available() {
                let (dest, d2, _) = answers(isa, rough);
                assert!(
                    dest == base && d2 == base_d2,
                    "the {isa:?} pass differs from the baseline at sinθ = {st} (rough: {rough})"
                );
            }
            // Where no point is beyond the near limit, the pass without the first-order
            // path gives the same answers.
            let near = RingParams {
                near_limit: f32::INFINITY,
                ..params
            };
            for isa in Isa::available() {
                let pass = |first: bool| {
                    let (mut dest, mut d2) = (vec![0u32; n], vec![0f32; n]);
                    let out = RingOut {
                        dest: &mut dest,
                        dist2: &mut d2,
                    };
                    ring_pass(isa, rough, first, r, &terms, &near, ring, out);
                    (dest, d2.iter().map(|f| f.to_bits()).collect::<Vec<u32>>())
                };
                assert!(
                    pass(true) == pass(false),
                    "without first order, sinθ = {st}"
                );
            }
        }
        // The rough pass gives the full pass's answers where it has them, and every
        // kind of answer occurs.
        let (full, d_full) = run(Isa::Base, false);
        let (rough, d_rough) = run(Isa::Base, true);
        assert_eq!(d_full, d_rough);
        let mut exact_path = 0;
        for j in 0..n {
            if full[j] != NOWHERE && full[j] & UNSURE != 0 {
                exact_path += 1;
                // The unsure cell carries the rough one.
                assert_eq!(full[j] & !UNSURE, rough[j]);
            } else {
                assert_eq!(full[j], rough[j], "point {j} at sinθ = {st}");
            }
        }
        assert!(
            exact_path > 0,
            "no point left to the exact path at sinθ = {st}"
        );
    }
}

#[test]
fn rough_cells_are_exact_away_from_edges_and_at_most_one_off_near_them() {
    use super::{exact_path_cell, ring_pass, RingOut, RingParams};
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let trig = CellTrig::new(&hemi);
    let n = 720;
    let mut seed = 0x0bad_cafe_dead_beefu64;
    let still = ZeroMotion::new(n);
    let terms = still.terms(&trig);
    let (mut same, mut total, mut sure_n) = (0usize, 0usize, 0usize);
    for i in (0..180).flat_map(|i| [i; 4]) {
        let r: Vec<f32> = (0..n)
            .map(|_| (0.02 + 5.0 * rng(&mut seed)) as f32)
            .collect();
        let d = [
            (0.3 * rng(&mut seed) - 0.15) as f32,
            (0.3 * rng(&mut seed) - 0.15) as f32,
            0.0,
        ];
        // Every point by the exact path (no first-order limit).
        let params = RingParams::new(&trig, i, d, f32::INFINITY, true);
        let run = |rough: bool| {
            let (mut dest, mut d2) = (vec![0u32; n], vec![0f32; n]);
            let out = RingOut {
                dest: &mut dest,
                dist2: &mut d2,
            };
            ring_pass(
                rad_core::Isa::detect(),
                rough,
                false,
                &r,
                &terms,
                &params,
                0,
                out,
            );
            dest
        };
        let (rough, full) = (run(true), run(false));
        for j in 0..n {
            let rs = r[j] * params.st;
            let q = [
                rs * trig.cp[j] - d[0],
                rs * trig.sp[j] - d[1],
                r[j] * params.ct - d[2],
            ];
            let exact = trig.cell_of_vector(q, q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
            // The exact path's correction gives the exact cell.
            if exact.is_some() {
                let corrected = exact_path_cell(&trig, r[j], &terms, &params, j, rough[j]);
                assert_eq!(exact.map(|c| c as u32), Some(corrected));
            }
            match exact {
                None => assert_eq!(rough[j], NOWHERE),
                Some(c) => {
                    total += 1;
                    let (k, l) = (c / n, c % n);
                    let (rk, rl) = (rough[j] as usize / n, rough[j] as usize % n);
                    let dl = l.abs_diff(rl).min(n - l.abs_diff(rl));
                    assert!(
                        k.abs_diff(rk) <= 1 && dl <= 1,
                        "ring {k} vs {rk}, sector {l} vs {rl}"
                    );
                    same += usize::from(c == rough[j] as usize);
                    // Far from every edge (not left to the exact path), the rough cell
                    // is the exact one.
                    if full[j] & UNSURE == 0 {
                        assert_eq!(c, full[j] as usize, "a sure rough cell is wrong");
                        sure_n += 1;
                    }
                }
            }
        }
    }
    assert!(
        same as f64 >= 0.99 * total as f64,
        "{same} of {total} rough cells exact"
    );
    assert!(
        sure_n as f64 >= 0.9 * total as f64,
        "only {sure_n} of {total} sure"
    );
}

/// Next to the pole the exact path's own ring test (cos²θ of the f32 vector against the
/// f32 edges) is ill-conditioned: a rough cell trusted there must still be the cell that
/// test gives. Points just off the first ring edges, at resolutions where the fast path
/// runs (360 × 1440 failed with a margin blind to this).
#[test]
fn sure_cells_agree_with_the_exact_path_next_to_the_pole() {
    use super::{ring_pass, RingOut, RingParams};
    let mut seed = 0x9017_e000_0000_0001u64;
    let (mut sure_n, mut total) = (0usize, 0usize);
    for (nt, np) in [(360usize, 1440usize), (785, 3140)] {
        let hemi = Hemisphere::new(HemisphereConfig::exact(nt as u32, np as u32)).unwrap();
        let trig = CellTrig::new(&hemi);
        assert!(
            trig.min_cell >= super::FAST_PATH_MIN_CELL,
            "the fast path runs here"
        );
        let still = ZeroMotion::new(np);
        let terms = still.terms(&trig);
        let d_theta = hemi.d_theta();
        for k in 1..6 {
            for delta in [1e-6, 3e-6, 1e-5, 1.5e-5, 2e-5, 3e-5, 5e-5, 1e-4] {
                for sign in [-1.0, 1.0] {
                    let theta = k as f64 * d_theta + sign * delta;
                    let phi = std::f64::consts::TAU * rng(&mut seed);
                    let big_r = 1.0 + 4.0 * rng(&mut seed);
                    let q = [
                        big_r * theta.sin() * phi.cos(),
                        big_r * theta.sin() * phi.sin(),
                        big_r * theta.cos(),
                    ];
                    // From the source point of cell (0, 0) at distance big_r, the motion
                    // that shows it at q.
                    let r = big_r as f32;
                    let rs = r * trig.st[0];
                    let d = [
                        rs * trig.cp[0] - q[0] as f32,
                        rs * trig.sp[0] - q[1] as f32,
                        r * trig.ct[0] - q[2] as f32,
                    ];
                    let qf = [
                        rs * trig.cp[0] - d[0],
                        rs * trig.sp[0] - d[1],
                        r * trig.ct[0] - d[2],
                    ];
                    let mut dist = vec![f32::INFINITY; np];
                    dist[0] = r;
                    let params = RingParams::new(&trig, 0, d, f32::INFINITY, true);
                    let (mut dest, mut d2) = (vec![0u32; np], vec![0f32; np]);
                    let out = RingOut {
                        dest: &mut dest,
                        dist2: &mut d2,
                    };
                    ring_pass(
                        rad_core::Isa::detect(),
                        false,
                        false,
                        &dist,
                        &terms,
                        &params,
                        0,
                        out,
                    );
                    let exact = trig
                        .cell_of_vector(qf, qf[0] * qf[0] + qf[1] * qf[1] + qf[2] * qf[2])
                        .expect("above the plane");
                    total += 1;
                    if dest[0] & UNSURE == 0 {
                        sure_n += 1;
                        assert_eq!(
                            dest[0] as usize, exact,
                            "{nt} x {np}: θ = edge {k} {sign:+} {delta:e}: a sure cell differs \
                             from the exact path's"
                        );
                    }
                }
            }
        }
    }
    // Most of these points are left to the exact path, but not all.
    assert!(sure_n > 0 && sure_n < total, "{sure_n} of {total} sure");
}
