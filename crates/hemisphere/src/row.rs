//! Sparse form-factor rows from item buffers, and rows of whole scenes through any
//! caster.

use crate::item_buffer::{ItemBuffer, Viewpoint};
use crate::{Caster, Error, Hemisphere};
use rad_core::{PatchId, RayCast, BACK, ESCAPED};
use rad_geometry::Scene;
use rayon::prelude::*;

/// One row of the form-factor matrix: `F_pj` for every patch j that p sees, sorted by j.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub patch: PatchId,
    pub entries: Vec<(PatchId, f64)>,
    /// Form factor of cells that met a polygon from behind.
    pub back: f64,
    /// Form factor of cells whose ray left the scene.
    pub escaped: f64,
}

impl Row {
    /// Σ_j F_pj (without back and escaped).
    pub fn sum(&self) -> f64 {
        self.entries.iter().map(|e| e.1).sum()
    }

    /// F_pj, 0 where p does not see j.
    pub fn get(&self, j: PatchId) -> f64 {
        self.entries
            .binary_search_by_key(&j, |e| e.0)
            .map(|k| self.entries[k].1)
            .unwrap_or(0.0)
    }
}

/// Dense f64 accumulator for building rows, reused across rows (one per thread).
#[derive(Clone, Debug)]
pub struct RowAccumulator {
    acc: Vec<f64>,
    /// The patches touched, in the order first touched: the first `n_touched` (one slot
    /// more than the patches, written whether or not the patch is new, so that adding
    /// takes no branch: which patch a cell sees first is not predictable).
    touched: Vec<PatchId>,
    n_touched: usize,
    /// The radix sort's second buffer.
    spare: Vec<PatchId>,
}

impl RowAccumulator {
    pub fn new(n_patches: usize) -> RowAccumulator {
        RowAccumulator {
            acc: vec![0.0; n_patches],
            touched: vec![0; n_patches + 1],
            n_touched: 0,
            spare: Vec::new(),
        }
    }

    #[inline]
    pub fn add(&mut self, patch: PatchId, ff: f64) {
        let a = &mut self.acc[patch as usize];
        // (A patch is new while its sum is 0: at most once each, as `ff` > 0, so the
        // count stays within the patches and the slot after them.)
        self.touched[self.n_touched] = patch;
        self.n_touched += (*a == 0.0) as usize;
        *a += ff;
    }

    /// `n` times [`RowAccumulator::add`] of the same form factor: the same bits.
    #[inline]
    pub fn add_run(&mut self, patch: PatchId, ff: f64, n: u32) {
        let a = &mut self.acc[patch as usize];
        self.touched[self.n_touched] = patch;
        self.n_touched += (*a == 0.0) as usize;
        for _ in 0..n {
            *a += ff;
        }
    }

    /// The accumulated entries, sorted by patch; resets the accumulator.
    pub fn take(&mut self) -> Vec<(PatchId, f64)> {
        let touched = &mut self.touched[..self.n_touched];
        if touched.len() < RADIX_FROM {
            touched.sort_unstable();
        } else {
            radix_sort(touched, &mut self.spare, self.acc.len());
        }
        let out = touched
            .iter()
            .map(|&j| (j, std::mem::take(&mut self.acc[j as usize])))
            .collect();
        self.n_touched = 0;
        out
    }
}

/// From how many entries a row's patch ids are sorted by radix (a hemisphere of a
/// mesh sees tens of thousands: four times faster than a comparison sort there).
const RADIX_FROM: usize = 512;

/// Sorts `ids` (each under `n`) in place, by their digits of 11 bits from the lowest
/// (`spare` a buffer): the same order as any sort.
fn radix_sort(ids: &mut [PatchId], spare: &mut Vec<PatchId>, n: usize) {
    const BITS: u32 = 11;
    let top = PatchId::BITS - (n.max(1) as PatchId - 1).leading_zeros();
    spare.clear();
    spare.resize(ids.len(), 0);
    // Each pass from one buffer into the other.
    let (mut from, mut to) = (ids, &mut spare[..]);
    let mut shift = 0;
    while shift < top {
        let mut start = [0u32; (1 << BITS) + 1];
        let digit = |id: PatchId| ((id >> shift) & ((1 << BITS) - 1)) as usize;
        for &id in from.iter() {
            start[digit(id) + 1] += 1;
        }
        for k in 0..1 << BITS {
            start[k + 1] += start[k];
        }
        for &id in from.iter() {
            let d = digit(id);
            to[start[d] as usize] = id;
            start[d] += 1;
        }
        std::mem::swap(&mut from, &mut to);
        shift += BITS;
    }
    // (After an odd number of passes the sorted ids are in `spare`.)
    if (top.div_ceil(BITS)) % 2 == 1 {
        to.copy_from_slice(from);
    }
}

