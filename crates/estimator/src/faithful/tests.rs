//! The splat's f32 cell lookup against the f64 reference (acos, atan2, `Hemisphere::cell_of`).

use super::{CellTrig, NOWHERE, UNSURE};
use rad_hemisphere::{Hemisphere, HemisphereConfig};

/// A small deterministic generator (xorshift), to avoid a dev-dependency here.
fn rng(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn cell_of_vector_agrees_with_the_f64_formulas_away_from_cell_edges() {
    for (nt, np, shift) in [(180, 720, 0.0), (45, 180, 0.5), (7, 13, 0.25)] {
        let hemi = Hemisphere::new(HemisphereConfig {
            phi_shift: shift,
            ..HemisphereConfig::exact(nt, np)
        })
        .unwrap();
        let trig = CellTrig::new(&hemi);
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let (mut checked, mut skipped) = (0, 0);
        for _ in 0..200_000 {
            let q = [
                2.0 * rng(&mut seed) - 1.0,
                2.0 * rng(&mut seed) - 1.0,
                rng(&mut seed),
            ];
            let r = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            if r < 1e-3 || q[2] <= 1e-6 {
                continue;
            }
            let (theta, phi) = ((q[2] / r).acos(), q[1].atan2(q[0]));
            // Skip points within 1e-5 rad of a cell edge, where f32 may round either way.
            let ft = theta / hemi.d_theta();
            let fp = (phi / hemi.d_phi() - shift).rem_euclid(np as f64);
            let near = |x: f64| (x - x.round()).abs() < 1e-5 / hemi.d_theta().min(hemi.d_phi());
            if near(ft) || near(fp) || theta.sin() < 1e-4 {
                skipped += 1;
                continue;
            }
            let qf = [q[0] as f32, q[1] as f32, q[2] as f32];
            let r2 = qf[0] * qf[0] + qf[1] * qf[1] + qf[2] * qf[2];
            assert_eq!(
                trig.cell_of_vector(qf, r2),
                hemi.cell_of(theta, phi),
                "{nt}x{np} q {q:?}"
            );
            checked += 1;
        }
        assert!(
            checked > 150_000 && skipped < 5_000,
            "{checked} checked, {skipped} skipped"
        );
    }
}

#[test]
fn sector_of_takes_any_angle() {
    for (np, shift) in [(8u32, 0.5), (720, 0.0), (13, 0.25)] {
        let hemi = Hemisphere::new(HemisphereConfig {
            phi_shift: shift,
            ..HemisphereConfig::exact(4, np)
        })
        .unwrap();
        let trig = CellTrig::new(&hemi);
        let n = np as i64;
        for m in -2 * n..4 * n {
            // Cell centres, from two turns below 0 to four turns above.
            let phi = (m as f64 + 0.5 + shift) * hemi.d_phi();
            let want = m.rem_euclid(n) as usize;
            assert_eq!(
                trig.sector_of(phi as f32),
                want,
                "{np} sectors, shift {shift}, phi {phi}"
            );
        }
    }
}

#[test]
fn the_vector_ring_passes_give_the_baseline_answers_bit_for_bit() {
    use super::{exact_path_cell, ring_pass, RingOut, RingParams, SectorTerms};
    use rad_core::Isa;
    let trig = CellTrig::new(&Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap());
    // (On a CPU with only the baseline there is nothing to compare.)
    let n = 720;
    let mut seed = 0x1234_5678_9abc_def1u64;
    let mut v = |lo: f64, hi: f64| (lo + (hi - lo) * rng(&mut seed)) as f32;
    let (ka, kb, a): (Vec<f32>, Vec<f32>, Vec<f32>) = (
        (0..n).map(|_| v(-50.0, 50.0)).collect(),
        (0..n).map(|_| v(-50.0, 50.0)).collect(),
        (0..n).map(|_| v(-0.3, 0.3)).collect(),
    );
    let jc: Vec<f32> = (0..n).map(|j| j as f32 + 0.5).collect();
    let phi: Vec<f32> = (0..n)
        .map(|j| (j as f32 + 0.5) * std::f32::consts::TAU / n as f32)
        .collect();
    let (cp, sp): (Vec<f32>, Vec<f32>) = (
        phi.iter().map(|p| p.cos()).collect(),
        phi.iter().map(|p| p.sin()).collect(),
    );
    // Distances of every kind: near, far, infinite.
    let r: Vec<f32> = (0..n)
        .map(|j| match j % 7 {
            0 => f32::INFINITY,
            1 => v(0.001, 0.05),
            _ => v(0.05, 20.0),
        })
        .collect();
    let terms = SectorTerms {
        ka: &ka,
        kb: &kb,
        jc: &jc,
        a: &a,
        cp: &cp,
        sp: &sp,
    };
    for (st, ct) in [(0.01f32, 0.99995f32), (0.7, 0.714), (0.99995, 0.01)] {
        let params = RingParams {
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
        };
        let ring = 7 * n as u32;
        let run = |isa: Isa, rough: bool| {
            let (mut dest, mut d2) = (vec![0u32; n], vec![0f32; n]);
            let out = RingOut {
                dest: &mut dest,
                dist2: &mut d2,
            };
            ring_pass(isa, rough, true, &r, &terms, &params, ring, out);
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
                    ring_pass(isa, rough, first, &r, &terms, &near, ring, out);
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
    use super::{exact_path_cell, ring_pass, RingOut, RingParams, SectorTerms};
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    let trig = CellTrig::new(&hemi);
    let n = 720;
    let mut seed = 0x0bad_cafe_dead_beefu64;
    let zeros = vec![0.0f32; n];
    let jc: Vec<f32> = (0..n).map(|j| j as f32 + 0.5).collect();
    let terms = SectorTerms {
        ka: &zeros,
        kb: &zeros,
        jc: &jc,
        a: &zeros,
        cp: &trig.cp,
        sp: &trig.sp,
    };
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
        let params = RingParams {
            st: trig.st[i],
            ct: trig.ct[i],
            near_limit: f32::INFINITY, // every point by the exact path
            fi0: i as f32 + 0.5,
            kd: 0.0,
            inv_st: 1.0 / trig.st[i],
            d,
            n,
            n_theta: 180,
            inv_d_theta: trig.inv_d_theta,
            inv_d_phi: trig.inv_d_phi,
            shift: trig.shift,
            fast: true,
            margin_k: super::EDGE_MARGIN * trig.inv_d_theta,
            margin_l: super::EDGE_MARGIN * trig.inv_d_phi,
            cot_k: super::COT_MARGIN * trig.inv_d_theta,
        };
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

/// Hole filling gives the same cells in every build (baseline, AVX2, AVX-512 where the
/// CPU has them), with both policies, on rings of every pattern of holes.
#[test]
fn hole_filling_is_the_same_in_every_build() {
    use super::{fill_holes_body, HOLE};
    use crate::config::HoleFill;
    use rad_core::{Isa, PatchId};
    let mut seed = 0x5eed_f111_0000_0001u64;
    for case in 0..300 {
        let n_phi = [4, 5, 63, 64, 65, 720][case % 6];
        let hemi = Hemisphere::new(HemisphereConfig::exact(7, n_phi as u32)).unwrap();
        let share = rng(&mut seed);
        let ids: Vec<PatchId> = (0..7 * n_phi)
            .map(|_| {
                if rng(&mut seed) < share {
                    HOLE
                } else {
                    (rng(&mut seed) * 5.0) as PatchId
                }
            })
            .collect();
        for fill in [HoleFill::KeepSource, HoleFill::RingNeighbour] {
            let source = |c: usize| 1000 + c as PatchId;
            let mut base = ids.clone();
            let base_holes = fill_holes_body(&hemi, &mut base, fill, source);
            assert!(!base.contains(&HOLE), "case {case}: a hole left");
            for isa in Isa::available() {
                let mut got = ids.clone();
                let holes = super::fill_holes_with(isa, &hemi, &mut got, fill, source);
                assert_eq!(got, base, "case {case}, {isa:?}, {fill:?}");
                assert_eq!(holes.0, base_holes.0);
                assert_eq!(holes.1.to_bits(), base_holes.1.to_bits());
            }
        }
    }
}

/// Next to the pole the exact path's own ring test (cos²θ of the f32 vector against the
/// f32 edges) is ill-conditioned: a rough cell trusted there must still be the cell that
/// test gives. Points just off the first ring edges, at resolutions where the fast path
/// runs (a review found 360 × 1440 failing with a margin blind to this).
#[test]
fn sure_cells_agree_with_the_exact_path_next_to_the_pole() {
    use super::{ring_pass, RingOut, RingParams, SectorTerms};
    let mut seed = 0x9017_e000_0000_0001u64;
    let (mut sure_n, mut total) = (0usize, 0usize);
    for (nt, np) in [(360usize, 1440usize), (785, 3140)] {
        let hemi = Hemisphere::new(HemisphereConfig::exact(nt as u32, np as u32)).unwrap();
        let trig = CellTrig::new(&hemi);
        assert!(
            trig.min_cell >= super::FAST_PATH_MIN_CELL,
            "the fast path runs here"
        );
        let zeros = vec![0.0f32; np];
        let jc: Vec<f32> = (0..np).map(|j| j as f32 + 0.5).collect();
        let terms = SectorTerms {
            ka: &zeros,
            kb: &zeros,
            jc: &jc,
            a: &zeros,
            cp: &trig.cp,
            sp: &trig.sp,
        };
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
                    let params = RingParams {
                        st: trig.st[0],
                        ct: trig.ct[0],
                        near_limit: f32::INFINITY,
                        fi0: 0.5,
                        kd: 0.0,
                        inv_st: 1.0 / trig.st[0],
                        d,
                        n: np,
                        n_theta: nt,
                        inv_d_theta: trig.inv_d_theta,
                        inv_d_phi: trig.inv_d_phi,
                        shift: trig.shift,
                        fast: true,
                        margin_k: super::EDGE_MARGIN * trig.inv_d_theta,
                        margin_l: super::EDGE_MARGIN * trig.inv_d_phi,
                        cot_k: super::COT_MARGIN * trig.inv_d_theta,
                    };
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

/// The z-buffered writes in every build against the plain rule (each cell keeps the
/// smallest key written to it), on rings whose points crowd into a few cells (so that
/// the eight lanes of a group often share a cell, in and out of order), with points
/// that leave the hemisphere and rings not a multiple of eight long.
#[test]
fn z_buffered_writes_keep_the_nearest_in_every_build() {
    use super::put_ring;
    use rad_core::{Isa, PatchId};
    let mut seed = 0x5eed_2b0f_0000_0001u64;
    for case in 0..400 {
        let n = [1, 7, 8, 9, 16, 61, 720][case % 7];
        let n_cells = [1, 3, 17, 1000][(case / 7) % 4];
        let nowhere = rng(&mut seed) * 0.3;
        let dest: Vec<u32> = (0..n)
            .map(|_| {
                if rng(&mut seed) < nowhere {
                    NOWHERE
                } else {
                    (rng(&mut seed) * n_cells as f64) as u32
                }
            })
            .collect();
        // Few distinct distances and values, so that ties are common.
        let dist2: Vec<f32> = (0..n)
            .map(|_| [0.25f32, 1.0, 2.5, f32::INFINITY][(rng(&mut seed) * 4.0) as usize])
            .collect();
        let values: Vec<PatchId> = (0..n).map(|_| (rng(&mut seed) * 6.0) as PatchId).collect();
        let start: Vec<u64> = (0..=n_cells)
            .map(|c| {
                if c % 3 == 0 {
                    super::EMPTY
                } else {
                    (u64::from(1.5f32.to_bits()) << 32) | c as u64
                }
            })
            .collect();
        let mut want = start.clone();
        for j in 0..n {
            let slot = (dest[j] as usize).min(n_cells);
            let key = (u64::from(dist2[j].to_bits()) << 32) | u64::from(values[j]);
            want[slot] = want[slot].min(key);
        }
        for isa in Isa::available() {
            let mut got = start.clone();
            put_ring(isa, &mut got, &dest, &dist2, &values);
            assert_eq!(
                got, want,
                "case {case}, {isa:?}, {n} points into {n_cells} cells"
            );
        }
    }
}
