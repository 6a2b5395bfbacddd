//! Visibility estimation: reproject the polygon each cell sees, then resolve every cell
//! of H2 with its own ray against the polygons guessed for it and its 8 neighbours.

use crate::config::{EstimatorConfig, HoleFill};
use crate::faithful::{fill_holes, motion, splat, CellTrig, Estimator, HOLE};
use crate::source::SourceHemisphere;
use rad_core::{PatchId, Ray, RayCast};
use rad_geometry::{Scene, MISS};
use rad_hemisphere::{Hemisphere, ItemBuffer, BACK, ESCAPED};

/// An estimated hemisphere from the improved mode.
#[derive(Clone, Debug, Default)]
pub struct ImprovedEstimate {
    pub items: ItemBuffer,
    /// Cells nothing landed in, before filling.
    pub holes: usize,
    /// Cells whose guessed polygons all missed, resolved by a real ray.
    pub real_rays: usize,
    /// Ray–polygon tests made (without the real rays' own).
    pub tests: usize,
}

/// Polygon guessed for a cell whose source saw no polygon (escaped or back-facing).
const NO_GUESS: u32 = u32::MAX;

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
    // 2. Resolve each cell with its own ray.
    let target = &scene.patches()[to as usize];
    let own = target.polygon;
    let polygons = scene.polygons();
    let frame = polygons[own as usize].frame();
    let o = target.center;
    let (n_theta, n_phi) = (hemi.n_theta(), hemi.n_phi());
    let mut out = ImprovedEstimate {
        holes,
        ..Default::default()
    };
    out.items.patch.reserve(hemi.n_cells());
    out.items.dist.reserve(hemi.n_cells());
    let mut ray = Ray::new(o, frame.n);
    ray.skip = own;
    // Every polygon's terms for this origin, computed once (a few hundred flops).
    let terms_of: Vec<[f32; 3]> = polygons.iter().map(|p| p.origin_terms(o)).collect();
    let usable = |g: u32| g != NO_GUESS && g != HOLE && g != own;
    // Whether cell j's row-neighbours (j − 1, j, j + 1, φ wrapping) guess alike, for the
    // rings i − 1, i and i + 1 (θ clamping): a cell is uniform when its 3 × 3 block is.
    let row_alike = |r: usize, out: &mut Vec<bool>| {
        let g = &guess[r * n_phi..(r + 1) * n_phi];
        out.clear();
        out.extend((0..n_phi).map(|j| {
            let (jl, jr) = (
                if j == 0 { n_phi - 1 } else { j - 1 },
                if j + 1 == n_phi { 0 } else { j + 1 },
            );
            g[jl] == g[j] && g[j] == g[jr]
        }));
    };
    let (mut above, mut here, mut below) = (Vec::new(), Vec::new(), Vec::new());
    row_alike(0, &mut here);
    above.clone_from(&here);
    let mut world = vec![glam::Vec3::ZERO; n_phi];
    let mut uniform_of = vec![false; n_phi];
    let mut batch_patch = vec![MISS; n_phi];
    let mut batch_t = vec![0.0f32; n_phi];
    let mut batched = vec![false; n_phi];
    for i in 0..n_theta {
        let i_below = (i + 1).min(n_theta - 1);
        row_alike(i_below, &mut below);
        let rows = [i.saturating_sub(1), i, i_below];
        let dirs = &hemi.directions()[i * n_phi..(i + 1) * n_phi];
        let g_ring = &guess[i * n_phi..(i + 1) * n_phi];
        for j in 0..n_phi {
            world[j] = frame.world_from_local(dirs[j]);
            // The whole 3 × 3 block guesses one polygon (most cells).
            let g0 = g_ring[j];
            uniform_of[j] = above[j]
                && here[j]
                && below[j]
                && guess[rows[0] * n_phi + j] == g0
                && guess[rows[2] * n_phi + j] == g0;
        }
        // Runs of uniform cells guessing one parallelogram: their single ray-polygon
        // tests in one batch (`Polygon::front_hits_from`, the same arithmetic).
        batched.fill(false);
        let mut j = 0;
        while j < n_phi {
            let g0 = g_ring[j];
            if !(uniform_of[j] && usable(g0)) {
                j += 1;
                continue;
            }
            let mut e = j + 1;
            while e < n_phi && uniform_of[e] && g_ring[e] == g0 {
                e += 1;
            }
            let poly = &polygons[g0 as usize];
            if poly
                .front_hits_from(
                    terms_of[g0 as usize],
                    &world[j..e],
                    &mut batch_patch[j..e],
                    &mut batch_t[j..e],
                )
                .is_some()
            {
                batched[j..e].fill(true);
                out.tests += e - j;
            }
            j = e;
        }
        for j in 0..n_phi {
            let d = world[j];
            let g0 = g_ring[j];
            let uniform = uniform_of[j];
            if batched[j] {
                if batch_patch[j] != MISS {
                    out.items.patch.push(batch_patch[j]);
                    out.items.dist.push(batch_t[j]);
                    continue;
                }
            } else if uniform && usable(g0) {
                let poly = &polygons[g0 as usize];
                out.tests += 1;
                if let Some((t, u, v, true)) =
                    poly.intersect_from(terms_of[g0 as usize], d, f32::INFINITY)
                {
                    out.items.patch.push(poly.patch_at(u, v));
                    out.items.dist.push(t);
                    continue;
                }
            }
            let mut cand = [NO_GUESS; 9];
            let mut n_cand = 0;
            if !uniform {
                let (jl, jr) = (
                    if j == 0 { n_phi - 1 } else { j - 1 },
                    if j + 1 == n_phi { 0 } else { j + 1 },
                );
                for r in rows {
                    for jj in [jl, j, jr] {
                        let g = guess[r * n_phi + jj];
                        if usable(g) && !cand[..n_cand].contains(&g) {
                            cand[n_cand] = g;
                            n_cand += 1;
                        }
                    }
                }
                cand[..n_cand].sort_unstable();
            }
            // The nearest hit among the candidates, whichever its side; ties go to the
            // lower polygon id, as in the grid. A back face nearest (something seen from
            // behind, or an occluder met from inside) is left to a real ray.
            let mut best: Option<(f32, u32, f32, f32, bool)> = None;
            for &p in &cand[..n_cand] {
                out.tests += 1;
                let t_max = best.map_or(f32::INFINITY, |b| b.0);
                let terms = terms_of[p as usize];
                if let Some((t, u, v, front)) = polygons[p as usize].intersect_from(terms, d, t_max)
                {
                    best = Some((t, p, u, v, front));
                }
            }
            let (id, dist) = match best {
                Some((t, p, u, v, true)) => (polygons[p as usize].patch_at(u, v), t),
                _ => {
                    out.real_rays += 1;
                    ray.dir = d;
                    match caster.closest_hit(&ray, scratch) {
                        Some(h) if h.front => {
                            (polygons[h.polygon as usize].patch_at(h.u, h.v), h.t)
                        }
                        Some(h) => (BACK, h.t),
                        None => (ESCAPED, f32::INFINITY),
                    }
                }
            };
            out.items.patch.push(id);
            out.items.dist.push(dist);
        }
        std::mem::swap(&mut above, &mut here);
        std::mem::swap(&mut here, &mut below);
    }
    let _ = config;
    out
}
