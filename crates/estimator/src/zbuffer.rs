//! The splat's z-buffer: one `u64` key a cell (squared distance bits above the value
//! recorded), kept by `min`, so the nearest point wins and ties go to the lower value
//! whatever the order of the writes.

use rad_core::{Isa, PatchId};

/// The z-buffered writes of a ring's points: `keys[c]` (the last key for `NOWHERE`)
/// keeps the smaller of itself and the point's key (its squared distance's bits above
/// its value). Vectorised where the CPU has AVX-512; the same keys in every build, the
/// minimum not depending on the order of the writes.
pub(crate) fn put_ring(
    isa: Isa,
    keys: &mut [u64],
    dest: &[u32],
    dist2: &[f32],
    values: &[PatchId],
) {
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
pub(crate) unsafe fn put_ring_avx512(
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
    pub(crate) keys: Vec<u64>,
}

/// The key of a cell nothing landed in: above every point's (whose distance bits are at
/// most ∞'s); all ones, so that the z-buffer is cleared by `memset`.
pub(crate) const EMPTY: u64 = u64::MAX;

/// No destination: the point left the hemisphere.
pub(crate) const NOWHERE: u32 = u32::MAX;

#[cfg(test)]
mod tests;
