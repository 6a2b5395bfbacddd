//! Rows of a scene with the window schedule: exact hemispheres at window centres,
//! estimated ones elsewhere, in parallel and deterministically.

use crate::config::{EstimatorConfig, Mode};
use crate::estimator::Estimator;
use crate::faithful::Estimate;
use crate::improved::{ImprovedEstimate, Outcome};
use crate::schedule::{Schedule, Window};
use crate::source::SourceHemisphere;
use crate::Error;
use rad_core::PatchId;
use rad_geometry::Scene;
use rad_hemisphere::{Caster, Hemisphere, Row, RowAccumulator};
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};

/// Where a row came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// Ray cast: a window's centre.
    Exact,
    /// Estimated from this patch's exact hemisphere.
    Estimated { from: PatchId },
    /// Improved mode: its estimate needed too many real rays, so it was cast exactly.
    ExactFallback { from: PatchId },
}

/// A row with its provenance.
#[derive(Clone, Debug, PartialEq)]
pub struct EstimatedRow {
    pub row: Row,
    pub source: Source,
    /// Holes filled (estimated rows), and real rays cast by the improved mode.
    pub holes: u32,
    pub real_rays: u32,
}

/// Counts over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EstimateStats {
    pub exact: usize,
    pub estimated: usize,
    pub fallback_exact: usize,
    pub real_rays: u64,
    pub holes: u64,
    pub polygon_tests: u64,
    /// Thread-seconds spent on exact hemispheres (window centres, with their boundary
    /// lists if configured, and their rows).
    pub exact_seconds: f64,
    /// Thread-seconds spent on estimated hemispheres and their rows (improved mode's
    /// exact fallbacks included).
    pub estimate_seconds: f64,
}

impl EstimateStats {
    /// Adds the counts of another run (of other patches).
    pub fn add(&mut self, o: &EstimateStats) {
        self.exact += o.exact;
        self.estimated += o.estimated;
        self.fallback_exact += o.fallback_exact;
        self.real_rays += o.real_rays;
        self.holes += o.holes;
        self.polygon_tests += o.polygon_tests;
        self.exact_seconds += o.exact_seconds;
        self.estimate_seconds += o.estimate_seconds;
    }
}

/// Rows of `patches` by the window schedule `schedule` (of `scene`: [`Schedule::of`]):
/// the exact hemisphere of each window's centre (with boundary lists if configured) and
/// estimates of the others. Windows run in parallel; the result does not depend on the
/// thread count, nor on which other patches are asked for (a window is made whole for
/// any of its patches). `progress(n)` after each window, with the number of rows done
/// so far.
pub fn estimate_rows<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    config: &EstimatorConfig,
    schedule: &Schedule,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Vec<EstimatedRow>, EstimateStats), Error> {
    check(scene, schedule, patches)?;
    let wanted: HashSet<PatchId> = patches.iter().copied().collect();
    let mut which: Vec<usize> = patches.iter().map(|&p| schedule.window_of(p)).collect();
    which.sort_unstable();
    which.dedup();
    let job = WindowsJob {
        scene,
        hemi,
        config,
        schedule,
        windows: &which,
        wanted: &|p| wanted.contains(&p),
    };
    let (made, stats) = estimate_windows(caster, &job, progress)?;
    let mut by_patch: HashMap<PatchId, EstimatedRow> = made.into_iter().collect();
    // (A patch asked for twice gets copies before its last place.)
    let last: HashMap<PatchId, usize> = patches.iter().enumerate().map(|(k, &p)| (p, k)).collect();
    let mut rows = Vec::with_capacity(patches.len());
    for (k, p) in patches.iter().enumerate() {
        let row = if last[p] > k {
            by_patch.get(p).cloned()
        } else {
            by_patch.remove(p)
        };
        rows.push(row.ok_or(Error::Unmade { patch: *p })?);
    }
    Ok((rows, stats))
}

/// Checks that `schedule` is made for a scene of `scene`'s patch count and that
/// `patches` are `scene`'s.
fn check(scene: &Scene, schedule: &Schedule, patches: &[PatchId]) -> Result<(), Error> {
    let n_patches = scene.patches().len();
    if schedule.n_patches() != n_patches {
        return Err(Error::ScheduleMismatch {
            schedule: schedule.n_patches(),
            scene: n_patches,
        });
    }
    if let Some(&bad) = patches.iter().find(|&&p| p as usize >= n_patches) {
        return Err(rad_hemisphere::Error::PatchOutOfRange {
            patch: bad as u64,
            n_patches,
        }
        .into());
    }
    Ok(())
}

/// Windows to make rows of, and which of their patches' rows are wanted.
pub struct WindowsJob<'a> {
    pub scene: &'a Scene,
    pub hemi: &'a Hemisphere,
    pub config: &'a EstimatorConfig,
    /// `scene`'s schedule, and the windows to make (indices into its windows).
    pub schedule: &'a Schedule,
    pub windows: &'a [usize],
    pub wanted: &'a (dyn Fn(PatchId) -> bool + Sync),
}

