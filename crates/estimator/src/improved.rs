//! Visibility estimation: reproject the polygon each cell sees, then resolve every cell
//! of H2 with its own ray against the polygons guessed for it and its 8 neighbours.

use crate::cell_trig::CellTrig;
use crate::config::EstimatorConfig;
use crate::estimator::{motion, with_thread_buffer, Estimator};
use crate::holes::{fill_runs, maximal_runs};
use crate::source::SourceHemisphere;
use crate::splat::{splat, Points, Splat, Turned};
use crate::zbuffer::ZBuffer;
use rad_core::{Hit, PatchId, PolygonId, BACK, ESCAPED, HOLE, NO_POLYGON};
use rad_geometry::Scene;
use rad_geometry::{Located, OriginTerms};
use rad_hemisphere::{Caster, Hemisphere, ItemBuffer, NearestHits, Viewpoint};

/// What became of an improved estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Estimated from the source hemisphere.
    Estimated,
    /// Abandoned (it needed real rays for over `max_real_ray_share` of its cells), and
    /// the patch's exact hemisphere cast instead.
    CastExactly,
}

/// An estimated hemisphere from the improved mode.
#[derive(Clone, Debug, Default)]
pub struct ImprovedEstimate {
    pub items: ItemBuffer,
    /// Cells of H2 whose guess cell nothing landed in, before filling (a coarse guess
    /// cell counts for the s × s cells it covers).
    pub holes: usize,
    /// Cells whose guessed polygons all missed (or whose nearest is a back face),
    /// resolved by a real ray (or that would have needed one, when the estimate was
    /// abandoned).
    pub real_rays: usize,
    /// Ray–polygon tests made (without the real rays' own).
    pub tests: usize,
}

/// Per-thread working memory, kept between estimates (a few MB at 180 × 720): a
/// window's estimates share their polygon, hence their world directions.
#[derive(Default)]
struct Work {
    hits: NearestHits,
    /// The polygon guessed for each cell (`HOLE` where nothing landed), and the z-buffer.
    guess: Vec<PolygonId>,
    zbuf: ZBuffer,
    /// A ring's maximal runs of equal guesses: (guess, first sector, end).
    raw: Vec<(u32, i64, i64)>,
    /// Coarse guess grids: the polygons of H1's cells other than their point's, with
    /// the guess cell it lands in: (cell, polygon), each a guess of that cell too.
    extras: Vec<(u32, PolygonId)>,
    /// Runs of usable guesses, holes filled and grown by a cell each way, ring by ring
    /// (`ring_runs[i]..ring_runs[i + 1]`), sorted: (polygon << 32 | first sector in
    /// [0, N_φ), end sector, at most first + N_φ).
    runs: Vec<(u64, u32)>,
    ring_runs: Vec<usize>,
    terms: LazyTerms,
    /// Spans of cells guessed a facet of several polygons: (facet, first cell, end),
    /// and a span's located points.
    facet_spans: Vec<(u32, u32, u32)>,
    located: Vec<Located>,
    facet_cells: rad_geometry::LocateScratch,
    real: Vec<usize>,
    dirs: Vec<glam::Vec3>,
    cast: Vec<Option<Hit>>,
}

thread_local! {
    static WORK: std::cell::RefCell<Work> = std::cell::RefCell::new(Work::default());
}

/// Polygons' terms for an estimate's origin, made as polygons are first tested (a mesh's
/// estimate tests a few of its polygons): `terms_of[g]` is this estimate's where
/// `made[g] == estimate`.
#[derive(Default)]
struct LazyTerms {
    terms_of: Vec<rad_geometry::OriginTerms>,
    made: Vec<u32>,
    estimate: u32,
    origin: glam::Vec3,
}

impl LazyTerms {
    /// Starts an estimate from `o` in a scene of `n` polygons.
    fn begin(&mut self, n: usize, o: glam::Vec3) {
        if self.made.len() != n || self.estimate == u32::MAX {
            self.made.clear();
            self.made.resize(n, 0);
            self.terms_of
                .resize(n, rad_geometry::OriginTerms::default());
            self.estimate = 0;
        }
        self.estimate += 1;
        self.origin = o;
    }

    /// Polygon `g`'s terms ([`rad_geometry::Polygon::terms_at`] the origin).
    #[inline]
    fn of(&mut self, polygons: &[rad_geometry::Polygon], g: PolygonId) -> &OriginTerms {
        let g = g as usize;
        if self.made[g] != self.estimate {
            self.made[g] = self.estimate;
            self.terms_of[g] = polygons[g].terms_at(self.origin);
        }
        &self.terms_of[g]
    }

    /// Polygon `g`'s terms, which must have been made this estimate.
    #[inline]
    fn made(&self, g: PolygonId) -> &OriginTerms {
        debug_assert_eq!(self.made[g as usize], self.estimate, "terms made");
        &self.terms_of[g as usize]
    }
}

