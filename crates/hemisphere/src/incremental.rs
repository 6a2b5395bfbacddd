//! Rows of a scene some of whose polygons moved, from the item buffers of the step
//! before ([`KeptBuffers`]): a patch whose polygon moved is cast whole; of a patch that
//! stayed, only the cells whose rays met a moved polygon (or a back, which names no
//! polygon) and the cells whose rays can meet a moved polygon where it is now (a
//! bounding sphere a polygon, padded past the hit test's tolerance, as a cone of
//! directions: an interval of each ring) are cast again, ray by ray. Every caster gives
//! the same hit a ray, to the bit, so a kept cell holds what casting it anew would give.
//!
//! A row's entry for patch j is the sum, in cell order, of the form factors of the
//! cells that see j: where no cell changed from or to j, it keeps its bits. So only the
//! entries of the patches that cells changed between are summed again (over the runs of
//! cells that see them), and the rows equal [`crate::compute_area_rows`]' over the new
//! scene to the bit (tested).
//!
//! "Moved" is judged on the scene rows are made from, by the bits of each polygon's f32
//! vertices: a polygon whose vertices kept their bits is the same polygon (same terms,
//! frame and patches). A step that changes the scene's largest coordinate divides every
//! vertex by another unit ([`rad_geometry::Scene::for_rows`]): every polygon then moved,
//! and the step is cast whole.

use crate::item_buffer::{ItemBuffer, Viewpoint};
use crate::row::{Row, RowAccumulator};
use crate::scan::NearestHits;
use crate::{Caster, Error, Hemisphere, MAX_ORIGINS};
use glam::DVec3;
use rad_core::{PatchId, PolygonId, BACK, ESCAPED, NO_POLYGON};
use rad_geometry::Scene;
use rayon::prelude::*;

/// One item buffer's patch ids, run-length coded: (id, run length), no run crossing
/// the end of a ring; each run two LEB128 varints, the id's zigzag difference from the
/// last run's and the length less one (about 3 bytes a run on a mesh).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct Runs(Box<[u8]>);

/// Writes [`Runs`] a run at a time.
#[derive(Default)]
struct RunWriter {
    out: Vec<u8>,
    last: i64,
}

impl RunWriter {
    #[inline]
    fn put(&mut self, mut x: u64) {
        while x >= 0x80 {
            self.out.push((x & 0x7f) as u8 | 0x80);
            x >>= 7;
        }
        self.out.push(x as u8);
    }

    #[inline]
    fn push(&mut self, id: PatchId, n: u32) {
        let d = i64::from(id) - self.last;
        self.last = i64::from(id);
        self.put(((d << 1) ^ (d >> 63)) as u64);
        self.put(u64::from(n - 1));
    }

    fn finish(self) -> Runs {
        Runs(self.out.into_boxed_slice())
    }
}

impl Runs {
    fn from_pairs(pairs: &[(PatchId, u32)]) -> Runs {
        let mut w = RunWriter::default();
        for &(id, n) in pairs {
            w.push(id, n);
        }
        w.finish()
    }

    fn iter(&self) -> RunIter<'_> {
        RunIter {
            bytes: &self.0,
            at: 0,
            last: 0,
        }
    }

    fn bytes(&self) -> usize {
        self.0.len()
    }
}

/// The runs of [`Runs`], in order.
struct RunIter<'a> {
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

/// Where a patch would cast again more than this share of its cells' worth of rays, it
/// is cast whole by the caster (the default; [`moved_area_rows_from`] takes another):
/// a choice of speed only, the rows are the same.
pub const WHOLE_FROM: f64 = 0.125;

/// What a cell tested against its kept polygon and the moved ones near it costs, in
/// single rays (measured: a ray through the wide BVH costs 8 to 30 such tests).
const NEAR_PER_RAY: f64 = 8.0;

/// What a patch's last rows kept: its buffers (one an origin) and its row.
#[derive(Clone, Debug)]
struct Kept {
    runs: Box<[Runs]>,
    row: Row,
}

impl Kept {
    fn bytes(&self) -> usize {
        let runs: usize = self.runs.iter().map(Runs::bytes).sum();
        runs + self.row.entries.len() * std::mem::size_of::<(PatchId, f64)>()
    }
}