/// The rows of `job`'s windows' patches that `job.wanted` wants (a window's centre is
/// cast whether wanted or not), window by window, each window's centre first: what
/// [`estimate_rows`] makes, for callers that take rows of whole windows as they come
/// (a stream of rows keeping those of later chunks). Windows run in parallel; the rows
/// do not depend on the thread count. `progress(n)` after each window, with the number
/// of rows done so far.
pub fn estimate_windows<C: Caster>(
    caster: &C,
    job: &WindowsJob,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<(Vec<(PatchId, EstimatedRow)>, EstimateStats), Error> {
    let WindowsJob {
        scene,
        hemi,
        config,
        schedule,
        windows,
        wanted,
    } = *job;
    config.validate()?;
    check(scene, schedule, &[])?;
    let n_windows = schedule.windows().len();
    if let Some(&bad) = windows.iter().find(|&&k| k >= n_windows) {
        return Err(Error::WindowOutOfRange {
            window: bad,
            windows: n_windows,
        });
    }
    let n_patches = scene.patches().len();
    let run = Run {
        scene,
        caster,
        hemi,
        config,
        est: Estimator::new(hemi),
        wanted,
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let per_window: Vec<Vec<Made>> = windows
        .par_iter()
        .map_init(
            || WindowWork {
                scratch: caster.scratch(),
                acc: RowAccumulator::new(n_patches),
                faithful: Estimate::default(),
                improved: ImprovedEstimate::default(),
            },
            |work, &k| {
                let out = run.window(&schedule.windows()[k], work);
                let rows = out.len();
                progress(done.fetch_add(rows, std::sync::atomic::Ordering::Relaxed) + rows);
                out
            },
        )
        .collect();
    Ok(tally(per_window))
}

/// A row made, with its polygon tests and thread-seconds.
type Made = (PatchId, EstimatedRow, u64, f64);

/// What every window of a run shares.
struct Run<'a, C> {
    scene: &'a Scene,
    caster: &'a C,
    hemi: &'a Hemisphere,
    config: &'a EstimatorConfig,
    est: Estimator<'a>,
    wanted: &'a (dyn Fn(PatchId) -> bool + Sync),
}

/// A thread's working memory.
struct WindowWork<S> {
    scratch: S,
    acc: RowAccumulator,
    faithful: Estimate,
    improved: ImprovedEstimate,
}

impl<C: Caster> Run<'_, C> {
    /// The rows wanted of window `w`: its centre's, cast exactly, then its estimates.
    fn window(&self, w: &Window, work: &mut WindowWork<C::Scratch>) -> Vec<Made> {
        let (scene, hemi, config) = (self.scene, self.hemi, self.config);
        let mut out = Vec::new();
        let clock = std::time::Instant::now();
        let src = SourceHemisphere::cast(
            scene,
            self.caster,
            hemi,
            w.centre,
            config.boundary_lists,
            &mut work.scratch,
        );
        if (self.wanted)(w.centre) {
            let row = hemi.row_from_items(w.centre, src.items(), &mut work.acc);
            let exact = EstimatedRow {
                row,
                source: Source::Exact,
                holes: 0,
                real_rays: 0,
            };
            out.push((w.centre, exact, 0, clock.elapsed().as_secs_f64()));
        }
        for &p in w.estimated.iter().filter(|&&p| (self.wanted)(p)) {
            let clock = std::time::Instant::now();
            let (items, holes, real_rays, tests, fallback) = match config.mode {
                Mode::Faithful => {
                    let e = &mut work.faithful;
                    self.est.faithful(scene, &src, p, config, e);
                    (&e.items, e.holes, 0, 0, false)
                }
                Mode::Improved => {
                    let e = &mut work.improved;
                    let outcome = self.est.improved(
                        scene,
                        self.caster,
                        &src,
                        p,
                        config,
                        &mut work.scratch,
                        e,
                    );
                    let cast = outcome == Outcome::CastExactly;
                    (&e.items, e.holes, e.real_rays, e.tests, cast)
                }
            };
            let row = hemi.row_from_items(p, items, &mut work.acc);
            let source = if fallback {
                Source::ExactFallback { from: w.centre }
            } else {
                Source::Estimated { from: w.centre }
            };
            let made = EstimatedRow {
                row,
                source,
                holes: holes as u32,
                real_rays: real_rays as u32,
            };
            out.push((p, made, tests as u64, clock.elapsed().as_secs_f64()));
        }
        out
    }
}

/// The rows made, in the order made, and the run's counts.
fn tally(per_window: Vec<Vec<Made>>) -> (Vec<(PatchId, EstimatedRow)>, EstimateStats) {
    let mut stats = EstimateStats::default();
    let mut out = Vec::new();
    for (p, r, tests, seconds) in per_window.into_iter().flatten() {
        match r.source {
            Source::Exact => {
                stats.exact += 1;
                stats.exact_seconds += seconds;
            }
            Source::Estimated { .. } => {
                stats.estimated += 1;
                stats.estimate_seconds += seconds;
            }
            Source::ExactFallback { .. } => {
                stats.fallback_exact += 1;
                stats.estimate_seconds += seconds;
            }
        }
        stats.real_rays += r.real_rays as u64;
        stats.holes += r.holes as u64;
        stats.polygon_tests += tests;
        out.push((p, r));
    }
    (out, stats)
}
