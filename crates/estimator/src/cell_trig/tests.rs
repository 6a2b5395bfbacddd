//! The splat's f32 cell lookup against the f64 reference (acos, atan2, `Hemisphere::cell_of`).

use super::CellTrig;
use crate::test_rng as rng;
use rad_hemisphere::{Hemisphere, HemisphereConfig};

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