/// The item buffers and rows of the last step, each patch's, kept to make the next
/// step's.
#[derive(Clone, Debug)]
pub struct KeptBuffers {
    /// The hemisphere (cells, φ shift bits, delta rule) and the origins a patch side
    /// they were made with.
    shape: Option<(usize, usize, u64, bool, u32)>,
    by_patch: Vec<Option<Kept>>,
    /// The most bytes kept: past them, patches (in the order given) keep nothing and
    /// are cast whole at the next step.
    budget: usize,
}

impl Default for KeptBuffers {
    fn default() -> KeptBuffers {
        KeptBuffers::with_budget(usize::MAX)
    }
}

impl KeptBuffers {
    /// Keeping every patch's buffers, however many bytes.
    pub fn new() -> KeptBuffers {
        KeptBuffers::default()
    }

    /// Keeping at most `budget` bytes of buffers and rows.
    pub fn with_budget(budget: usize) -> KeptBuffers {
        KeptBuffers {
            shape: None,
            by_patch: Vec::new(),
            budget,
        }
    }

    /// Patches with buffers kept.
    pub fn len(&self) -> usize {
        self.by_patch.iter().filter(|b| b.is_some()).count()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes the kept runs and rows take.
    pub fn bytes(&self) -> usize {
        self.by_patch.iter().flatten().map(|k| k.bytes()).sum()
    }
}

/// What one step cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecastStats {
    /// Patches cast whole (moved, nothing kept, or too much to cast again), and
    /// patches cast in part.
    pub whole: usize,
    pub partly: usize,
    /// Cells cast (whole patches' included) of the cells of every row made.
    pub cells_cast: u64,
    pub cells: u64,
    /// Patches whose buffers were not kept for the next step (past the budget), and
    /// the bytes kept.
    pub not_kept: usize,
    pub kept_bytes: usize,
}

impl RecastStats {
    /// The share of cells cast again.
    pub fn cast_share(&self) -> f64 {
        self.cells_cast as f64 / self.cells.max(1) as f64
    }
}

/// Which polygons of `now` differ from `before` (their vertices' bits, their grids, their
/// first patch, their sides, or their count): all of them where the polygon or patch
/// counts differ.
pub fn moved_polygons(before: &Scene, now: &Scene) -> Vec<bool> {
    let (a, b) = (before.polygons(), now.polygons());
    if a.len() != b.len() || before.patches().len() != now.patches().len() {
        return vec![true; b.len()];
    }
    a.iter()
        .zip(b)
        .map(|(p, q)| {
            p.vertices().len() != q.vertices().len()
                || p.grid() != q.grid()
                || p.first_patch() != q.first_patch()
                || p.front_only() != q.front_only()
                || (p.vertices().iter().zip(q.vertices()))
                    .any(|(u, v)| u.to_array().map(f32::to_bits) != v.to_array().map(f32::to_bits))
        })
        .collect()
}

/// A sphere holding every point where a ray can be accepted on a polygon.
#[derive(Clone, Copy, Debug)]
struct Bound {
    polygon: PolygonId,
    centre: DVec3,
    radius: f64,
}

/// The rows of `patches` of `scene` (the scene rows are made from, as
/// [`crate::compute_area_rows`] is given), averaged over `origins`² origins: the very
/// rows [`crate::compute_area_rows`] makes, to the bit. `moved` says which polygons
/// differ from the scene `kept` was made on (`None`: every one); patches whose polygon
/// moved, or with nothing kept, go whole through `caster`; the cells of the others that
/// may see otherwise go ray by ray through `rays`. `kept` then holds this step's buffers
/// of `patches` (and no others). In parallel over patches; the same whatever the thread
/// count.
#[allow(clippy::too_many_arguments)]
pub fn moved_area_rows<C: Caster, R: Caster>(
    scene: &Scene,
    caster: &C,
    rays: &R,
    hemi: &Hemisphere,
    patches: &[PatchId],
    origins: u32,
    moved: Option<&[bool]>,
    kept: &mut KeptBuffers,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Vec<Row>, RecastStats), Error> {
    let job = (scene, caster, rays, hemi);
    moved_area_rows_from(job, patches, origins, moved, kept, WHOLE_FROM, progress)
}

