//! The exact hemisphere H1 kept for estimation: what each cell sees, how far, and the
//! boundary lists of §3.5.2.

use rad_core::{PatchId, PolygonId, Ray, BACK, ESCAPED, NO_POLYGON};
use rad_geometry::Scene;
use rad_hemisphere::{Caster, Hemisphere, ItemBuffer, Viewpoint};

/// An exact hemisphere with, where asked, boundary lists: a cell whose closest hit is a
/// patch on its polygon's boundary keeps every further front-facing patch its ray
/// crosses up to the scene's bound, with its distance.
///
/// Its fields are private: the caches below are made from `items` on first use, so
/// nothing may change it after it is cast.
#[derive(Clone, Debug, Default)]
pub struct SourceHemisphere {
    patch: PatchId,
    /// What each cell sees (a patch, `ESCAPED` or `BACK`) and how far.
    items: ItemBuffer,
    /// CSR boundary lists: the extra entries of cell `c` are
    /// `list[list_start[c]..list_start[c + 1]]`; empty when lists are off.
    list_start: Vec<u32>,
    list: Vec<(PatchId, f32)>,
    /// The facet each cell sees (`NO_POLYGON` for escaped and back-facing rays), made on
    /// first use by the improved mode and shared by a window's estimates.
    facets: std::sync::OnceLock<Vec<PolygonId>>,
    /// Its points on grids 2, 3 and 4 times coarser, made on first use likewise.
    coarse: [std::sync::OnceLock<CoarsePoints>; 3],
    /// The largest distance of each ring, made on first use likewise.
    ring_max: std::sync::OnceLock<Vec<f32>>,
}

/// H1's points on a grid s times coarser both ways: one point per s × s cells, the
/// nearest of them (the first on ties), with its facet; and the other facets those
/// cells see.
#[derive(Clone, Debug, Default)]
pub(crate) struct CoarsePoints {
    /// By coarse cell: the point's distance, facet, and H1's cell.
    pub dist: Vec<f32>,
    pub facets: Vec<PolygonId>,
    pub cells: Vec<u32>,
    /// (coarse cell, facet): the other facets of its s × s cells, by cell.
    pub extras: Vec<(u32, PolygonId)>,
    /// The largest of `dist` in each ring.
    pub ring_max: Vec<f32>,
}

impl SourceHemisphere {
    /// Casts the exact hemisphere of `patch` through `caster` (and its boundary lists
    /// if asked: every caster casts their single rays, the scan by brute force).
    pub fn cast<C: Caster>(
        scene: &Scene,
        caster: &C,
        hemi: &Hemisphere,
        patch: PatchId,
        boundary_lists: bool,
        scratch: &mut C::Scratch,
    ) -> SourceHemisphere {
        let mut out = SourceHemisphere {
            patch,
            ..Default::default()
        };
        caster.item_buffer(scene, hemi, patch, scratch, &mut out.items);
        if boundary_lists {
            out.add_boundary_lists(scene, caster, hemi, scratch);
        }
        out
    }

    fn add_boundary_lists<C: Caster>(
        &mut self,
        scene: &Scene,
        caster: &C,
        hemi: &Hemisphere,
        scratch: &mut C::Scratch,
    ) {
        let p = &scene.patches()[self.patch as usize];
        let frame = scene.polygons()[p.polygon as usize].frame();
        let mut hits = Vec::new();
        self.list_start.clear();
        self.list_start.reserve(hemi.n_cells() + 1);
        self.list_start.push(0);
        let mut ray = Ray::new(p.center, frame.n);
        ray.skip = p.polygon;
        for (c, &id) in self.items.patch.iter().enumerate() {
            if id != ESCAPED && id != BACK && scene.patches()[id as usize].on_boundary {
                ray.dir = frame.world_from_local(hemi.directions()[c]);
                caster.all_hits_along(scene, &ray, scratch, &mut hits);
                let first = self.items.dist[c];
                for h in hits.iter().filter(|h| h.front && h.t > first) {
                    let q = scene.polygons()[h.polygon as usize].patch_at(h.u, h.v);
                    self.list.push((q, h.t));
                }
            }
            self.list_start.push(self.list.len() as u32);
        }
    }

    /// A copy without boundary lists (to measure what they do).
    pub fn without_lists(&self) -> SourceHemisphere {
        SourceHemisphere {
            patch: self.patch,
            items: self.items.clone(),
            list_start: Vec::new(),
            list: Vec::new(),
            facets: self.facets.clone(),
            coarse: self.coarse.clone(),
            ring_max: self.ring_max.clone(),
        }
    }

