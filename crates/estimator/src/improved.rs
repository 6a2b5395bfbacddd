//! Visibility estimation: reproject the polygon each cell sees, then resolve every cell
//! of H2 with its own ray against the polygons guessed for it and its 8 neighbours.

use crate::config::{EstimatorConfig, HoleFill};
use crate::faithful::{fill_holes, motion, splat, CellTrig, Estimator, HOLE};
use crate::source::SourceHemisphere;
use rad_core::{PatchId, RayCast};
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, ItemBuffer, NearestHits, BACK, ESCAPED};

/// An estimated hemisphere from the improved mode.
#[derive(Clone, Debug, Default)]
pub struct ImprovedEstimate {
    pub items: ItemBuffer,
    /// Cells nothing landed in, before filling.
    pub holes: usize,
    /// Cells whose guessed polygons all missed (or whose nearest is a back face),
    /// resolved by a real ray.
    pub real_rays: usize,
    /// The estimate needed real rays for over `max_real_ray_share` of its cells and
    /// stopped before casting them (`real_rays` counts the rays it would have needed):
    /// `items` is empty from [`Estimator::improved`], and the patch's exact hemisphere
    /// from [`Estimator::improved_or_cast`].
    pub abandoned: bool,
    /// Ray–polygon tests made (without the real rays' own).
    pub tests: usize,
}

/// Polygon guessed for a cell whose source saw no polygon (escaped or back-facing).
const NO_GUESS: u32 = u32::MAX;

thread_local! {
    /// Per-thread nearest-hit buffers (3.6 MB at 180 × 720), kept between estimates:
    /// a window's estimates share their polygon, hence their world directions.
    static HITS: std::cell::RefCell<NearestHits> = std::cell::RefCell::new(NearestHits::default());
}

impl Estimator<'_> {
    /// Estimates H2 at patch `to` from `src` by visibility estimation.
    pub fn improved<C: RayCast>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
    ) -> ImprovedEstimate {
        estimate_improved_with(
            scene, caster, self.hemi, &self.trig, src, to, config, scratch,
        )
    }
}

