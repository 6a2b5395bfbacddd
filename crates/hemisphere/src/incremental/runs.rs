//! One item buffer's patch ids as the incremental rows keep them between steps: run-length
//! coded ring by ring (each ring's bytes stand alone, so a ring that did not change is
//! copied, not decoded), with the first and last ring each id is seen in (so a step
//! reads only the rings that can hold what changed).

use rad_core::{PatchId, BACK, ESCAPED};

/// A patch id's place in a table by patch id for `n` patches: the patch's own, then
/// escaped, then back.
#[inline]
pub(super) fn slot_of(id: PatchId, n: usize) -> usize {
    match id {
        ESCAPED => n,
        BACK => n + 1,
        j => j as usize,
    }
}

/// An id a buffer holds, the first and last ring holding it, and how many cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Seen {
    pub id: PatchId,
    pub first: u32,
    pub last: u32,
    pub cells: u32,
}

/// One item buffer's ids, run-length coded: (id, run length), no run crossing the end
/// of a ring; each run two LEB128 varints, the id's zigzag difference from the ring's
/// last run's (from 0 at each ring's start) and the length less one (about 3 bytes a
/// run on a mesh).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(super) struct Runs {
    bytes: Box<[u8]>,
    /// Where each ring's runs start in `bytes`, then their end.
    rings: Box<[u32]>,
    /// Every id held, ascending.
    seen: Box<[Seen]>,
}

impl Runs {
    #[cfg(test)]
    pub fn n_rings(&self) -> usize {
        self.rings.len().saturating_sub(1)
    }

    /// Ring `r`'s coded runs.
    pub fn ring_bytes(&self, r: usize) -> &[u8] {
        &self.bytes[self.rings[r] as usize..self.rings[r + 1] as usize]
    }

    /// Ring `r`'s runs, in order.
    pub fn ring(&self, r: usize) -> RunIter<'_> {
        RunIter {
            bytes: self.ring_bytes(r),
            at: 0,
            last: 0,
        }
    }

    /// Every run, ring after ring.
    #[cfg(test)]
    pub fn iter(&self) -> impl Iterator<Item = (PatchId, u32)> + '_ {
        (0..self.rings.len() - 1).flat_map(move |r| self.ring(r))
    }

    /// The ids held, ascending, with their rings.
    pub fn seen(&self) -> &[Seen] {
        &self.seen
    }

    /// Where `id` is held, if anywhere.
    pub fn find(&self, id: PatchId) -> Option<Seen> {
        let i = self.seen.binary_search_by_key(&id, |s| s.id).ok()?;
        Some(self.seen[i])
    }

    /// The bytes of the runs.
    pub fn coded_bytes(&self) -> usize {
        self.bytes.len()
    }

    /// The bytes the runs and their indexes take.
    pub fn bytes(&self) -> usize {
        self.bytes.len() + std::mem::size_of_val(&*self.rings) + std::mem::size_of_val(&*self.seen)
    }
}

/// The runs of one ring of [`Runs`], in order.
pub(super) struct RunIter<'a> {
    bytes: &'a [u8],
    at: usize,
    last: i64,
}

impl RunIter<'_> {
    #[inline]
    fn varint(&mut self) -> u64 {
        let mut x = 0u64;
        let mut shift = 0;
        loop {
            let b = self.bytes[self.at];
            self.at += 1;
            x |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return x;
            }
            shift += 7;
        }
    }
}

impl Iterator for RunIter<'_> {
    type Item = (PatchId, u32);
    #[inline]
    fn next(&mut self) -> Option<(PatchId, u32)> {
        if self.at >= self.bytes.len() {
            return None;
        }
        let z = self.varint();
        let d = ((z >> 1) as i64) ^ -((z & 1) as i64);
        self.last += d;
        let n = self.varint() as u32 + 1;
        Some((self.last as PatchId, n))
    }
}