impl Estimator<'_> {
    /// Estimates H2 at patch `to` from `src` by visibility estimation, into `out`
    /// (reusing its buffers). An estimate that would need real rays for over
    /// `config.max_real_ray_share` of its cells is abandoned before casting them, and
    /// the patch's exact hemisphere is cast through `caster` instead (what the schedule
    /// does, and what the mode costs): the outcome says which.
    #[allow(clippy::too_many_arguments)]
    pub fn improved<C: Caster>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
        out: &mut ImprovedEstimate,
    ) -> Outcome {
        let at = Viewpoint::of_patch(scene, to);
        self.improved_at(scene, caster, src, at, config, scratch, out)
    }

    /// [`Estimator::improved`] at any point of a polygon (in its frame): `to` is on
    /// `src`'s polygon, or on one whose normal points the same way
    /// ([`crate::frame_turn`]).
    #[allow(clippy::too_many_arguments)]
    pub fn improved_at<C: Caster>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: Viewpoint,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
        out: &mut ImprovedEstimate,
    ) -> Outcome {
        let outcome = with_thread_buffer(&WORK, |work| {
            self.improved_with(scene, caster, src, to, config, scratch, work, out)
        });
        if outcome == Outcome::CastExactly {
            caster.item_buffer_at(scene, self.hemi, to, scratch, &mut out.items);
        }
        outcome
    }

    #[allow(clippy::too_many_arguments)]
    fn improved_with<C: Caster>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: Viewpoint,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
        w: &mut Work,
        out: &mut ImprovedEstimate,
    ) -> Outcome {
        let (own, o) = (to.polygon, to.point);
        // The guess grid: the hemisphere's, or coarser (see `guess_stride`).
        let trig = self.trig_strided(config.guess_stride as usize);
        let stride = trig.stride;
        // 1. Splat polygons (z-buffered); 2. runs of guesses ring by ring.
        let (ring_values, turn) = self.splat_guesses(scene, src, to, config, trig, w);
        let own_facet = scene.facets().facet_of(own);
        out.holes =
            w.guess_runs(ring_values, turn, own_facet, trig.n_theta, trig.n_phi) * stride * stride;
        // 3. Resolve each cell against the guesses around it.
        out.tests = w.resolve(scene, self.hemi, own, o, trig);
        // 4. The nearest hit if it is a front one (runs of cells with one polygon looked
        // up together); otherwise (a back face nearest, or no guess hit) a real ray.
        let polygons = scene.polygons();
        let n_cells = self.hemi.n_cells();
        // (`items` writes every cell, the real rays' below: no need to clear.)
        let (patch, dist) = (&mut out.items.patch, &mut out.items.dist);
        patch.resize(n_cells, ESCAPED);
        dist.resize(n_cells, f32::INFINITY);
        let real = &mut w.real;
        real.clear();
        // (A polygon of a facet of several may have been taken without its terms: its
        // facet's plane says which side the origin is on.)
        let (terms, facets) = (&w.terms, scene.facets());
        let front = |p: u32| {
            let f = facets.facet_of(p);
            if facets.is_several(f) {
                facets.plane_num(f, o) < 0.0
            } else {
                terms.made(p).num < 0.0
            }
        };
        w.hits
            .items(scene, front, patch, dist, |cells, _, _| real.extend(cells));
        out.real_rays = real.len();
        if real.len() as f64 > config.max_real_ray_share * n_cells as f64 {
            return Outcome::CastExactly;
        }
        if !real.is_empty() {
            w.dirs.clear();
            w.dirs.extend(real.iter().map(|&c| w.hits.direction(c)));
            caster.closest_hits(scene, o, own, &w.dirs, scratch, &mut w.cast);
            for (&c, h) in real.iter().zip(&w.cast) {
                (patch[c], dist[c]) = match h {
                    Some(h) if h.front => (polygons[h.polygon as usize].patch_at(h.u, h.v), h.t),
                    Some(h) => (BACK, h.t),
                    None => (ESCAPED, f32::INFINITY),
                };
            }
        }
        Outcome::Estimated
    }

    /// Step 1: splats H1's polygons onto the guess grid `trig` into `w.guess`
    /// (z-buffered; coarse grids' other polygons into `w.extras`, by ring); returns the
    /// facets of the points splatted, by guess cell, and the turn of `to`'s frame from
    /// the source's in whole sectors of the guess grid. Guesses need not be exact: a cell
    /// tests its neighbours' guesses too, so the near points' cells come from the
    /// polynomial angles without edge corrections (off by one cell within about 1e-6
    /// rad of an edge).
    fn splat_guesses<'s>(
        &self,
        scene: &Scene,
        src: &'s SourceHemisphere,
        to: Viewpoint,
        config: &EstimatorConfig,
        trig: &CellTrig,
        w: &mut Work,
    ) -> (&'s [PolygonId], i64) {
        let hemi = self.hemi;
        let (m, alpha) = motion(scene, src.viewpoint(scene), to);
        let turned = (alpha != 0.0).then(|| Turned::new(trig, alpha));
        let values = src.facets(scene);
        let points = if trig.stride == 1 {
            Points {
                dist: &src.items().dist,
                values,
                cells: &[],
                extras: &[],
                ring_max: src.ring_max(hemi),
            }
        } else {
            let c = src.coarse(scene, hemi, trig.stride);
            Points {
                dist: &c.dist,
                values: &c.facets,
                cells: &c.cells,
                extras: &c.extras,
                ring_max: &c.ring_max,
            }
        };
        let ring_values = points.values;
        let job = Splat {
            trig,
            src,
            m: &m,
            turned: turned.as_ref(),
            config,
            rough: true,
            points,
        };
        splat(
            job,
            |id| SourceHemisphere::facet_of(scene, id),
            &mut w.guess,
            None,
            &mut w.zbuf,
            &mut w.extras,
        );
        // Extra guesses (coarse grids): by ring.
        w.extras.sort_unstable();
        (ring_values, (alpha / trig.d_phi).round() as i64)
    }
}