/// [`moved_area_rows`], a patch cast whole where casting its cells again would cost more
/// than `whole_from` of its cells in single rays (a ray a cell cast again through
/// `rays`, an eighth of one a cell tested against a few polygons): the pipeline takes
/// less where the whole caster is cheap (the scan of a few polygons) than where it is
/// dear (a hierarchy of a mesh); 1 casts every kept patch in part.
pub fn moved_area_rows_from<C: Caster, R: Caster>(
    (scene, caster, rays, hemi): (&Scene, &C, &R, &Hemisphere),
    patches: &[PatchId],
    origins: u32,
    moved: Option<&[bool]>,
    kept: &mut KeptBuffers,
    whole_from: f64,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Vec<Row>, RecastStats), Error> {
    if !(1..=MAX_ORIGINS).contains(&origins) {
        return Err(Error::Origins {
            origins: u64::from(origins),
            limit: MAX_ORIGINS,
        });
    }
    let n_patches = scene.patches().len();
    if let Some(&bad) = patches.iter().find(|&&p| p as usize >= n_patches) {
        return Err(Error::PatchOutOfRange {
            patch: bad as u64,
            n_patches,
        });
    }
    let c = hemi.config();
    let exact = c.delta == crate::DeltaRule::Exact;
    let shape = (
        hemi.n_theta(),
        hemi.n_phi(),
        c.phi_shift.to_bits(),
        exact,
        origins,
    );
    let usable = kept.shape == Some(shape) && kept.by_patch.len() == n_patches;
    let moved = match moved {
        Some(m) if usable && m.len() == scene.polygons().len() => Some(m),
        _ => None,
    };
    if moved.is_none() {
        kept.by_patch.clear();
    }
    kept.by_patch.resize(n_patches, None);
    kept.shape = Some(shape);
    let step = match moved {
        Some(m) => Moved::new(scene, hemi, m),
        None => Moved::default(),
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let old = &kept.by_patch;
    let made: Vec<(Kept, bool, u64, u64)> = patches
        .par_iter()
        .map_init(
            || {
                let buffers = Buffers {
                    buf: ItemBuffer::default(),
                    acc: RowAccumulator::new(n_patches),
                    dirs: Vec::new(),
                    hits: Vec::new(),
                    near: NearestHits::default(),
                    slot: vec![u32::MAX; n_patches + 2],
                };
                (caster.scratch(), rays.scratch(), buffers)
            },
            |(scratch, ray_scratch, b), &p| {
                let patch = &scene.patches()[p as usize];
                let viewpoints = viewpoints(scene, p, origins);
                let n_cells = (viewpoints.len() * hemi.n_cells()) as u64;
                let before = match (moved, &old[p as usize]) {
                    (Some(m), Some(k))
                        if !m[patch.polygon as usize] && k.runs.len() == viewpoints.len() =>
                    {
                        Some((m, k))
                    }
                    _ => None,
                };
                let again = before.and_then(|(m, k)| {
                    let plans: Vec<Plan> = viewpoints
                        .iter()
                        .zip(k.runs.iter())
                        .map(|(&(at, _), runs)| plan(scene, hemi, at, m, &step, runs))
                        .collect();
                    let total: usize = plans.iter().map(Plan::cells).sum();
                    let cost: f64 = plans
                        .iter()
                        .map(|p| p.rays.len() as f64 + p.near.len() as f64 / NEAR_PER_RAY)
                        .sum();
                    (cost <= whole_from * n_cells as f64).then_some((k, plans, total))
                });
                let made = match again {
                    Some((k, cells, total)) => {
                        let job = Again {
                            scene,
                            hemi,
                            rays,
                            origins,
                        };
                        let made = job.update(p, &viewpoints, k, &cells, ray_scratch, b);
                        (made, false, total as u64, n_cells)
                    }
                    None => {
                        let made = whole(scene, hemi, caster, origins, p, &viewpoints, scratch, b);
                        (made, true, n_cells, n_cells)
                    }
                };
                progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
                made
            },
        )
        .collect();
    Ok(kept.take(patches, made))
}

impl KeptBuffers {
    /// This step's rows, in the order of `patches`, and what they cost; keeps the
    /// patches' buffers within the budget, in that order, and nothing else.
    fn take(
        &mut self,
        patches: &[PatchId],
        made: Vec<(Kept, bool, u64, u64)>,
    ) -> (Vec<Row>, RecastStats) {
        let mut stats = RecastStats::default();
        let mut fresh: Vec<Option<Kept>> = vec![None; self.by_patch.len()];
        let mut rows = Vec::with_capacity(made.len());
        for (&p, (k, whole, cast, cells)) in patches.iter().zip(made) {
            if whole {
                stats.whole += 1;
            } else {
                stats.partly += 1;
            }
            stats.cells_cast += cast;
            stats.cells += cells;
            rows.push(k.row.clone());
            let bytes = k.bytes();
            if stats.kept_bytes + bytes <= self.budget {
                stats.kept_bytes += bytes;
                fresh[p as usize] = Some(k);
            } else {
                stats.not_kept += 1;
            }
        }
        self.by_patch = fresh;
        (rows, stats)
    }
}

/// A thread's working buffers.
struct Buffers {
    buf: ItemBuffer,
    acc: RowAccumulator,
    dirs: Vec<glam::Vec3>,
    hits: Vec<Option<rad_core::Hit>>,
    near: NearestHits,
    /// By patch id (then escaped, back): its index in the changed list, or `u32::MAX`
    /// (cleared after each patch).
    slot: Vec<u32>,
}

/// A patch id's place in [`Buffers::slot`] for `n` patches.
#[inline]
fn slot_of(id: PatchId, n: usize) -> usize {
    match id {
        ESCAPED => n,
        BACK => n + 1,
        j => j as usize,
    }
}

/// The viewpoints of patch `p`'s row and their weights, as [`crate::compute_area_rows`]
/// takes them.
fn viewpoints(scene: &Scene, p: PatchId, origins: u32) -> Vec<(Viewpoint, f64)> {
    if origins == 1 {
        return vec![(Viewpoint::of_patch(scene, p), 1.0)];
    }
    let patch = &scene.patches()[p as usize];
    let polygon = &scene.polygons()[patch.polygon as usize];
    polygon
        .patch_origins(patch.cell, origins)
        .into_iter()
        .map(|(point, w)| {
            let at = Viewpoint {
                point,
                polygon: patch.polygon,
            };
            (at, w)
        })
        .collect()
}

/// Patch `p` cast whole through `caster`: [`crate::compute_area_rows`]' row.
#[allow(clippy::too_many_arguments)]
fn whole<C: Caster>(
    scene: &Scene,
    hemi: &Hemisphere,
    caster: &C,
    origins: u32,
    p: PatchId,
    viewpoints: &[(Viewpoint, f64)],
    scratch: &mut C::Scratch,
    b: &mut Buffers,
) -> Kept {
    let (mut back, mut escaped) = (0.0, 0.0);
    let mut runs = Vec::with_capacity(viewpoints.len());
    for &(at, weight) in viewpoints {
        caster.item_buffer_at(scene, hemi, at, scratch, &mut b.buf);
        runs.push(encode(&b.buf.patch, hemi.n_phi()));
        if origins > 1 {
            hemi.accumulate_items(&b.buf, weight, &mut b.acc, &mut back, &mut escaped);
        }
    }
    // (One origin: compute_rows' row, whose sums take the cells' form factors
    // unweighted.)
    let row = if origins == 1 {
        hemi.row_from_items(p, &b.buf, &mut b.acc)
    } else {
        Row {
            patch: p,
            entries: b.acc.take(),
            back,
            escaped,
        }
    };
    Kept {
        runs: runs.into_boxed_slice(),
        row,
    }
}

/// Casting a kept patch's changed cells again.
struct Again<'a, R> {
    scene: &'a Scene,
    hemi: &'a Hemisphere,
    rays: &'a R,
    origins: u32,
}