impl Hemisphere {
    /// Casts one ray per cell from the centre of `patch`; fills `buf`.
    pub fn cast<C: RayCast>(
        &self,
        scene: &Scene,
        caster: &C,
        patch: PatchId,
        scratch: &mut C::Scratch,
        buf: &mut ItemBuffer,
    ) {
        self.cast_at(
            scene,
            caster,
            Viewpoint::of_patch(scene, patch),
            scratch,
            buf,
        )
    }

    /// Casts one ray per cell from `at`; fills `buf`.
    pub fn cast_at<C: RayCast>(
        &self,
        scene: &Scene,
        caster: &C,
        at: Viewpoint,
        scratch: &mut C::Scratch,
        buf: &mut ItemBuffer,
    ) {
        let frame = scene.polygons()[at.polygon as usize].frame();
        let polygons = scene.polygons();
        buf.patch.clear();
        buf.dist.clear();
        buf.patch.reserve(self.n_cells());
        buf.dist.reserve(self.n_cells());
        // One ring at a time: directions to world space, then the rays.
        let mut dirs = Vec::with_capacity(self.n_phi());
        let mut hits = Vec::with_capacity(self.n_phi());
        for ring in self.directions().chunks(self.n_phi()) {
            dirs.clear();
            dirs.extend(ring.iter().map(|d| frame.world_from_local(*d)));
            caster.closest_hits_from(at.point, at.polygon, &dirs, scratch, &mut hits);
            for hit in &hits {
                let (id, dist) = match hit {
                    Some(h) if h.front => (polygons[h.polygon as usize].patch_at(h.u, h.v), h.t),
                    Some(h) => (BACK, h.t),
                    None => (ESCAPED, f32::INFINITY),
                };
                buf.patch.push(id);
                buf.dist.push(dist);
            }
        }
    }

    /// Adds `weight` times the form factors of `buf`'s cells to `acc` (patches),
    /// `back` and `escaped`, cell by cell in the order of [`Hemisphere::row_from_items`].
    pub fn accumulate_items(
        &self,
        buf: &ItemBuffer,
        weight: f64,
        acc: &mut RowAccumulator,
        back: &mut f64,
        escaped: &mut f64,
    ) {
        let n_phi = self.n_phi();
        for (ring, ff) in self.ring_form_factors().iter().enumerate() {
            let ff = weight * ff;
            for &id in &buf.patch[ring * n_phi..(ring + 1) * n_phi] {
                match id {
                    ESCAPED => *escaped += ff,
                    BACK => *back += ff,
                    j => acc.add(j, ff),
                }
            }
        }
    }

    /// The row of `patch` from its item buffer.
    pub fn row_from_items(
        &self,
        patch: PatchId,
        buf: &ItemBuffer,
        acc: &mut RowAccumulator,
    ) -> Row {
        let (mut back, mut escaped) = (0.0, 0.0);
        let n_phi = self.n_phi();
        for (ring, ff) in self.ring_form_factors().iter().enumerate() {
            for &id in &buf.patch[ring * n_phi..(ring + 1) * n_phi] {
                match id {
                    ESCAPED => escaped += ff,
                    BACK => back += ff,
                    j => acc.add(j, *ff),
                }
            }
        }
        Row {
            patch,
            entries: acc.take(),
            back,
            escaped,
        }
    }
}

/// Rows of `patches`, computed in parallel (rayon's current pool) from the item
/// buffers `caster` makes; `progress(n)` is called after each row with the number of
/// rows done so far. The result does not depend on the number of threads, nor on the
/// caster (they all give the same item buffers, to the bit).
pub fn compute_rows<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemisphere: &Hemisphere,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Row>, Error> {
    in_parallel(scene, caster, patches, progress, |p, scratch, buf, acc| {
        caster.item_buffer(scene, hemisphere, p, scratch, buf);
        hemisphere.row_from_items(p, buf, acc)
    })
}

