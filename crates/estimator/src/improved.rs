//! Visibility estimation: reproject the polygon each cell sees, then resolve every cell
//! of H2 with its own ray against the polygons guessed for it and its 8 neighbours.

use crate::config::EstimatorConfig;
use crate::faithful::{motion, splat, Estimator, Points, ZBuffer};
use crate::source::SourceHemisphere;
use rad_core::{Hit, PatchId, PolygonId, BACK, ESCAPED, HOLE, NO_POLYGON};
use rad_geometry::Scene;
use rad_hemisphere::{Caster, ItemBuffer, NearestHits};

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
    terms_of: Vec<rad_geometry::OriginTerms>,
    real: Vec<usize>,
    dirs: Vec<glam::Vec3>,
    cast: Vec<Option<Hit>>,
}

thread_local! {
    static WORK: std::cell::RefCell<Work> = std::cell::RefCell::new(Work::default());
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
        // (A fresh buffer if this thread's is in use: a caster that ran another estimate
        // on this thread from inside `closest_hits`.)
        let outcome = WORK.with(|cell| match cell.try_borrow_mut() {
            Ok(mut work) => {
                self.improved_with(scene, caster, src, to, config, scratch, &mut work, out)
            }
            Err(_) => self.improved_with(
                scene,
                caster,
                src,
                to,
                config,
                scratch,
                &mut Work::default(),
                out,
            ),
        });
        if outcome == Outcome::CastExactly {
            caster.item_buffer(scene, self.hemi, to, scratch, &mut out.items);
        }
        outcome
    }

    #[allow(clippy::too_many_arguments)]
    fn improved_with<C: Caster>(
        &self,
        scene: &Scene,
        caster: &C,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        scratch: &mut C::Scratch,
        w: &mut Work,
        out: &mut ImprovedEstimate,
    ) -> Outcome {
        let hemi = self.hemi;
        let m = motion(scene, src.patch(), to);
        let target = &scene.patches()[to as usize];
        let own = target.polygon;
        let polygons = scene.polygons();
        let o = target.center;
        // The guess grid: the hemisphere's, or coarser (see `guess_stride`).
        let trig = self.trig_strided(config.guess_stride as usize);
        let stride = trig.stride;
        let (n_theta, n_phi) = (trig.n_theta, trig.n_phi);
        let fine_n_phi = hemi.n_phi();
        // 1. Splat polygons (z-buffered). Guesses need not be exact: a cell tests its
        // neighbours' guesses too, so the near points' cells come from the polynomial
        // angles without edge corrections (off by one cell within about 1e-6 rad of an
        // edge).
        let values = src.polygons(scene);
        let points = if stride == 1 {
            Points {
                dist: &src.items().dist,
                values,
                cells: &[],
                extras: &[],
                ring_max: src.ring_max(hemi),
            }
        } else {
            let c = src.coarse(scene, hemi, stride);
            Points {
                dist: &c.dist,
                values: &c.polygons,
                cells: &c.cells,
                extras: &c.extras,
                ring_max: &c.ring_max,
            }
        };
        let ring_values = points.values;
        splat(
            trig,
            src,
            &m,
            config,
            true,
            points,
            |id| SourceHemisphere::polygon_of(scene, id),
            &mut w.guess,
            None,
            &mut w.zbuf,
            &mut w.extras,
        );
        // Extra guesses (coarse grids): by ring.
        w.extras.sort_unstable();
        // 2. Runs of guesses ring by ring, holes filled as `HoleFill::RingNeighbour`
        // fills them (each hole takes the nearer written cell of its ring, the lower φ
        // on ties; H1's polygon where the whole ring is a hole).
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
                w.runs
                    .extend(w.raw.iter().filter(|r| usable(r.0)).map(|&r| span(r)));
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
        out.holes = holes * stride * stride;
        // 3. Resolve each cell with its own ray, against the polygons guessed for its
        // guess cell and that cell's 8 neighbours: polygon by polygon over spans of a
        // ring (vectorised, the voxel grid's arithmetic), each polygon tested on the
        // cells it is guessed for, grown by one guess cell each way (so on every cell
        // that has it among its 3 × 3 guesses), in increasing id order so that ties go
        // to the lower id, as in the grid. Every polygon's terms for this origin are
        // computed once.
        w.terms_of.clear();
        w.terms_of.extend(polygons.iter().map(|p| p.terms().at(o)));
        let hits = &mut w.hits;
        hits.begin(hemi, scene, own);
        let tests_before = hits.tests;
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
                let (poly, terms) = (&polygons[g as usize], &w.terms_of[g as usize]);
                let (a, b, n) = (stride * a, stride * b as usize, fine_n_phi);
                for ring in fine_rings.clone().map(|r| r * n) {
                    if b - a >= n {
                        hits.test(poly, g, terms, ring..ring + n);
                    } else if b <= n {
                        hits.test(poly, g, terms, ring + a..ring + b);
                    } else {
                        // Wrapping round: two pieces.
                        hits.test(poly, g, terms, ring + a..ring + n);
                        hits.test(poly, g, terms, ring..ring + (b - n));
                    }
                }
            }
        }
        out.tests = (hits.tests - tests_before) as usize;
        // 4. The nearest hit if it is a front one (runs of cells with one polygon looked
        // up together); otherwise (a back face nearest, or no guess hit) a real ray.
        let n_cells = hemi.n_cells();
        // (`items` writes every cell, the real rays' below: no need to clear.)
        let (patch, dist) = (&mut out.items.patch, &mut out.items.dist);
        patch.resize(n_cells, ESCAPED);
        dist.resize(n_cells, f32::INFINITY);
        let real = &mut w.real;
        real.clear();
        let terms_of = &w.terms_of;
        let front = |p: u32| terms_of[p as usize].num < 0.0;
        hits.items(polygons, front, patch, dist, |cells, _, _| {
            real.extend(cells)
        });
        out.real_rays = real.len();
        if real.len() as f64 > config.max_real_ray_share * n_cells as f64 {
            return Outcome::CastExactly;
        }
        if !real.is_empty() {
            w.dirs.clear();
            w.dirs.extend(real.iter().map(|&c| hits.direction(c)));
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
}