impl<R: Caster> Again<'_, R> {
    /// The patch's buffers and row with `cells` (by viewpoint) cast again.
    fn update(
        &self,
        p: PatchId,
        viewpoints: &[(Viewpoint, f64)],
        kept: &Kept,
        plans: &[Plan],
        scratch: &mut R::Scratch,
        b: &mut Buffers,
    ) -> Kept {
        let mut changed: Vec<PatchId> = Vec::new();
        let mut recast = Vec::with_capacity(viewpoints.len());
        for (&(at, _), plan) in viewpoints.iter().zip(plans) {
            if plan.cells() == 0 {
                recast.push((Vec::new(), Vec::new()));
                continue;
            }
            let by_ray = self.cast(at, &plan.rays, scratch, b);
            let near = self.near(at, plan, b);
            // (Both lists in cell order, disjoint: merged.)
            let mut cells = Vec::with_capacity(plan.cells());
            let mut ids = Vec::with_capacity(plan.cells());
            let (mut i, mut j) = (0, 0);
            while i < plan.rays.len() || j < plan.near.len() {
                let (cell, old, new) = if j == plan.near.len()
                    || (i < plan.rays.len() && plan.rays[i] < plan.near[j])
                {
                    i += 1;
                    (plan.rays[i - 1], plan.rays_old[i - 1], by_ray[i - 1])
                } else {
                    j += 1;
                    (plan.near[j - 1], plan.near_old[j - 1], near[j - 1])
                };
                if old != new {
                    changed.push(old);
                    changed.push(new);
                }
                cells.push(cell);
                ids.push(new);
            }
            recast.push((cells, ids));
        }
        if changed.is_empty() {
            // (No cell changed: the same buffers, the same row.)
            return kept.clone();
        }
        changed.sort_unstable();
        changed.dedup();
        // One walk a viewpoint, in order: the new runs, and the sums of the changed
        // patches' cells as the row's sums take them (cell by cell, in order).
        let n_phi = self.hemi.n_phi() as u32;
        let ring_ff = self.hemi.ring_form_factors();
        let mut sums = vec![0.0f64; changed.len()];
        let mut runs = Vec::with_capacity(viewpoints.len());
        let n = self.scene.patches().len();
        let slot = &mut b.slot;
        for (i, &id) in changed.iter().enumerate() {
            slot[slot_of(id, n)] = i as u32;
        }
        for ((&(_, weight), old), (cells, ids)) in
            viewpoints.iter().zip(kept.runs.iter()).zip(&recast)
        {
            let mut add = |id: PatchId, k: u32, start: u32| {
                let i = slot[slot_of(id, n)];
                if i != u32::MAX {
                    let i = i as usize;
                    let ff = ring_ff[(start / n_phi) as usize];
                    let ff = if self.origins == 1 { ff } else { weight * ff };
                    let s = &mut sums[i];
                    for _ in 0..k {
                        *s += ff;
                    }
                }
            };
            if cells.is_empty() {
                let mut at = 0u32;
                for (id, n) in old.iter() {
                    add(id, n, at);
                    at += n;
                }
                runs.push(old.clone());
            } else {
                runs.push(patched(old, n_phi as usize, cells, ids, &mut add));
            }
        }
        for &id in &changed {
            slot[slot_of(id, n)] = u32::MAX;
        }
        let row = settled(p, &kept.row, &changed, &sums);
        Kept {
            runs: runs.into_boxed_slice(),
            row,
        }
    }

    /// The ids of the plan's `near` cells at `at`: each cell's kept polygon (it met no
    /// moved one, so it is the nearest of the polygons that stayed) and the moved
    /// polygons whose cones hold it, tested by the shared hit test with ties to the
    /// lower id: the nearest of all, as a whole cast finds it.
    fn near(&self, at: Viewpoint, plan: &Plan, b: &mut Buffers) -> Vec<PatchId> {
        if plan.near.is_empty() {
            return Vec::new();
        }
        let scene = self.scene;
        let (polygons, patches) = (scene.polygons(), scene.patches());
        self.directions(at, &plan.near, &mut b.dirs);
        let hits = &mut b.near;
        hits.begin_rays(&b.dirs);
        // Each cell's kept polygon, over runs of cells that kept the same one.
        let mut from = 0usize;
        let mut current = NO_POLYGON;
        for (k, &id) in plan.near_old.iter().enumerate() {
            let polygon = match id {
                ESCAPED | BACK => NO_POLYGON,
                j => patches[j as usize].polygon,
            };
            if polygon != current {
                if current != NO_POLYGON {
                    let poly = &polygons[current as usize];
                    hits.test_any_order(poly, current, &poly.terms_at(at.point), from..k);
                }
                (current, from) = (polygon, k);
            }
        }
        if current != NO_POLYGON {
            let poly = &polygons[current as usize];
            hits.test_any_order(
                poly,
                current,
                &poly.terms_at(at.point),
                from..plan.near.len(),
            );
        }
        // Each moved polygon on the near cells of its cone.
        for (m, spans) in &plan.cones {
            let poly = &polygons[*m as usize];
            if *m == at.polygon {
                continue;
            }
            let terms = poly.terms_at(at.point);
            for &(lo, hi) in spans {
                let a = plan.near.partition_point(|&c| c < lo);
                let z = plan.near.partition_point(|&c| c < hi);
                if a < z {
                    hits.test_any_order(poly, *m, &terms, a..z);
                }
            }
        }
        b.hits.clear();
        hits.hits_into(polygons, &b.dirs, &mut b.hits);
        item_ids(polygons, &b.hits)
    }

    /// The world directions of `cells` of the hemisphere at `at`, into `dirs`.
    fn directions(&self, at: Viewpoint, cells: &[u32], dirs: &mut Vec<glam::Vec3>) {
        let frame = self.scene.polygons()[at.polygon as usize].frame();
        let local = self.hemi.directions();
        dirs.clear();
        dirs.extend(
            cells
                .iter()
                .map(|&c| frame.world_from_local(local[c as usize])),
        );
    }

    /// The ids of `cells` cast from `at` through the rays, as [`Hemisphere::cast_at`]
    /// makes each cell.
    fn cast(
        &self,
        at: Viewpoint,
        cells: &[u32],
        scratch: &mut R::Scratch,
        b: &mut Buffers,
    ) -> Vec<PatchId> {
        if cells.is_empty() {
            return Vec::new();
        }
        let polygons = self.scene.polygons();
        self.directions(at, cells, &mut b.dirs);
        self.rays.closest_hits(
            self.scene,
            at.point,
            at.polygon,
            &b.dirs,
            scratch,
            &mut b.hits,
        );
        item_ids(polygons, &b.hits)
    }
}

