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
//! A step reads only the rings it needs of a kept buffer ([`runs`]: coded ring by ring,
//! with the rings and cells each id is seen in): the rings the cones cross and those
//! holding a moved polygon, to plan; the rings holding a changed id, to sum; rings with
//! no changed cell are copied as they are coded.
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
use runs::{encode, merged_seen, slot_of, RunWriter, Runs};
use std::sync::Arc;

mod runs;

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
    runs: Box<[Arc<Runs>]>,
    row: Row,
}

impl Kept {
    fn bytes(&self) -> usize {
        let runs: usize = self.runs.iter().map(|r| r.bytes()).sum();
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
                    let plans = plans_within(scene, hemi, (m, &step), &viewpoints, k, whole_from)?;
                    let total: usize = plans.iter().map(Plan::cells).sum();
                    Some((k, plans, total))
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

/// The plans of a kept patch's viewpoints, if casting them again costs at most
/// `whole_from` of its cells in single rays (else it is cast whole).
fn plans_within(
    scene: &Scene,
    hemi: &Hemisphere,
    (moved, step): (&[bool], &Moved),
    viewpoints: &[(Viewpoint, f64)],
    kept: &Kept,
    whole_from: f64,
) -> Option<Vec<Plan>> {
    let limit = whole_from * (viewpoints.len() * hemi.n_cells()) as f64;
    // (The cells cast again ray by ray, known from the ids kept: past the limit alone,
    // no plan is made.)
    let rays: u64 = kept
        .runs
        .iter()
        .flat_map(|r| r.seen())
        .filter(|s| met_moved(scene, moved, step.any, s.id))
        .map(|s| u64::from(s.cells))
        .sum();
    if rays as f64 > limit {
        return None;
    }
    let plans: Vec<Plan> = viewpoints
        .iter()
        .zip(kept.runs.iter())
        .map(|(&(at, _), runs)| plan(scene, hemi, at, moved, step, runs))
        .collect();
    let cost: f64 = plans
        .iter()
        .map(|p| p.rays.len() as f64 + p.near.len() as f64 / NEAR_PER_RAY)
        .sum();
    (cost <= limit).then_some(plans)
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
    let ring_ff = hemi.ring_form_factors();
    let n_phi = hemi.n_phi();
    for &(at, weight) in viewpoints {
        caster.item_buffer_at(scene, hemi, at, scratch, &mut b.buf);
        // (The row's sums a run at a time, each cell's form factor added in cell order
        // as `row_from_items` and `accumulate_items` add them: the same bits. One
        // origin: compute_rows' row, whose sums take the cells' form factors unweighted.)
        let acc = &mut b.acc;
        let coded = encode(&b.buf.patch, n_phi, &mut b.slot, |ring, id, n| {
            let ff = if origins == 1 {
                ring_ff[ring]
            } else {
                weight * ring_ff[ring]
            };
            let sum = match id {
                ESCAPED => &mut escaped,
                BACK => &mut back,
                j => return acc.add_run(j, ff, n),
            };
            for _ in 0..n {
                *sum += ff;
            }
        });
        runs.push(Arc::new(coded));
    }
    let row = Row {
        patch: p,
        entries: b.acc.take(),
        back,
        escaped,
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
    /// The patch's buffers and row with the cells of `plans` (by viewpoint) cast again.
    fn update(
        &self,
        p: PatchId,
        viewpoints: &[(Viewpoint, f64)],
        kept: &Kept,
        plans: &[Plan],
        scratch: &mut R::Scratch,
        b: &mut Buffers,
    ) -> Kept {
        let (mut changed, recast) = self.recast(viewpoints, plans, scratch, b);
        if changed.is_empty() {
            // (No cell changed: the same buffers, the same row.)
            return kept.clone();
        }
        changed.sort_unstable();
        changed.dedup();
        // A walk a viewpoint, ring by ring: rings with changed cells written anew, the
        // others copied; and the sums of the changed patches' cells as the row's sums
        // take them (cell by cell, in order), over the rings that hold them, before or
        // now (every cell of a changed id lies in a ring that held it or changed).
        let n_theta = self.hemi.n_theta();
        let n_phi = self.hemi.n_phi() as u32;
        let ring_ff = self.hemi.ring_form_factors();
        let mut sums = vec![0.0f64; changed.len()];
        let mut span = vec![(u32::MAX, 0u32, 0u32); changed.len()];
        let mut walk = vec![0i32; n_theta + 1];
        let mut runs = Vec::with_capacity(viewpoints.len());
        let n = self.scene.patches().len();
        let slot = &mut b.slot;
        for (i, &id) in changed.iter().enumerate() {
            slot[slot_of(id, n)] = i as u32;
        }
        for ((&(_, weight), old), (cells, ids)) in
            viewpoints.iter().zip(kept.runs.iter()).zip(&recast)
        {
            walk.fill(0);
            let mut any = false;
            for &id in &changed {
                if let Some(s) = old.find(id) {
                    walk[s.first as usize] += 1;
                    walk[s.last as usize + 1] -= 1;
                    any = true;
                }
            }
            if !any && cells.is_empty() {
                runs.push(old.clone());
                continue;
            }
            span.fill((u32::MAX, 0, 0));
            let mut add = |id: PatchId, k: u32, ring: usize| {
                let i = slot[slot_of(id, n)];
                if i != u32::MAX {
                    let i = i as usize;
                    let ff = ring_ff[ring];
                    let ff = if self.origins == 1 { ff } else { weight * ff };
                    let s = &mut sums[i];
                    for _ in 0..k {
                        *s += ff;
                    }
                    let sp = &mut span[i];
                    sp.0 = sp.0.min(ring as u32);
                    sp.1 = ring as u32;
                    sp.2 += k;
                }
            };
            let mut out = RunWriter::with_capacity(old.coded_bytes() + 4 * cells.len(), n_theta);
            let (mut depth, mut k) = (0, 0);
            for r in 0..n_theta {
                depth += walk[r];
                let start = r as u32 * n_phi;
                if k < cells.len() && cells[k] < start + n_phi {
                    out.ring();
                    let mut c = start;
                    for (id, m) in old.ring(r) {
                        let end = c + m;
                        while k < cells.len() && cells[k] < end {
                            let cell = cells[k];
                            if cell > c {
                                out.push(id, cell - c);
                                add(id, cell - c, r);
                            }
                            out.push(ids[k], 1);
                            add(ids[k], 1, r);
                            c = cell + 1;
                            k += 1;
                        }
                        if end > c {
                            out.push(id, end - c);
                            add(id, end - c, r);
                        }
                        c = end;
                    }
                } else {
                    out.copy_ring(old.ring_bytes(r));
                    if depth > 0 {
                        for (id, m) in old.ring(r) {
                            add(id, m, r);
                        }
                    }
                }
            }
            let seen = merged_seen(old.seen(), &changed, &span);
            runs.push(Arc::new(out.finish(seen)));
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

    /// The cells of `plans` cast again: each viewpoint's cells whose id changed, in
    /// order, with their new ids; and the ids they changed from and to.
    #[allow(clippy::type_complexity)]
    fn recast(
        &self,
        viewpoints: &[(Viewpoint, f64)],
        plans: &[Plan],
        scratch: &mut R::Scratch,
        b: &mut Buffers,
    ) -> (Vec<PatchId>, Vec<(Vec<u32>, Vec<PatchId>)>) {
        let mut changed: Vec<PatchId> = Vec::new();
        let mut recast = Vec::with_capacity(viewpoints.len());
        for (&(at, _), plan) in viewpoints.iter().zip(plans) {
            let (mut cells, mut ids) = (Vec::new(), Vec::new());
            if plan.cells() > 0 {
                let by_ray = self.cast(at, &plan.rays, scratch, b);
                let near = self.near(at, plan, b);
                // (Both lists in cell order, disjoint: merged.)
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
                        cells.push(cell);
                        ids.push(new);
                    }
                }
            }
            recast.push((cells, ids));
        }
        (changed, recast)
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

/// `old` (its entries by ascending patch) with the entries (and back, escaped) of the
/// patches in `changed` (ascending) taken from `sums`: one merge.
fn settled(p: PatchId, old: &Row, changed: &[PatchId], sums: &[f64]) -> Row {
    let mut entries: Vec<(PatchId, f64)> = Vec::with_capacity(old.entries.len() + changed.len());
    let (mut back, mut escaped) = (old.back, old.escaped);
    let mut fresh = changed.iter().copied().zip(sums.iter().copied()).peekable();
    for &(j, f) in old.entries.iter() {
        while let Some((c, s)) = fresh.next_if(|&(c, _)| c < j) {
            if s > 0.0 {
                entries.push((c, s));
            }
        }
        match fresh.next_if(|&(c, _)| c == j) {
            Some((_, s)) if s > 0.0 => entries.push((j, s)),
            Some(_) => {}
            None => entries.push((j, f)),
        }
    }
    for (c, s) in fresh {
        match c {
            BACK => back = s,
            ESCAPED => escaped = s,
            _ if s > 0.0 => entries.push((c, s)),
            _ => {}
        }
    }
    Row {
        patch: p,
        entries,
        back,
        escaped,
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
    cones: Cones,
}

impl Plan {
    fn cells(&self) -> usize {
        self.rays.len() + self.near.len()
    }
}

/// Whether a cell that met `id` is cast again ray by ray: it met a polygon that moved,
/// or a back while `any` polygon moved.
#[inline]
fn met_moved(scene: &Scene, moved: &[bool], any: bool, id: PatchId) -> bool {
    match id {
        BACK => any,
        ESCAPED => false,
        j => moved[scene.patches()[j as usize].polygon as usize],
    }
}

/// Each moved polygon's cone of directions from `at` (its padded bounding sphere), in
/// the patch's frame: its id and, for each ring, the interval of azimuths within the
/// cone (padded by a cell either side), as cell intervals `[lo, hi)` in order.
fn cones(scene: &Scene, hemi: &Hemisphere, at: Viewpoint, step: &Moved) -> Cones {
    let n_cells = hemi.n_cells();
    let n_phi = hemi.n_phi();
    let frame = scene.polygons()[at.polygon as usize].frame();
    let o = at.point.as_dvec3();
    let (t, bb, n) = (frame.t.as_dvec3(), frame.b.as_dvec3(), frame.n.as_dvec3());
    // (Slack of the cone test: f32 directions stray from the f64 ones by far less.)
    const SLACK: f64 = 1e-4;
    let d_phi = hemi.d_phi();
    let shift = hemi.config().phi_shift;
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
        cones.push((b.polygon, spans));
    }
    cones
}

/// Per moved polygon whose cone is not empty: its id and its cells, as intervals.
type Cones = Vec<(PolygonId, Vec<(u32, u32)>)>;

/// The cells of the kept buffer `runs` at `at` to cast again ([`Plan`]): one walk over
/// the rings that the moved polygons' cones cross or that hold a moved polygon.
fn plan(
    scene: &Scene,
    hemi: &Hemisphere,
    at: Viewpoint,
    moved: &[bool],
    step: &Moved,
    runs: &Runs,
) -> Plan {
    let n_phi = hemi.n_phi();
    let cones = cones(scene, hemi, at, step);
    // The cells in some cone, as disjoint intervals in order.
    let mut in_cone: Vec<(u32, u32)> = cones.iter().flat_map(|(_, s)| s.iter().copied()).collect();
    in_cone.sort_unstable();
    in_cone.dedup_by(|b, a| {
        // (`a` the interval before `b`: merged where they touch.)
        if b.0 <= a.1 {
            a.1 = a.1.max(b.1);
            true
        } else {
            false
        }
    });
    // The rings to read: those the cones cross, and those holding an id met again.
    let again = |id: PatchId| met_moved(scene, moved, step.any, id);
    let n_rings = hemi.n_theta();
    let mut walk = vec![0i32; n_rings + 1];
    for &(lo, hi) in &in_cone {
        walk[lo as usize / n_phi] += 1;
        walk[(hi as usize - 1) / n_phi + 1] -= 1;
    }
    for s in runs.seen() {
        if again(s.id) {
            walk[s.first as usize] += 1;
            walk[s.last as usize + 1] -= 1;
        }
    }
    // One walk over them: a run that met a moved polygon (or a back) is cast again
    // whole, ray by ray; of the others, the cells in a cone are tested.
    let mut plan = Plan {
        cones,
        ..Plan::default()
    };
    let (mut depth, mut iv) = (0, 0);
    for (r, w) in walk[..n_rings].iter().enumerate() {
        depth += w;
        if depth == 0 {
            continue;
        }
        let mut cell = (r * n_phi) as u32;
        for (id, n) in runs.ring(r) {
            let end = cell + n;
            if again(id) {
                plan.rays.extend(cell..end);
                plan.rays_old.extend(std::iter::repeat_n(id, n as usize));
            } else {
                while iv < in_cone.len() && in_cone[iv].1 <= cell {
                    iv += 1;
                }
                let mut j = iv;
                while j < in_cone.len() && in_cone[j].0 < end {
                    let (lo, hi) = (in_cone[j].0.max(cell), in_cone[j].1.min(end));
                    plan.near.extend(lo..hi);
                    plan.near_old
                        .extend(std::iter::repeat_n(id, (hi - lo) as usize));
                    j += 1;
                }
            }
            cell = end;
        }
    }
    plan
}