impl Estimator<'_> {
    /// [`Estimator::improved`], or, when that is abandoned, the patch's exact hemisphere
    /// cast through `caster` (what the schedule does, and what the mode costs).
    pub fn improved_or_cast<C: RayCast>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
    ) -> ImprovedEstimate {
        let mut e = self.improved(scene, caster, src, to, config, scratch);
        if e.abandoned {
            self.hemi.cast(scene, caster, to, scratch, &mut e.items);
        }
        e
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn estimate_improved_with<C: RayCast>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    trig: &CellTrig,
    src: &SourceHemisphere,
    to: PatchId,
    config: &EstimatorConfig,
    scratch: &mut C::Scratch,
) -> ImprovedEstimate {
    let m = motion(scene, src.patch, to);
    let polygon_of = |id: PatchId| {
        if id == ESCAPED || id == BACK {
            NO_GUESS
        } else {
            scene.patches()[id as usize].polygon
        }
    };
    // 1. Splat polygons (z-buffered), fill holes with the ring neighbour's polygon.
    let mut guess = Vec::new();
    let mut zbuf = Vec::new();
    // Guesses need not be exact: a cell tests its neighbours' guesses too, so the
    // near points' cells come from the polynomial angles without edge corrections
    // (off by one cell within about 1e-5 rad of an edge).
    splat(
        hemi, trig, src, &m, config, true, polygon_of, &mut guess, &mut zbuf,
    );
    let (holes, _) = fill_holes(hemi, &mut guess, HoleFill::RingNeighbour, |c| {
        polygon_of(src.items.patch[c])
    });
    // 2. Resolve each cell with its own ray, against the polygons guessed for it and its
    // 8 neighbours: polygon by polygon over spans of a ring (vectorised, the voxel grid's
    // arithmetic), each polygon tested on the cells it is guessed for, grown by one cell
    // each way (so on every cell that has it among its 3 × 3 guesses), in increasing id
    // order so that ties go to the lower id, as in the grid.
    let target = &scene.patches()[to as usize];
    let own = target.polygon;
    let polygons = scene.polygons();
    let o = target.center;
    let (n_theta, n_phi) = (hemi.n_theta(), hemi.n_phi());
    let mut out = ImprovedEstimate {
        holes,
        ..Default::default()
    };
    // Every polygon's terms for this origin, computed once (a few hundred flops).
    let terms_of: Vec<[f32; 3]> = polygons.iter().map(|p| p.origin_terms(o)).collect();
    let usable = |g: u32| g != NO_GUESS && g != HOLE && g != own;
    // Runs of equal usable guesses, ring by ring: (polygon, first sector, end).
    let mut runs: Vec<(u32, u32, u32)> = Vec::new();
    let mut ring_runs = Vec::with_capacity(n_theta + 1);
    ring_runs.push(0);
    for ring in guess.chunks(n_phi) {
        let mut j = 0;
        while j < n_phi {
            let g = ring[j];
            let mut e = j + 1;
            while e < n_phi && ring[e] == g {
                e += 1;
            }
            if usable(g) {
                runs.push((g, j as u32, e as u32));
            }
            j = e;
        }
        ring_runs.push(runs.len());
    }
    // (A fresh buffer if this thread's is in use: a caster that ran another estimate
    // on this thread from inside `closest_hits_from`.)
    HITS.with(|cell| {
        let mut fresh;
        let mut guard = cell.try_borrow_mut();
        let hits: &mut NearestHits = match guard.as_deref_mut() {
            Ok(h) => h,
            Err(_) => {
                fresh = NearestHits::default();
                &mut fresh
            }
        };
        hits.begin(hemi, scene, own);
        let tests_before = hits.tests;
        let n = n_phi as i64;
        // Per ring: (polygon, first, end) in sectors unwrapped to [−1, n + 1).
        let mut spans: Vec<(u32, i64, i64)> = Vec::new();
        for i in 0..n_theta {
            spans.clear();
            for r in [i.saturating_sub(1), i, (i + 1).min(n_theta - 1)] {
                spans.extend(
                    runs[ring_runs[r]..ring_runs[r + 1]]
                        .iter()
                        .map(|&(g, a, b)| (g, a as i64 - 1, b as i64 + 1)),
                );
            }
            spans.sort_unstable();
            let ring = i * n_phi;
            let mut k = 0;
            while k < spans.len() {
                // Merge the overlapping spans of one polygon.
                let (g, a, mut b) = spans[k];
                k += 1;
                while k < spans.len() && spans[k].0 == g && spans[k].1 <= b {
                    b = b.max(spans[k].2);
                    k += 1;
                }
                let poly = &polygons[g as usize];
                let terms = terms_of[g as usize];
                if b - a >= n {
                    hits.test(poly, g, terms, ring..ring + n_phi);
                    continue;
                }
                // Wrap into [0, n): at most two pieces.
                let (a, b) = (a.rem_euclid(n), a.rem_euclid(n) + (b - a));
                if b <= n {
                    hits.test(poly, g, terms, ring + a as usize..ring + b as usize);
                } else {
                    hits.test(poly, g, terms, ring + a as usize..ring + n_phi);
                    hits.test(poly, g, terms, ring..ring + (b - n) as usize);
                }
            }
        }
        out.tests = (hits.tests - tests_before) as usize;
        // The nearest hit if it is a front one (runs of cells with one polygon looked up
        // together); otherwise (a back face nearest, or no guess hit) a real ray.
        let n_cells = hemi.n_cells();
        let (patch, dist) = (&mut out.items.patch, &mut out.items.dist);
        patch.clear();
        patch.resize(n_cells, ESCAPED);
        dist.clear();
        dist.resize(n_cells, f32::INFINITY);
        let mut real = Vec::new();
        let front = |p: u32| terms_of[p as usize][0] < 0.0;
        hits.items(polygons, front, patch, dist, |cells, _, _| {
            real.extend(cells)
        });
        out.real_rays = real.len();
        if real.len() as f64 > config.max_real_ray_share * n_cells as f64 {
            out.abandoned = true;
            out.items = ItemBuffer::default();
            return;
        }
        if !real.is_empty() {
            let dirs: Vec<glam::Vec3> = real.iter().map(|&c| hits.direction(c)).collect();
            let mut cast = Vec::with_capacity(dirs.len());
            caster.closest_hits_from(o, own, &dirs, scratch, &mut cast);
            for (&c, h) in real.iter().zip(&cast) {
                (patch[c], dist[c]) = match h {
                    Some(h) if h.front => (polygons[h.polygon as usize].patch_at(h.u, h.v), h.t),
                    Some(h) => (BACK, h.t),
                    None => (ESCAPED, f32::INFINITY),
                };
            }
        }
    });
    out
}