/// The item buffer's id of each hit, as [`Hemisphere::cast_at`] makes it.
fn item_ids(polygons: &[rad_geometry::Polygon], hits: &[Option<rad_core::Hit>]) -> Vec<PatchId> {
    hits.iter()
        .map(|hit| match hit {
            Some(h) if h.front => polygons[h.polygon as usize].patch_at(h.u, h.v),
            Some(_) => BACK,
            None => ESCAPED,
        })
        .collect()
}

/// `old` with the entries (and back, escaped) of the patches in `changed` (sorted)
/// taken from `sums`.
fn settled(p: PatchId, old: &Row, changed: &[PatchId], sums: &[f64]) -> Row {
    let sum_of = |id: PatchId, old: f64| match changed.binary_search(&id) {
        Ok(i) => sums[i],
        Err(_) => old,
    };
    let mut entries: Vec<(PatchId, f64)> = old
        .entries
        .iter()
        .filter(|e| changed.binary_search(&e.0).is_err())
        .copied()
        .collect();
    entries.extend(
        changed
            .iter()
            .zip(sums)
            .filter(|&(&j, &s)| j != BACK && j != ESCAPED && s > 0.0)
            .map(|(&j, &s)| (j, s)),
    );
    entries.sort_unstable_by_key(|e| e.0);
    Row {
        patch: p,
        entries,
        back: sum_of(BACK, old.back),
        escaped: sum_of(ESCAPED, old.escaped),
    }
}