/// Fills the holes of a ring of `n` cells given by its maximal runs `raw` (at least
/// one hole, at least one written cell) as `HoleFill::RingNeighbour` does, and gives
/// each written run grown over the holes it takes to `emit`: a run takes the nearer half
/// of the holes on each side (of L holes before it, the ⌊L / 2⌋ nearest; of R after
/// it, the ⌈R / 2⌉: the lower φ wins ties). Runs are unwrapped: they may leave [0, n).
fn fill_runs(raw: &mut Vec<(u32, i64, i64)>, n: i64, mut emit: impl FnMut((u32, i64, i64))) {
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
fn maximal_runs(ring: &[u32], out: &mut Vec<(u32, i64, i64)>) {
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
mod tests {
    use super::{fill_runs, maximal_runs, HOLE};
    use crate::config::HoleFill;
    use crate::faithful::fill_holes;
    use rad_hemisphere::{Hemisphere, HemisphereConfig};

    /// Filling by runs gives, cell for cell, what `fill_holes` gives, on rings of every
    /// pattern of holes (wrapping ones included).
    #[test]
    fn filled_runs_match_fill_holes() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for case in 0..3000 {
            // Short rings, and rings across the hole filling's 64-cell masks.
            let n = match case % 4 {
                0 => [63, 64, 65, 127, 128, 130][(next() % 6) as usize],
                _ => 1 + (next() % 40) as usize,
            };
            let hemi = Hemisphere::new(HemisphereConfig::exact(1, n as u32)).unwrap();
            let hole_share = next() % 100;
            let mut ring: Vec<u32> = (0..n)
                .map(|_| {
                    if next() % 100 < hole_share {
                        HOLE
                    } else {
                        (next() % 3) as u32
                    }
                })
                .collect();
            let written = ring.iter().filter(|&&g| g != HOLE).count();
            if written == 0 || written == n {
                continue;
            }
            let mut raw = Vec::new();
            maximal_runs(&ring, &mut raw);
            let mut got = vec![HOLE; n];
            fill_runs(&mut raw, n as i64, |(g, a, b)| {
                for c in a..b {
                    let c = c.rem_euclid(n as i64) as usize;
                    assert_eq!(got[c], HOLE, "case {case}: runs overlap at {c}");
                    got[c] = g;
                }
            });
            fill_holes(
                &hemi,
                &mut ring,
                HoleFill::RingNeighbour,
                |_| unreachable!(),
            );
            assert_eq!(got, ring, "case {case}");
        }
    }
}