/// Writes [`Runs`] ring by ring; cells pushed one after another in a ring that see the
/// same id make one run.
#[derive(Default)]
pub(super) struct RunWriter {
    out: Vec<u8>,
    rings: Vec<u32>,
    last: i64,
    pending: Option<(PatchId, u32)>,
}

impl RunWriter {
    pub fn with_capacity(bytes: usize, rings: usize) -> RunWriter {
        RunWriter {
            out: Vec::with_capacity(bytes),
            rings: Vec::with_capacity(rings + 1),
            ..RunWriter::default()
        }
    }

    #[inline]
    fn put(&mut self, mut x: u64) {
        while x >= 0x80 {
            self.out.push((x & 0x7f) as u8 | 0x80);
            x >>= 7;
        }
        self.out.push(x as u8);
    }

    /// A whole run, written at once (none pending).
    #[inline]
    fn run(&mut self, id: PatchId, n: u32) {
        let d = i64::from(id) - self.last;
        self.last = i64::from(id);
        self.put(((d << 1) ^ (d >> 63)) as u64);
        self.put(u64::from(n - 1));
    }

    fn flush(&mut self) {
        if let Some((id, n)) = self.pending.take() {
            self.run(id, n);
        }
    }

    /// Starts the next ring.
    pub fn ring(&mut self) {
        self.flush();
        self.rings.push(self.out.len() as u32);
        self.last = 0;
    }

    /// `n` more cells of the ring see `id`.
    #[inline]
    pub fn push(&mut self, id: PatchId, n: u32) {
        match &mut self.pending {
            Some((p, m)) if *p == id => *m += n,
            _ => {
                self.flush();
                self.pending = Some((id, n));
            }
        }
    }

    /// The next ring, as another [`Runs`]' coded ring.
    pub fn copy_ring(&mut self, bytes: &[u8]) {
        self.ring();
        self.out.extend_from_slice(bytes);
    }

    /// The runs written, holding the ids of `seen` (ascending).
    pub fn finish(mut self, seen: Box<[Seen]>) -> Runs {
        self.flush();
        self.rings.push(self.out.len() as u32);
        Runs {
            bytes: self.out.into_boxed_slice(),
            rings: self.rings.into_boxed_slice(),
            seen,
        }
    }
}

/// An item buffer's ids (`n_phi` cells a ring) as runs; `slot` is a table by
/// [`slot_of`] of `u32::MAX`, left as it was found. `each(ring, id, n)` hears every run
/// in order.
pub(super) fn encode(
    ids: &[PatchId],
    n_phi: usize,
    slot: &mut [u32],
    mut each: impl FnMut(usize, PatchId, u32),
) -> Runs {
    let n = slot.len() - 2;
    let mut out = RunWriter::with_capacity(ids.len() / 16, ids.len() / n_phi.max(1));
    let mut seen: Vec<Seen> = Vec::new();
    for (ring_index, ring) in ids.chunks(n_phi).enumerate() {
        let r = ring_index as u32;
        out.ring();
        let mut k = 0;
        while k < ring.len() {
            let id = ring[k];
            let m = run_end(ring, k) - k;
            out.run(id, m as u32);
            each(ring_index, id, m as u32);
            let s = &mut slot[slot_of(id, n)];
            if *s == u32::MAX {
                *s = seen.len() as u32;
                seen.push(Seen {
                    id,
                    first: r,
                    last: r,
                    cells: m as u32,
                });
            } else {
                let s = &mut seen[*s as usize];
                s.last = r;
                s.cells += m as u32;
            }
            k += m;
        }
    }
    for s in &seen {
        slot[slot_of(s.id, n)] = u32::MAX;
    }
    seen.sort_unstable_by_key(|s| s.id);
    out.finish(seen.into_boxed_slice())
}

/// Where the run of `ring[k]`'s id that starts at `k` ends.
#[inline]
fn run_end(ring: &[PatchId], k: usize) -> usize {
    let id = ring[k];
    let mut e = k + 1;
    while e + 8 <= ring.len() {
        // (Eight at a time: a compare and a mask.)
        let diff = ring[e..e + 8]
            .iter()
            .enumerate()
            .fold(0u32, |m, (i, &x)| m | (u32::from(x != id) << i));
        if diff != 0 {
            return e + diff.trailing_zeros() as usize;
        }
        e += 8;
    }
    while e < ring.len() && ring[e] == id {
        e += 1;
    }
    e
}

