//! Rows of a scene by a [`RowMethod`]: the one place that turns a method's name into
//! casters and the estimator.

use crate::{default_estimator, default_grid, CasterKind, Error, RowMethod};
use rad_accel::VoxelGrid;
use rad_core::PatchId;
use rad_estimator::{estimate_rows, estimate_windows, EstimateStats, Schedule, Source, WindowsJob};
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Caster, FacetScan, Hemisphere, Hierarchy, Row, Scan};
use std::collections::HashMap;

/// Rows made by one method.
#[derive(Clone, Debug)]
pub struct Rows {
    pub method: RowMethod,
    /// In the order of the patches asked for.
    pub rows: Vec<Row>,
    /// Per row: the patch it was estimated from, or `None` for a row cast exactly (a
    /// window's centre, or a patch improved mode cast after abandoning its estimate).
    pub sources: Vec<Option<PatchId>>,
    /// Counts of an estimated run (all exact for an exact one).
    pub stats: EstimateStats,
}

/// The rows of `patches` by `method`, in parallel (rayon's current pool), the same
/// whatever the thread count; `progress(n)` is called with the number of rows done so
/// far (after each row, or each window of estimated rows).
pub fn rows(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rows, Error> {
    struct Job<'a> {
        hemi: &'a Hemisphere,
        method: RowMethod,
        patches: &'a [PatchId],
        progress: &'a (dyn Fn(usize) + Sync),
    }
    impl CasterJob for Job<'_> {
        type Out = Rows;
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Rows, Error> {
            let schedule = schedule_for(scene, self.method);
            let made = rows_with(
                scene,
                caster,
                self.hemi,
                self.method,
                schedule.as_ref(),
                self.patches,
                self.progress,
            )?;
            check_finite(&made)?;
            Ok(made)
        }
    }
    with_caster(
        scene,
        method.caster(),
        Job {
            hemi,
            method,
            patches,
            progress,
        },
    )
}

/// Patches a chunk of [`rows_streamed`] holds (the last may hold fewer). A chunk may cut
/// a polygon, and a window with it: the window is made whole for its first chunk, its
/// other rows kept for theirs, so the rows are those of [`rows`]. (Not whole polygons: a
/// polygon of 9,600 patches would make a chunk of 9,600 rows, and what a stream holds
/// would then follow the largest polygon, not the memory limit.)
pub const STREAM_CHUNK: usize = 512;

/// Every patch's row by `method`, made chunk by chunk (each in parallel) and handed to
/// `sink` in patch order as soon as the chunk is done, so that only two chunks are
/// held at a time (one being made, one being taken; estimated rows keep up to
/// [`AHEAD_CHUNKS`] more, made with a window that a chunk cuts, ahead of their chunk); the
/// next chunk is made while `sink` takes the last. The rows, and the order, are those of
/// [`rows`] over every patch; `progress(n)` gets the rows done so far. Returns the run's
/// counts.
pub fn rows_streamed(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    progress: &(dyn Fn(usize) + Sync),
    sink: &mut (dyn FnMut(Rows) -> Result<(), Error> + Send),
) -> Result<EstimateStats, Error> {
    let all: Vec<PatchId> = (0..scene.patches().len() as PatchId).collect();
    rows_streamed_of(scene, hemi, method, &all, progress, sink)
}

/// [`rows_streamed`] over `patches` (in their order, any order; a share of
/// [`crate::share::shares`] lists whole polygons, which keeps windows together): the rows
/// of [`rows`] over `patches`, chunk by chunk.
pub fn rows_streamed_of(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
    sink: &mut (dyn FnMut(Rows) -> Result<(), Error> + Send),
) -> Result<EstimateStats, Error> {
    struct Job<'a, 'b> {
        hemi: &'a Hemisphere,
        method: RowMethod,
        patches: &'a [PatchId],
        progress: &'a (dyn Fn(usize) + Sync),
        sink: &'b mut (dyn FnMut(Rows) -> Result<(), Error> + Send),
    }
    impl CasterJob for Job<'_, '_> {
        type Out = EstimateStats;
        fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<EstimateStats, Error> {
            let mut stats = EstimateStats::default();
            let schedule = schedule_for(scene, self.method);
            let chunks = stream_chunks(self.patches.len());
            let sink = self.sink;
            let ahead = schedule
                .as_ref()
                .map(|_| std::sync::Mutex::new(Ahead::new(scene, self.patches)));
            for_each_chunk(
                &chunks,
                |r| {
                    let base = r.start;
                    let len = r.len();
                    let progress = |k: usize| (self.progress)(base + k.min(len));
                    let made = match (&schedule, &ahead) {
                        (Some(schedule), Some(ahead)) => {
                            let mut ahead = ahead.lock().unwrap_or_else(|e| e.into_inner());
                            let job = (scene, self.hemi, self.method, schedule);
                            ahead.chunk(caster, job, r.clone(), &progress)?
                        }
                        _ => rows_with(
                            scene,
                            caster,
                            self.hemi,
                            self.method,
                            None,
                            &self.patches[r.clone()],
                            &progress,
                        )?,
                    };
                    check_finite(&made)?;
                    Ok(made)
                },
                &mut |made: Rows| {
                    stats.add(&made.stats);
                    sink(made)
                },
            )?;
            Ok(stats)
        }
    }
    with_caster(
        scene,
        method.caster(),
        Job {
            hemi,
            method,
            patches,
            progress,
            sink,
        },
    )
}