impl Work {
    /// Step 2: the runs of usable guesses (not `own`, the target's facet, not a hole,
    /// not nothing) ring by
    /// ring of the guess grid (`n_theta` × `n_phi`), holes filled as
    /// `HoleFill::RingNeighbour` fills them (each hole takes the nearer written cell of
    /// its ring, the lower φ on ties; H1's polygon, `ring_values`, turned by `turn`
    /// sectors, where the whole ring is a hole), grown by a cell each way, into `runs`
    /// and `ring_runs`; returns the number of guess cells that were holes.
    fn guess_runs(
        &mut self,
        ring_values: &[PolygonId],
        turn: i64,
        own: PolygonId,
        n_theta: usize,
        n_phi: usize,
    ) -> usize {
        let w = self;
        let usable = |g: u32| g != NO_POLYGON && g != HOLE && g != own;
        let n = n_phi as i64;
        // A run grown by a cell each way, as a span within a turn: (key, end).
        let span = |(g, a, b): (u32, i64, i64)| {
            let (a, b) = (a - 1, b + 1);
            let (a, b) = if b - a >= n {
                (0, n)
            } else {
                (a.rem_euclid(n), a.rem_euclid(n) + (b - a))
            };
            (u64::from(g) << 32 | a as u64, b as u32)
        };
        let (mut holes, mut extra) = (0, 0);
        w.runs.clear();
        w.ring_runs.clear();
        w.ring_runs.push(0);
        for i in 0..n_theta {
            let ring = &w.guess[i * n_phi..(i + 1) * n_phi];
            maximal_runs(ring, &mut w.raw);
            let n_holes: i64 = w
                .raw
                .iter()
                .filter(|r| r.0 == HOLE)
                .map(|r| r.2 - r.1)
                .sum();
            holes += n_holes as usize;
            if n_holes == n {
                // H1's polygons of this ring's points.
                maximal_runs(&ring_values[i * n_phi..(i + 1) * n_phi], &mut w.raw);
                w.runs.extend(
                    w.raw
                        .iter()
                        .filter(|r| usable(r.0))
                        .map(|&(g, a, b)| span((g, a + turn, b + turn))),
                );
            } else if n_holes == 0 {
                w.runs
                    .extend(w.raw.iter().filter(|r| usable(r.0)).map(|&r| span(r)));
            } else {
                fill_runs(&mut w.raw, n, |r| {
                    if usable(r.0) {
                        w.runs.push(span(r));
                    }
                });
            }
            // This ring's extra guesses, each a run of one cell.
            let ring_cells = (i * n_phi) as u32..((i + 1) * n_phi) as u32;
            while let Some(&(c, g)) = w.extras.get(extra) {
                if !ring_cells.contains(&c) {
                    break;
                }
                extra += 1;
                if usable(g) {
                    let j = (c - ring_cells.start) as i64;
                    w.runs.push(span((g, j, j + 1)));
                }
            }
            let first = w.ring_runs[i];
            w.runs[first..].sort_unstable_by_key(|s| s.0);
            w.ring_runs.push(w.runs.len());
        }
        holes
    }