/// `old`'s ids but those of `changed` (ascending), with the changed ones whose rings
/// and cells `span` gives (first, last, cells; no cells: no longer held), ascending.
pub(super) fn merged_seen(
    old: &[Seen],
    changed: &[PatchId],
    span: &[(u32, u32, u32)],
) -> Box<[Seen]> {
    let mut out = Vec::with_capacity(old.len() + changed.len());
    let mut fresh = changed
        .iter()
        .zip(span)
        .filter(|(_, s)| s.2 > 0)
        .map(|(&id, &(first, last, cells))| Seen {
            id,
            first,
            last,
            cells,
        })
        .peekable();
    for &s in old {
        if changed.binary_search(&s.id).is_ok() {
            continue;
        }
        while let Some(f) = fresh.next_if(|f| f.id < s.id) {
            out.push(f);
        }
        out.push(s);
    }
    out.extend(fresh);
    out.into_boxed_slice()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_read_back_as_written() {
        let ids: Vec<PatchId> = [3, 3, 3, 4, 4, 3, 3, 3, 9, ESCAPED, ESCAPED, BACK].to_vec();
        let mut slot = vec![u32::MAX; 12];
        let runs = encode(&ids, 4, &mut slot, |_, _, _| {});
        assert!(slot.iter().all(|&s| s == u32::MAX), "slots left as found");
        assert_eq!(runs.n_rings(), 3);
        assert_eq!(
            runs.iter().collect::<Vec<_>>(),
            [
                (3, 3),
                (4, 1),
                (4, 1),
                (3, 3),
                (9, 1),
                (ESCAPED, 2),
                (BACK, 1)
            ],
            "no run crosses a ring"
        );
        let seen = |id, first, last, cells| Seen {
            id,
            first,
            last,
            cells,
        };
        assert_eq!(
            runs.seen(),
            [
                seen(3, 0, 1, 6),
                seen(4, 0, 1, 2),
                seen(9, 2, 2, 1),
                seen(BACK, 2, 2, 1),
                seen(ESCAPED, 2, 2, 2)
            ]
        );
        assert_eq!(runs.find(9), Some(seen(9, 2, 2, 1)));
        assert_eq!(runs.find(5), None);
        // Rings copied and rewritten read back as the cells they hold.
        let mut w = RunWriter::default();
        w.copy_ring(runs.ring_bytes(0));
        w.ring();
        for (id, n) in [(4, 1), (4, 2), (7, 1)] {
            w.push(id, n);
        }
        w.copy_ring(runs.ring_bytes(2));
        let new = w.finish(merged_seen(
            runs.seen(),
            &[3, 4, 7],
            &[(0, 0, 3), (0, 1, 4), (1, 1, 1)],
        ));
        assert_eq!(
            new.iter().collect::<Vec<_>>(),
            [
                (3, 3),
                (4, 1),
                (4, 3),
                (7, 1),
                (9, 1),
                (ESCAPED, 2),
                (BACK, 1)
            ]
        );
        assert_eq!(
            new.seen(),
            [
                seen(3, 0, 0, 3),
                seen(4, 0, 1, 4),
                seen(7, 1, 1, 1),
                seen(9, 2, 2, 1),
                seen(BACK, 2, 2, 1),
                seen(ESCAPED, 2, 2, 2)
            ]
        );
        assert!(new.bytes() > new.coded_bytes());
        // Far ids and long runs.
        let far = [1 << 20; 4096];
        let mut slot = vec![u32::MAX; (1 << 20) + 3];
        let runs = encode(&far, 4096, &mut slot, |_, _, _| {});
        assert_eq!(runs.iter().collect::<Vec<_>>(), [(1 << 20, 4096)]);
    }
}
