//! Hole filling: the cells of H2 that nothing landed in, filled from H1 or from the
//! nearest written cell of their ring (`fill_holes`, by cells, for faithful mode;
//! `fill_runs`, by maximal runs, for improved mode's guesses: the same rule).

use crate::config::HoleFill;
use rad_core::{with_isa, Isa, PatchId, HOLE};
use rad_hemisphere::Hemisphere;

/// Fills holes in `ids` (marked `HOLE`) by `fill`, compiled for `isa` (integer work
/// only: the same answers in every build); `source(c)` is H1's entry of cell `c`.
/// Returns the number of holes and their form factor.
pub(crate) fn fill_holes_with(
    isa: Isa,
    hemi: &Hemisphere,
    ids: &mut [PatchId],
    fill: HoleFill,
    source: impl Fn(usize) -> PatchId,
) -> (usize, f64) {
    with_isa!(isa, |ISA| fn(
        hemi: &Hemisphere = hemi,
        ids: &mut [PatchId] = ids,
        fill: HoleFill = fill,
        source: impl Fn(usize) -> PatchId = source,
    ) -> (usize, f64) {
        fill_holes_body(hemi, ids, fill, source)
    })
}

#[inline(always)]
pub(crate) fn fill_holes_body(
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

/// Fills the holes of a ring of `n` cells given by its maximal runs `raw` (at least
/// one hole, at least one written cell) as `HoleFill::RingNeighbour` does, and gives
/// each written run grown over the holes it takes to `emit`: a run takes the nearer half
/// of the holes on each side (of L holes before it, the ⌊L / 2⌋ nearest; of R after
/// it, the ⌈R / 2⌉: the lower φ wins ties). Runs are unwrapped: they may leave [0, n).
pub(crate) fn fill_runs(
    raw: &mut Vec<(u32, i64, i64)>,
    n: i64,
    mut emit: impl FnMut((u32, i64, i64)),
) {
    // Join the runs at each end of the ring if they hold the same value.
    if raw.len() > 1 && raw[0].0 == raw[raw.len() - 1].0 {
        let first = raw.remove(0);
        let last = raw.len() - 1;
        raw[last].2 = n + first.2;
    }
    let k = raw.len();
    let holes = |r: &(u32, i64, i64)| if r.0 == HOLE { r.2 - r.1 } else { 0 };
    for t in 0..k {
        let (g, a, b) = raw[t];
        if g != HOLE {
            let before = holes(&raw[(t + k - 1) % k]);
            let after = holes(&raw[(t + 1) % k]);
            emit((g, a - before / 2, b + (after + 1) / 2));
        }
    }
}

/// The maximal runs of equal values of `ring`: (value, first, end).
pub(crate) fn maximal_runs(ring: &[u32], out: &mut Vec<(u32, i64, i64)>) {
    out.clear();
    let mut j = 0;
    while j < ring.len() {
        let g = ring[j];
        let mut e = j + 1;
        while e < ring.len() && ring[e] == g {
            e += 1;
        }
        out.push((g, j as i64, e as i64));
        j = e;
    }
}

#[cfg(test)]
mod tests;