    /// The patch whose hemisphere this is.
    pub fn patch(&self) -> PatchId {
        self.patch
    }

    /// Where it stands: its patch's centre, on its polygon.
    pub fn viewpoint(&self, scene: &Scene) -> Viewpoint {
        Viewpoint::of_patch(scene, self.patch)
    }

    /// What each cell sees (a patch, `ESCAPED` or `BACK`) and how far.
    pub fn items(&self) -> &ItemBuffer {
        &self.items
    }

    /// Whether boundary lists were built.
    pub fn has_lists(&self) -> bool {
        !self.list_start.is_empty()
    }

    /// The facet ([`rad_geometry::Facets`]) of the polygon of `id` (a cell's entry or a
    /// boundary-list entry) of `scene`, or [`NO_POLYGON`] for `ESCAPED` and `BACK`. (A
    /// polygon with a patch grid of its own is a facet alone, numbered as the polygon
    /// where every polygon is.)
    #[inline]
    pub fn facet_of(scene: &Scene, id: PatchId) -> PolygonId {
        if id == ESCAPED || id == BACK {
            NO_POLYGON
        } else {
            scene
                .facets()
                .facet_of(scene.patches()[id as usize].polygon)
        }
    }

    /// The facet each cell sees ([`SourceHemisphere::facet_of`] of its entry), made
    /// from `items` on the first call and kept (so `items` must not change after it).
    /// `scene` must be the scene the hemisphere was cast in.
    pub fn facets(&self, scene: &Scene) -> &[PolygonId] {
        self.facets.get_or_init(|| {
            self.items
                .patch
                .iter()
                .map(|&id| Self::facet_of(scene, id))
                .collect()
        })
    }

    /// Its points on `hemi`'s grid `stride` (2 to 4, dividing N_θ and N_φ) times coarser,
    /// made once (from `items`, which must not change after).
    pub(crate) fn coarse(&self, scene: &Scene, hemi: &Hemisphere, stride: usize) -> &CoarsePoints {
        self.coarse[stride - 2].get_or_init(|| {
            let values = self.facets(scene);
            let dist = &self.items.dist;
            let (n_theta, n_phi) = (hemi.n_theta() / stride, hemi.n_phi() / stride);
            let fine = hemi.n_phi();
            let mut out = CoarsePoints::default();
            let n = n_theta * n_phi;
            out.dist.reserve(n);
            out.facets.reserve(n);
            out.cells.reserve(n);
            for i in 0..n_theta {
                for j in 0..n_phi {
                    let row = |a: usize| (stride * i + a) * fine + stride * j;
                    // The nearest point of the block, the first in row order on ties
                    // (branch-free: which is nearer is unpredictable).
                    let (mut best, mut bd) = (row(0), dist[row(0)]);
                    for a in 0..stride {
                        let r = row(a);
                        for (c, &d) in dist[r..r + stride].iter().enumerate() {
                            let nearer = d < bd;
                            bd = if nearer { d } else { bd };
                            best = if nearer { r + c } else { best };
                        }
                    }
                    out.dist.push(bd);
                    out.facets.push(values[best]);
                    out.cells.push(best as u32);
                    let cell = (i * n_phi + j) as u32;
                    let first = out.extras.len();
                    for a in 0..stride {
                        let r = row(a);
                        for &v in &values[r..r + stride] {
                            if v != values[best] && !out.extras[first..].contains(&(cell, v)) {
                                out.extras.push((cell, v));
                            }
                        }
                    }
                }
            }
            out.ring_max = ring_max(&out.dist, n_phi);
            out
        })
    }

    /// The largest distance of each of `hemi`'s rings (∞ where a ray escaped), made once
    /// (from `items`, which must not change after): whether a ring has a point far
    /// enough for the first-order formulas, for each estimate made from it.
    pub(crate) fn ring_max(&self, hemi: &Hemisphere) -> &[f32] {
        self.ring_max
            .get_or_init(|| ring_max(&self.items.dist, hemi.n_phi()))
    }

    /// The boundary-list entries of cell `c` (empty without lists).
    #[inline]
    pub fn list(&self, c: usize) -> &[(PatchId, f32)] {
        if self.list_start.is_empty() {
            return &[];
        }
        &self.list[self.list_start[c] as usize..self.list_start[c + 1] as usize]
    }
}

/// The largest of each run of `n` in `dist` (distances: no NaN).
fn ring_max(dist: &[f32], n: usize) -> Vec<f32> {
    dist.chunks(n)
        .map(|ring| ring.iter().fold(0.0f32, |m, &d| m.max(d)))
        .collect()
}