/// The bounding sphere of each moved polygon of `scene`, padded by how far past its
/// corners its hit test accepts ([`rad_geometry::Polygon::hull_reach`], a sliver's far
/// along it), by 1e-4 of the scene's scale, and by a part in 1e-6 of its radius.
fn moved_bounds(scene: &Scene, moved: &[bool]) -> Vec<Bound> {
    let pad = 1e-4 * f64::from(scene.scale());
    scene
        .polygons()
        .iter()
        .zip(moved)
        .enumerate()
        .filter(|(_, (_, &m))| m)
        .map(|(id, (poly, _))| {
            let vs = poly.vertices();
            let centre = vs.iter().map(|v| v.as_dvec3()).sum::<DVec3>() / vs.len() as f64;
            let radius = vs
                .iter()
                .map(|v| (v.as_dvec3() - centre).length())
                .fold(0.0, f64::max);
            Bound {
                polygon: id as PolygonId,
                centre,
                radius: radius * (1.0 + 1e-6) + poly.hull_reach() + pad,
            }
        })
        .collect()
}

/// What a step's plans share: the moved polygons' bounds, the rings' (sin θ, cos θ)
/// (none if nothing moved), and whether anything moved.
#[derive(Default)]
struct Moved {
    bounds: Vec<Bound>,
    rings: Vec<(f64, f64)>,
    any: bool,
}

impl Moved {
    fn new(scene: &Scene, hemi: &Hemisphere, moved: &[bool]) -> Moved {
        let bounds = moved_bounds(scene, moved);
        let rings = if bounds.is_empty() {
            Vec::new()
        } else {
            (0..hemi.n_theta())
                .map(|r| hemi.theta(r).sin_cos())
                .collect()
        };
        Moved {
            bounds,
            rings,
            any: moved.iter().any(|&m| m),
        }
    }
}