/// `row` of each of `patches`, in parallel (rayon's current pool) with per-thread
/// scratch, item buffer and accumulator, after checking the ids; `progress(n)` after
/// each row.
fn in_parallel<C: Caster>(
    scene: &Scene,
    caster: &C,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
    row: impl Fn(PatchId, &mut C::Scratch, &mut ItemBuffer, &mut RowAccumulator) -> Row + Sync,
) -> Result<Vec<Row>, Error> {
    let n_patches = scene.patches().len();
    if let Some(&bad) = patches.iter().find(|&&p| p as usize >= n_patches) {
        return Err(Error::PatchOutOfRange {
            patch: bad as u64,
            n_patches,
        });
    }
    let done = std::sync::atomic::AtomicUsize::new(0);
    Ok(patches
        .par_iter()
        .map_init(
            || {
                (
                    caster.scratch(),
                    ItemBuffer::default(),
                    RowAccumulator::new(n_patches),
                )
            },
            |(scratch, buf, acc), &p| {
                let made = row(p, scratch, buf, acc);
                progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
                made
            },
        )
        .collect())
}

/// The largest number of origins a patch side [`compute_area_rows`] takes (256² = 65,536
/// hemispheres a patch).
pub const MAX_ORIGINS: u32 = 256;

/// Rows of `patches` averaged over `origins × origins` hemispheres a patch, at the points
/// [`rad_geometry::Polygon::patch_origins`] spreads over it, each weighted by its share
/// of the patch's area: F_ij of the patch's area to patch j's, by the midpoint rule over
/// i (where [`compute_rows`] takes i's centre alone: point to area). With `origins = 1`
/// this is [`compute_rows`], to the bit. In parallel over patches, the same whatever
/// the thread count.
pub fn compute_area_rows<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemisphere: &Hemisphere,
    patches: &[PatchId],
    origins: u32,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Row>, Error> {
    if !(1..=MAX_ORIGINS).contains(&origins) {
        return Err(Error::Origins {
            origins: u64::from(origins),
            limit: MAX_ORIGINS,
        });
    }
    if origins == 1 {
        return compute_rows(scene, caster, hemisphere, patches, progress);
    }
    in_parallel(scene, caster, patches, progress, |p, scratch, buf, acc| {
        let patch = &scene.patches()[p as usize];
        let polygon = &scene.polygons()[patch.polygon as usize];
        let (mut back, mut escaped) = (0.0, 0.0);
        for (point, weight) in polygon.patch_origins(patch.cell, origins) {
            let at = Viewpoint {
                point,
                polygon: patch.polygon,
            };
            caster.item_buffer_at(scene, hemisphere, at, scratch, buf);
            hemisphere.accumulate_items(buf, weight, acc, &mut back, &mut escaped);
        }
        Row {
            patch: p,
            entries: acc.take(),
            back,
            escaped,
        }
    })
}

#[cfg(test)]
mod radix_tests {
    /// The radix sort gives the comparison sort's order, repeated ids kept, for
    /// patch counts of one digit and of several (ids up to 2²⁴).
    #[test]
    fn the_radix_sort_sorts() {
        let mut s = 7u64;
        for n in [1usize, 5, 2048, 2049, 115_200, 1 << 24] {
            for len in [0usize, 1, 600, 30_000] {
                let ids: Vec<u32> = (0..len)
                    .map(|_| {
                        s = s
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        ((s >> 33) % n as u64) as u32
                    })
                    .collect();
                let mut want = ids.clone();
                want.sort_unstable();
                let (mut got, mut spare) = (ids, Vec::new());
                super::radix_sort(&mut got, &mut spare, n);
                assert_eq!(got, want, "n {n}, {len} ids");
            }
        }
    }

    /// The accumulator gives each patch once, in order, its values added in the order
    /// given, row after row (short rows and rows sorted by radix), every patch touched
    /// included.
    #[test]
    fn the_accumulator_sums_each_patch_once() {
        let mut s = 11u64;
        for n in [1usize, 700, 115_200] {
            let mut acc = super::RowAccumulator::new(n);
            for len in [0usize, 3, 600, 30_000, 3 * n] {
                let mut want = std::collections::BTreeMap::<u32, f64>::new();
                for _ in 0..len {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let (j, ff) = (((s >> 33) % n as u64) as u32, 1.0 + (s >> 60) as f64);
                    *want.entry(j).or_default() += ff;
                    acc.add(j, ff);
                }
                let got = acc.take();
                assert_eq!(got, want.into_iter().collect::<Vec<_>>(), "n {n}, {len}");
            }
        }
    }
}