/// How far ahead (in chunks of [`STREAM_CHUNK`] patches of the list) a stream of
/// estimated rows makes the rows of a window's other patches, kept until their chunk:
/// a window of a mesh's polygons spans patches far apart in the list, a 3 × 3 window of
/// a polygon three of its rows of patches (about `2 nu` positions), and its centre is
/// cast once for all of them within this reach (beyond it, again: a polygon of over
/// about 768 patches along its `u` side can have its windows' centres cast twice, the
/// rows the same).
pub const AHEAD_CHUNKS: usize = 4;

/// A stream of estimated rows: the rows made ahead of their chunk, by patch.
struct Ahead {
    list: Vec<PatchId>,
    kept: HashMap<PatchId, (Row, Option<PatchId>)>,
    /// By position: where the same patch comes next in the list (`u32::MAX`: never).
    next: Vec<u32>,
    /// By patch: its next position not yet handed out (`u32::MAX`: none).
    pending: Vec<u32>,
}

impl Ahead {
    fn new(scene: &Scene, list: &[PatchId]) -> Ahead {
        let mut pending = vec![u32::MAX; scene.patches().len()];
        let mut next = vec![u32::MAX; list.len()];
        for (k, &p) in list.iter().enumerate().rev() {
            next[k] = pending[p as usize];
            pending[p as usize] = k as u32;
        }
        Ahead {
            list: list.to_vec(),
            kept: HashMap::new(),
            next,
            pending,
        }
    }

    /// The rows of the list's patches `r` (positions), in order: those kept, and those
    /// of the windows of the others, made whole (their centres cast once) for every
    /// patch of the list whose next place is up to [`AHEAD_CHUNKS`] chunks ahead, the
    /// later ones kept (a patch listed again within that reach keeps a copy).
    fn chunk<C: Caster>(
        &mut self,
        caster: &C,
        (scene, hemi, method, schedule): (&Scene, &Hemisphere, RowMethod, &Schedule),
        r: std::ops::Range<usize>,
        progress: &(dyn Fn(usize) + Sync),
    ) -> Result<Rows, Error> {
        let Some(mode) = method.mode() else {
            return Err(Error::Parse {
                what: "row method",
                input: method.name(),
                reason: "windows are made for estimated rows only".into(),
            });
        };
        let mut windows: Vec<usize> = self.list[r.clone()]
            .iter()
            .filter(|p| !self.kept.contains_key(p))
            .map(|&p| schedule.window_of(p))
            .collect();
        windows.sort_unstable();
        windows.dedup();
        let reach = (r.start + AHEAD_CHUNKS * STREAM_CHUNK).max(r.end) as u32;
        let (pending, kept) = (&self.pending, &self.kept);
        let wanted = |p: PatchId| {
            let k = pending[p as usize];
            k >= r.start as u32 && k < reach && !kept.contains_key(&p)
        };
        let config = default_estimator(mode);
        let job = WindowsJob {
            scene,
            hemi,
            config: &config,
            schedule,
            windows: &windows,
            wanted: &wanted,
        };
        let (made, stats) = estimate_windows(caster, &job, progress)?;
        for (p, r) in made {
            let from = match r.source {
                Source::Exact | Source::ExactFallback { .. } => None,
                Source::Estimated { from } => Some(from),
            };
            self.kept.insert(p, (r.row, from));
        }
        let mut rows = Vec::with_capacity(r.len());
        let mut sources = Vec::with_capacity(r.len());
        for k in r.clone() {
            let p = self.list[k];
            let next = self.next[k];
            self.pending[p as usize] = next;
            let made = if next < reach {
                self.kept.get(&p).cloned()
            } else {
                self.kept.remove(&p)
            };
            let Some((row, from)) = made else {
                return Err(rad_estimator::Error::Unmade { patch: p }.into());
            };
            rows.push(row);
            sources.push(from);
        }
        // Rows kept from earlier chunks were not counted as this chunk's windows ran.
        progress(r.len());
        Ok(Rows {
            method,
            rows,
            sources,
            stats,
        })
    }
}