    /// Step 3: resolves each cell of `hemi` from `o` (on polygon `own`) with its own
    /// ray, against the facets guessed for its guess cell (of `trig`) and that cell's
    /// 8 neighbours: facet by facet over spans of a ring, each tested on the cells it
    /// is guessed for, grown by one guess cell each way (so on every cell that has it
    /// among its 3 × 3 guesses). A facet of one polygon is that polygon's test
    /// (vectorised, the voxel grid's arithmetic), in increasing id order so that ties go
    /// to the lower id, as in the grid; a facet of several (a mesh's flat piece) gives
    /// each cell the polygon that holds its ray's point in the facet's plane
    /// ([`rad_geometry::Facets::locate_span`]: at the plane's distance where the point
    /// is well inside one, by each candidate's own test near an edge), ties then going to
    /// the lower id whatever the order. Each polygon's terms for this origin are made
    /// once, when first needed. Returns the tests made.
    fn resolve(
        &mut self,
        scene: &Scene,
        hemi: &Hemisphere,
        own: PolygonId,
        o: glam::Vec3,
        trig: &CellTrig,
    ) -> usize {
        let w = self;
        let polygons = scene.polygons();
        let (n_theta, stride, fine_n_phi) = (trig.n_theta, trig.stride, hemi.n_phi());
        w.terms.begin(polygons.len(), o);
        // Guesses are facets ([`rad_geometry::Facets`]); where some facet holds several
        // polygons, tests are not made in polygon order, so ties go to the lower id
        // whatever the order (as the grid's rule has it).
        let facets = scene.facets();
        let any_order = facets.len() < polygons.len();
        let hits = &mut w.hits;
        hits.begin(hemi, scene, own);
        let tests_before = hits.tests;
        w.facet_spans.clear();
        for i in 0..n_theta {
            // The spans of rings i − 1, i and i + 1, merged in (polygon, first) order.
            let rings = [i.saturating_sub(1), i, (i + 1).min(n_theta - 1)];
            let mut at = rings.map(|r| w.ring_runs[r]);
            let end = rings.map(|r| w.ring_runs[r + 1]);
            let runs = &w.runs;
            let mut next = || {
                let mut best: Option<usize> = None;
                for k in 0..3 {
                    if at[k] < end[k] && best.is_none_or(|b| runs[at[k]].0 < runs[at[b]].0) {
                        best = Some(k);
                    }
                }
                best.map(|k| {
                    at[k] += 1;
                    runs[at[k] - 1]
                })
            };
            // This guess ring's cells: the hemisphere's rings stride i .. stride (i + 1).
            let fine_rings = stride * i..stride * (i + 1);
            let mut cur = next();
            while let Some((key, mut b)) = cur {
                // Merge the overlapping spans of one polygon.
                let (g, a) = ((key >> 32) as u32, (key & 0xffff_ffff) as usize);
                cur = next();
                while let Some((k2, b2)) = cur {
                    if (k2 >> 32) as u32 != g || (k2 & 0xffff_ffff) as u32 > b {
                        break;
                    }
                    b = b.max(b2);
                    cur = next();
                }
                let (a, b, n) = (stride * a, stride * b as usize, fine_n_phi);
                let members = facets.polygons(g);
                for ring in fine_rings.clone().map(|r| r * n) {
                    let pieces = if b - a >= n {
                        [ring..ring + n, 0..0]
                    } else if b <= n {
                        [ring + a..ring + b, 0..0]
                    } else {
                        // Wrapping round: two pieces.
                        [ring + a..ring + n, ring..ring + (b - n)]
                    };
                    for cells in pieces.into_iter().filter(|r| !r.is_empty()) {
                        if let &[p] = members {
                            let (poly, terms) = (&polygons[p as usize], w.terms.of(polygons, p));
                            if any_order {
                                hits.test_any_order(poly, p, terms, cells);
                            } else {
                                hits.test(poly, p, terms, cells);
                            }
                        } else {
                            // A facet of several polygons: later, facet by facet.
                            w.facet_spans
                                .push((g, cells.start as u32, cells.end as u32));
                        }
                    }
                }
            }
        }
        // The facets of several polygons, each facet's spans together (its grid and
        // polygons stay in cache): each cell's ray tests the polygons that hold its
        // point in the facet's plane, the last one found first (neighbouring cells
        // often see one polygon).
        w.facet_spans.sort_unstable();
        for &(g, a, b) in &w.facet_spans {
            let (a, b) = (a as usize, b as usize);
            facets.locate_span(
                g,
                o,
                hits.directions_of(a..b),
                &hits.best_t()[a..b],
                &mut w.located,
                &mut w.facet_cells,
            );
            let front = facets.plane_num(g, o) < 0.0;
            for (c, &l) in (a..b).zip(&w.located) {
                match l {
                    Located::Outside => {}
                    Located::Clear(p, t) if front && p != own => hits.offer(c, p, t, 0.0, 0.0),
                    _ => facets.for_each_holding(g, o, hits.direction(c), |p| {
                        if p != own {
                            hits.test_cell(&polygons[p as usize], p, w.terms.of(polygons, p), c);
                        }
                    }),
                }
            }
        }
        (hits.tests - tests_before) as usize
    }
}