/// What a kept buffer casts again at one viewpoint.
#[derive(Clone, Debug, Default)]
struct Plan {
    /// Cells whose ray met a moved polygon or a back (where any polygon moved): cast
    /// again ray by ray, in cell order; and their kept ids.
    rays: Vec<u32>,
    rays_old: Vec<PatchId>,
    /// The other cells whose ray can meet a moved polygon where it is now, in cell
    /// order: their kept polygon and the moved ones whose cone holds them are tested;
    /// and their kept ids.
    near: Vec<u32>,
    near_old: Vec<PatchId>,
    /// Per moved polygon that may be seen: its id and its cone's cells, as intervals
    /// `[lo, hi)` in cell order.
    cones: Vec<(PolygonId, Vec<(u32, u32)>)>,
}

impl Plan {
    fn cells(&self) -> usize {
        self.rays.len() + self.near.len()
    }
}

/// The cells of the kept buffer `runs` at `at` to cast again ([`Plan`]): one walk over
/// the runs, after the moved polygons' cones.
fn plan(
    scene: &Scene,
    hemi: &Hemisphere,
    at: Viewpoint,
    moved: &[bool],
    step: &Moved,
    runs: &Runs,
) -> Plan {
    let patches = scene.patches();
    let n_cells = hemi.n_cells();
    let n_phi = hemi.n_phi();
    let words = n_cells.div_ceil(64);
    // Each bound's cone of directions, in the patch's frame: for each ring, the
    // interval of azimuths within the cone (padded by a cell either side).
    let frame = scene.polygons()[at.polygon as usize].frame();
    let o = at.point.as_dvec3();
    let (t, bb, n) = (frame.t.as_dvec3(), frame.b.as_dvec3(), frame.n.as_dvec3());
    // (Slack of the cone test: f32 directions stray from the f64 ones by far less.)
    const SLACK: f64 = 1e-4;
    let d_phi = hemi.d_phi();
    let shift = hemi.config().phi_shift;
    let mut in_cone = vec![0u64; words];
    let mut cones = Vec::new();
    for b in &step.bounds {
        let v = b.centre - o;
        let d = v.length();
        let mut spans: Vec<(u32, u32)> = Vec::new();
        if d <= b.radius * 1.01 {
            spans.push((0, n_cells as u32));
        } else {
            let (ax, ay, az) = (t.dot(v) / d, bb.dot(v) / d, n.dot(v) / d);
            let cos_half = (1.0 - (b.radius / d).powi(2)).max(0.0).sqrt() - SLACK;
            let rho = (ax * ax + ay * ay).sqrt();
            let phi_a = ay.atan2(ax);
            for (ring, &(st, ct)) in step.rings.iter().enumerate() {
                let base = (ring * n_phi) as u32;
                // d·a = sinθ ρ cos(φ − φa) + cosθ az ≥ cos(half)
                let need = cos_half - ct * az;
                let span = st * rho;
                if need > span {
                    continue;
                }
                let half = if need <= -span {
                    std::f64::consts::PI
                } else {
                    (need / span).clamp(-1.0, 1.0).acos()
                };
                // Cells whose centre azimuth (j + 0.5 + shift) Δφ lies within half of φa.
                let lo = ((phi_a - half) / d_phi - 0.5 - shift).floor() as i64 - 1;
                let hi = ((phi_a + half) / d_phi - 0.5 - shift).ceil() as i64 + 1;
                if hi - lo + 1 >= n_phi as i64 {
                    spans.push((base, base + n_phi as u32));
                    continue;
                }
                let lo = lo.rem_euclid(n_phi as i64) as u32;
                let hi = hi.rem_euclid(n_phi as i64) as u32;
                if lo <= hi {
                    spans.push((base + lo, base + hi + 1));
                } else {
                    spans.push((base, base + hi + 1));
                    spans.push((base + lo, base + n_phi as u32));
                }
            }
        }
        if spans.is_empty() {
            continue;
        }
        spans.sort_unstable();
        for &(lo, hi) in &spans {
            mark_range(&mut in_cone, lo as usize, hi as usize);
        }
        cones.push((b.polygon, spans));
    }
    // One walk: a run that met a moved polygon (or a back) is cast again whole, ray by
    // ray; of the others, the cells in a cone are tested.
    let any = step.any;
    let mut plan = Plan {
        cones,
        ..Plan::default()
    };
    let mut cell = 0usize;
    for (id, n) in runs.iter() {
        let n = n as usize;
        let again = match id {
            BACK => any,
            ESCAPED => false,
            j => moved[patches[j as usize].polygon as usize],
        };
        if again {
            plan.rays.extend(cell as u32..(cell + n) as u32);
            plan.rays_old.extend(std::iter::repeat_n(id, n));
        } else if !plan.cones.is_empty() {
            for_each_set(&in_cone, cell, cell + n, |c| {
                plan.near.push(c as u32);
                plan.near_old.push(id);
            });
        }
        cell += n;
    }
    plan
}