/// Makes each chunk (in parallel inside `make`) and hands it to `sink` in order, the
/// next chunk made while `sink` takes the last: two chunks held at a time.
pub(crate) fn for_each_chunk<T: Send>(
    chunks: &[std::ops::Range<usize>],
    make: impl Fn(&std::ops::Range<usize>) -> Result<T, Error> + Sync,
    sink: &mut (dyn FnMut(T) -> Result<(), Error> + Send),
) -> Result<(), Error> {
    let mut pending: Option<T> = None;
    for chunk in chunks.iter().map(Some).chain([None]) {
        let previous = pending.take();
        let take = || previous.map_or(Ok(()), &mut *sink);
        let (made, taken) = rayon::join(|| chunk.map(&make).transpose(), take);
        taken?;
        pending = made?;
    }
    Ok(())
}

/// The chunks of [`rows_streamed`] over a list of `n` patches: ranges of positions,
/// [`STREAM_CHUNK`] each but the last.
pub(crate) fn stream_chunks(n: usize) -> Vec<std::ops::Range<usize>> {
    (0..n)
        .step_by(STREAM_CHUNK)
        .map(|a| a..(a + STREAM_CHUNK).min(n))
        .collect()
}

/// Work to do with whichever caster a method names, built once, for the scene rows are
/// made from.
pub(crate) trait CasterJob {
    type Out;
    /// `scene` is the scene rows are made from ([`Scene::for_rows`]: the job's scene
    /// divided by its largest coordinate), `caster` built for it.
    fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Self::Out, Error>;
}

/// Builds the caster `kind` names for the scene `scene`'s rows are made from
/// ([`Scene::for_rows`], so that they do not depend on its scale) and runs `job` with
/// both: the one place names become casters.
pub(crate) fn with_caster<J: CasterJob>(
    scene: &Scene,
    kind: CasterKind,
    job: J,
) -> Result<J::Out, Error> {
    let scene = scene.for_rows()?;
    match kind {
        CasterKind::Scan => job.run(scene, &Scan),
        CasterKind::Grid => job.run(scene, &VoxelGrid::build(scene, &default_grid())?),
        CasterKind::Hierarchy => job.run(scene, &Hierarchy::new(scene)),
        CasterKind::Facets => job.run(scene, &FacetScan::new(scene)),
    }
}

/// The patch ids of a chunk, and its progress callback offset to the chunk's start.
pub(crate) fn chunk_patches<'p>(
    r: &std::ops::Range<usize>,
    progress: &'p (dyn Fn(usize) + Sync),
) -> (Vec<PatchId>, impl Fn(usize) + Sync + 'p) {
    let base = r.start;
    (r.clone().map(|p| p as PatchId).collect(), move |k| {
        progress(base + k)
    })
}

/// Refuses rows holding a non-finite value. (Form factors are sums of finite delta form
/// factors: a non-finite one is a bug.)
fn check_finite(made: &Rows) -> Result<(), Error> {
    check_rows(&made.rows)
}

/// [`check_finite`] of bare rows.
pub(crate) fn check_rows(rows: &[Row]) -> Result<(), Error> {
    for r in rows {
        let values = r.entries.iter().map(|e| e.1).chain([r.back, r.escaped]);
        if let Some(v) = values.into_iter().find(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("a form factor of patch {}", r.patch),
                value: v,
                place: "its row",
            });
        }
    }
    Ok(())
}

/// The window schedule of an estimated method (made once a run), or `None`.
fn schedule_for(scene: &Scene, method: RowMethod) -> Option<Schedule> {
    method.mode().map(|_| Schedule::of(scene))
}

/// Rows of `patches` by `method` through `caster`; an estimated method's `schedule` is
/// [`schedule_for`]'s.
fn rows_with<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    method: RowMethod,
    schedule: Option<&Schedule>,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rows, Error> {
    match method.mode() {
        None => {
            let rows = compute_rows(scene, caster, hemi, patches, progress)?;
            let n = rows.len();
            Ok(Rows {
                method,
                rows,
                sources: vec![None; n],
                stats: EstimateStats {
                    exact: n,
                    ..EstimateStats::default()
                },
            })
        }
        Some(mode) => {
            let config = default_estimator(mode);
            let made;
            let schedule = match schedule {
                Some(s) => s,
                None => {
                    made = Schedule::of(scene);
                    &made
                }
            };
            let (rows, stats) =
                estimate_rows(scene, caster, hemi, &config, schedule, patches, progress)?;
            let sources = rows
                .iter()
                .map(|r| match r.source {
                    Source::Exact | Source::ExactFallback { .. } => None,
                    Source::Estimated { from } => Some(from),
                })
                .collect();
            Ok(Rows {
                method,
                rows: rows.into_iter().map(|r| r.row).collect(),
                sources,
                stats,
            })
        }
    }
}
