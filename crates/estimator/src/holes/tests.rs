//! Hole filling: every build against the baseline, and filling by runs against filling by cells.

use crate::test_rng as rng;

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

use super::{fill_holes_with, fill_runs, maximal_runs};
use crate::config::HoleFill;
use rad_core::HOLE;
use rad_hemisphere::{Hemisphere, HemisphereConfig};

/// Filling by runs gives, cell for cell, what `fill_holes` gives, on rings of every
/// pattern of holes (wrapping ones included).
#[test]
fn filled_runs_match_fill_holes() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for case in 0..3000 {
        // Short rings, and rings across the hole filling's 64-cell masks.
        let n = match case % 4 {
            0 => [63, 64, 65, 127, 128, 130][(next() % 6) as usize],
            _ => 1 + (next() % 40) as usize,
        };
        let hemi = Hemisphere::new(HemisphereConfig::exact(1, n as u32)).unwrap();
        let hole_share = next() % 100;
        let mut ring: Vec<u32> = (0..n)
            .map(|_| {
                if next() % 100 < hole_share {
                    HOLE
                } else {
                    (next() % 3) as u32
                }
            })
            .collect();
        let written = ring.iter().filter(|&&g| g != HOLE).count();
        if written == 0 || written == n {
            continue;
        }
        let mut raw = Vec::new();
        maximal_runs(&ring, &mut raw);
        let mut got = vec![HOLE; n];
        fill_runs(&mut raw, n as i64, |(g, a, b)| {
            for c in a..b {
                let c = c.rem_euclid(n as i64) as usize;
                assert_eq!(got[c], HOLE, "case {case}: runs overlap at {c}");
                got[c] = g;
            }
        });
        fill_holes_with(
            rad_core::Isa::detect(),
            &hemi,
            &mut ring,
            HoleFill::RingNeighbour,
            |_| unreachable!(),
        );
        assert_eq!(got, ring, "case {case}");
    }
}