/// Calls `f` with every set bit of `bits` in `from..to`, in order.
#[inline]
fn for_each_set(bits: &[u64], from: usize, to: usize, mut f: impl FnMut(usize)) {
    let mut c = from;
    while c < to {
        let w = c / 64;
        let mut word = bits[w] >> (c % 64);
        if word == 0 {
            c = (w + 1) * 64;
            continue;
        }
        let end = to.min((w + 1) * 64);
        while word != 0 {
            let k = c + word.trailing_zeros() as usize;
            if k >= end {
                break;
            }
            f(k);
            word &= word - 1;
        }
        c = (w + 1) * 64;
    }
}

/// Sets bits `from..to` of `bits`.
fn mark_range(bits: &mut [u64], from: usize, to: usize) {
    if from >= to {
        return;
    }
    let (first, last) = (from / 64, (to - 1) / 64);
    let lo = !0u64 << (from % 64);
    let hi = !0u64 >> (63 - (to - 1) % 64);
    if first == last {
        bits[first] |= lo & hi;
        return;
    }
    bits[first] |= lo;
    for w in &mut bits[first + 1..last] {
        *w = !0;
    }
    bits[last] |= hi;
}

/// `old` with `cells` (sorted) holding `ids`; `add(id, n, start)` hears every piece of
/// the result in order (a run of `n` cells seeing `id` from cell `start`, within a ring).
fn patched(
    old: &Runs,
    n_phi: usize,
    cells: &[u32],
    ids: &[PatchId],
    add: &mut impl FnMut(PatchId, u32, u32),
) -> Runs {
    let mut out: Vec<(PatchId, u32)> = Vec::with_capacity(old.bytes() / 2 + 2 * cells.len());
    let n_phi = n_phi as u32;
    let mut push = |id: PatchId, n: u32, start: u32| {
        add(id, n, start);
        match out.last_mut() {
            Some((last, m)) if *last == id && !start.is_multiple_of(n_phi) => *m += n,
            _ => out.push((id, n)),
        }
    };
    let (mut at, mut k) = (0u32, 0);
    for (id, n) in old.iter() {
        let end = at + n;
        let mut c = at;
        while k < cells.len() && cells[k] < end {
            let cell = cells[k];
            if cell > c {
                push(id, cell - c, c);
            }
            push(ids[k], 1, cell);
            c = cell + 1;
            k += 1;
        }
        if end > c {
            push(id, end - c, c);
        }
        at = end;
    }
    Runs::from_pairs(&out)
}

/// An item buffer's ids as runs, none crossing the end of a ring.
fn encode(ids: &[PatchId], n_phi: usize) -> Runs {
    let mut out = RunWriter::default();
    for ring in ids.chunks(n_phi) {
        let mut k = 0;
        while k < ring.len() {
            let id = ring[k];
            let mut n = 1;
            while k + n < ring.len() && ring[k + n] == id {
                n += 1;
            }
            out.push(id, n as u32);
            k += n;
        }
    }
    out.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_read_back_as_written() {
        let pairs = vec![
            (7, 3),
            (5, 1),
            (ESCAPED, 700),
            (BACK, 2),
            (0, 1),
            (1 << 25, 129_600),
        ];
        let runs = Runs::from_pairs(&pairs);
        assert_eq!(runs.iter().collect::<Vec<_>>(), pairs);
        assert!(runs.bytes() < 8 * pairs.len());
        let ids: Vec<PatchId> = [3, 3, 3, 4, 4, 3, 3, 3, 9].to_vec();
        let got: Vec<_> = encode(&ids, 4).iter().collect();
        assert_eq!(
            got,
            [(3, 3), (4, 1), (4, 1), (3, 3), (9, 1)],
            "no run crosses a ring"
        );
        let mut pieces = Vec::new();
        let new = patched(&encode(&ids, 4), 4, &[3, 8], &[3, 9], &mut |id, n, at| {
            pieces.push((id, n, at))
        });
        assert_eq!(
            new.iter().collect::<Vec<_>>(),
            [(3, 4), (4, 1), (3, 3), (9, 1)]
        );
        assert_eq!(
            pieces,
            [(3, 3, 0), (3, 1, 3), (4, 1, 4), (3, 3, 5), (9, 1, 8)]
        );
    }
}
