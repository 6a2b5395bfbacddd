//! The z-buffered writes of every build against the plain rule.

use super::NOWHERE;
use crate::test_rng as rng;

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
