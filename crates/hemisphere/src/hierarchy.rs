//! The hierarchical caster: the polygon scan over a bounding volume hierarchy, so that
//! a hemisphere's cost follows what it sees rather than what the scene holds.
//!
//! [`Hemisphere::scan`] tests every polygon on the cells of its angular box. On a
//! triangle mesh most polygons are hidden behind nearer ones, and merely finding their
//! boxes is most of the work. Here the polygons sit in a BVH (binned SAH over their
//! padded boxes), walked from the patch centre near child first; a node is skipped when
//! it lies wholly behind the patch's tangent plane (the grid's own culling, for a whole
//! subtree at once), or when every cell its angular footprint covers already holds a hit
//! strictly nearer than the node's nearest point (a depth test against per-tile maxima
//! of the stored distances: tiles of one ring and [`TILE`] sectors). Leaves are resolved
//! with the scan's own per-polygon work and f32 test, with ties in t going to the lower
//! polygon id whatever the order polygons come in; so the item buffers are the grid's,
//! bit for bit. Single rays (improved estimation's, boundary lists') walk the same tree.
//!
//! Why the skips are exact: a hit the grid accepts on a polygon lies, up to f32
//! rounding, inside the polygon's padded (u, v) box on its plane (what the scan's
//! angular boxes rest on), hence inside the node's box grown by the rounding slack; so
//! its ray lies in the footprint of that grown box, and its t is at least the box's
//! distance less the slack. A node is skipped only when every such cell already holds
//! a hit nearer than that: the polygon would lose there anyway.

use crate::scan::{edge_reach, padded_corners, pole_dip, wrap, PoleDip, ScanOrigin};
use crate::{Caster, Hemisphere, ItemBuffer, ScanScratch, Viewpoint};
use glam::DVec3;
use rad_core::{Hit, PatchId, PolygonId, Ray, RayCast, Vec3};
use rad_geometry::{Polygon, PolygonTerms, Scene, Shape};
use std::f64::consts::PI;
use std::ops::Range;

/// Sectors a depth tile spans (one ring high).
pub const TILE: usize = 16;

/// At most this many polygons a leaf.
const LEAF_SIZE: usize = 4;

/// SAH bins a split.
const BINS: usize = 16;

/// A node of the tree: its box (padded, in f64), the largest reach of its polygons,
/// its polygons (`first..first + len` in tree order), and its children `left` and
/// `left + 1` (`left` 0 for a leaf: the root is no one's child).
#[derive(Clone, Copy, Debug)]
struct Node {
    /// In f32, rounded outwards from the f64 box (so it still holds every polygon).
    lo: Vec3,
    hi: Vec3,
    reach: f32,
    first: u32,
    len: u32,
    left: u32,
}

impl Node {
    fn lo64(&self) -> DVec3 {
        self.lo.as_dvec3()
    }
    fn hi64(&self) -> DVec3 {
        self.hi.as_dvec3()
    }
}

/// `x` in f32, rounded down (`up`: up), so that the f32 box holds the f64 one.
fn outward(x: f64, up: bool) -> f32 {
    let f = x as f32;
    match (up, (f as f64).total_cmp(&x)) {
        (true, std::cmp::Ordering::Less) => f.next_up(),
        (false, std::cmp::Ordering::Greater) => f.next_down(),
        _ => f,
    }
}

/// What a polygon's visit reads, in tree order (one place in memory for a leaf).
#[derive(Clone, Copy, Debug)]
struct Item {
    /// Its padded box.
    lo: DVec3,
    hi: DVec3,
    reach: f64,
    id: PolygonId,
    shape: Shape,
    /// A triangle's vertices, and how far past them (world units) its inside test
    /// reaches at its sharpest corner (none for other polygons).
    triangle: Option<([Vec3; 3], f32)>,
}

/// The hierarchical exact caster (see the module documentation), built for one scene.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    nodes: Vec<Node>,
    items: Vec<Item>,
    /// Each item's hit-test terms (as [`Polygon::terms`] gives them).
    terms: Vec<PolygonTerms>,
    /// Each polygon's [`padded_corners`], by id, made once.
    padded: Vec<[DVec3; 4]>,
    /// The scene's largest coordinate plus its diagonal: the scale of f32 rounding.
    scale: f64,
    n_polygons: usize,
}

/// Work counts of the hierarchical caster, summed over calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HierarchyStats {
    pub hemispheres: u64,
    /// Nodes taken off the heap.
    pub nodes: u64,
    /// Nodes skipped because wholly behind the tangent plane.
    pub behind: u64,
    /// Nodes skipped because every cell of their footprint held a nearer hit.
    pub occluded: u64,
    /// Polygons visited in the nodes reached.
    pub polygons: u64,
    /// Of which tested on their node's footprint.
    pub flat: u64,
    /// Of which tested on their own footprint.
    pub own: u64,
}

/// Per-thread working memory of [`Hierarchy`].
#[derive(Clone, Debug, Default)]
pub struct HierarchyScratch {
    scan: ScanScratch,
    /// The largest distance stored in each tile, valid unless `dirty`.
    tile_max: Vec<f32>,
    dirty: Vec<bool>,
    stack: Vec<(u32, f32)>,
    /// The item buffer's walk: nodes with their distances.
    dfs: Vec<(u32, f64)>,
    /// The runs of cells of the node footprint last made, and of a polygon's own.
    runs: Vec<Range<usize>>,
    own_runs: Vec<Range<usize>>,
    /// Sectors a ring, and tiles a ring, of the hemisphere being made.
    np: usize,
    per_ring: usize,
    pub stats: HierarchyStats,
}

/// The cells a box's polygons may be seen on (runs, one or two a ring, in the vector
/// given), and the distance a hit must be under to hide them there.
#[derive(Clone, Copy, Debug)]
struct Footprint {
    cells: usize,
    threshold: f64,
    /// Rings `i0..=i1` (none if i0 > i1), each over the sectors of `spans` (widened).
    rings: (usize, usize),
    spans: [(usize, usize); 2],
}

impl Footprint {
    /// Its runs of cells, into `runs`.
    fn fill(&self, np: usize, runs: &mut Vec<Range<usize>>) {
        runs.clear();
        for i in self.rings.0..=self.rings.1 {
            for (a, b) in self.spans {
                if b > a {
                    runs.push(i * np + a..i * np + b);
                }
            }
        }
    }
}

/// A [`Hierarchy`] with its scene, as a ray caster ([`Hierarchy::rays`]): the same hits
/// as the voxel grid and brute force, to the bit.
#[derive(Clone, Copy, Debug)]
pub struct HierarchyRays<'a> {
    tree: &'a Hierarchy,
    scene: &'a Scene,
}

impl RayCast for HierarchyRays<'_> {
    type Scratch = Vec<(u32, f32)>;

    fn new_scratch(&self) -> Vec<(u32, f32)> {
        Vec::new()
    }

    fn closest_hit(&self, ray: &Ray, stack: &mut Vec<(u32, f32)>) -> Option<Hit> {
        self.tree.closest_hit(self.scene, ray, stack)
    }

    fn all_hits(&self, ray: &Ray, stack: &mut Vec<(u32, f32)>, out: &mut Vec<Hit>) {
        self.tree.all_hits(self.scene, ray, stack, out)
    }
}

/// Nodes of at most this many polygons have them prefetched when taken.
const PREFETCH: usize = 32;

/// A polygon whose own footprint has more cells than this is scanned with its exact
/// angular box instead ([`Hemisphere::scan`]'s), dearer to find but tighter.
const REGION_CELLS: usize = 1024;

/// Subtrees whose footprint has at most this many cells are tested whole on it.
const FLAT_CELLS: usize = 128;

impl HierarchyScratch {
    /// The scan's own counts (cell tests among them).
    pub fn scan_stats(&self) -> crate::ScanStats {
        self.scan.stats
    }
}

impl Hierarchy {
    /// Builds the tree over `scene`'s polygons.
    pub fn new(scene: &Scene) -> Hierarchy {
        let polygons = scene.polygons();
        let padded: Vec<[DVec3; 4]> = polygons.iter().map(padded_corners).collect();
        let boxes: Vec<(DVec3, DVec3)> = polygons
            .iter()
            .zip(&padded)
            .map(|(p, c)| {
                let pts = p
                    .vertices()
                    .iter()
                    .map(|v| v.as_dvec3())
                    .chain(c.iter().copied());
                pts.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q), hi.max(q))
                })
            })
            .collect();
        let reach: Vec<f64> = polygons.iter().map(|p| p.reach() as f64).collect();
        let mut order: Vec<PolygonId> = (0..polygons.len() as PolygonId).collect();
        let empty = Node {
            lo: Vec3::INFINITY,
            hi: Vec3::NEG_INFINITY,
            reach: 0.0,
            first: 0,
            len: 0,
            left: 0,
        };
        let mut nodes = vec![empty];
        if !polygons.is_empty() {
            build(&boxes, &reach, &mut order, 0, 0, &mut nodes);
        }
        let items = order
            .iter()
            .map(|&id| {
                let (lo, hi) = boxes[id as usize];
                Item {
                    lo,
                    hi,
                    reach: reach[id as usize],
                    id,
                    shape: Shape::of(&polygons[id as usize]),
                    triangle: triangle_reach(&polygons[id as usize]),
                }
            })
            .collect();
        let terms = order
            .iter()
            .map(|&id| polygons[id as usize].terms())
            .collect();
        let root = nodes[0];
        let scale = if polygons.is_empty() {
            0.0
        } else {
            let (lo, hi) = (root.lo64(), root.hi64());
            lo.abs().max(hi.abs()).max_element() + (hi - lo).length()
        };
        Hierarchy {
            nodes,
            items,
            terms,
            padded,
            scale,
            n_polygons: polygons.len(),
        }
    }

    /// Nodes in the tree.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The rounding slack, as a distance, of f32 terms for rays from `o`.
    fn slack(&self, o: DVec3) -> f64 {
        1e-5 * (self.scale + o.abs().max_element())
    }

    fn check(&self, scene: &Scene) {
        assert_eq!(
            scene.polygons().len(),
            self.n_polygons,
            "a Hierarchy is used with the scene it was built for"
        );
    }

    /// The exact item buffer of `patch` (see the module documentation).
    pub fn scan(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        patch: PatchId,
        s: &mut HierarchyScratch,
        buf: &mut ItemBuffer,
    ) {
        self.scan_at(scene, hemi, Viewpoint::of_patch(scene, patch), s, buf)
    }

    /// [`Hierarchy::scan`] from any point of a polygon.
    pub fn scan_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        from: Viewpoint,
        s: &mut HierarchyScratch,
        buf: &mut ItemBuffer,
    ) {
        self.check(scene);
        let mut at = hemi.scan_begin(scene, from, &mut s.scan);
        // Subtrees behind the plane may be skipped whole only where the grid culls
        // them in every ring.
        let forward = Hemisphere::scan_all_forward(&s.scan);
        let np = hemi.n_phi();
        let per_ring = np.div_ceil(TILE);
        (s.np, s.per_ring) = (np, per_ring);
        let n_tiles = hemi.n_theta() * per_ring;
        s.tile_max.clear();
        s.tile_max.resize(n_tiles, f32::INFINITY);
        s.dirty.clear();
        s.dirty.resize(n_tiles, false);
        s.stats.hemispheres += 1;
        let tests_before = s.scan.hits.tests;
        let slack = self.slack(at.o64);
        let o = at.o64;
        // Depth first, the nearer child first (subtrees lie together in memory).
        s.dfs.clear();
        s.dfs.push((
            0,
            box_distance(self.nodes[0].lo64(), self.nodes[0].hi64(), o),
        ));
        while let Some((n, dmin)) = s.dfs.pop() {
            let node = &self.nodes[n as usize];
            s.stats.nodes += 1;
            if node.len as usize <= PREFETCH {
                // Its polygons are likely read next: fetch them while the node's tests run.
                self.prefetch(node.first as usize..(node.first + node.len) as usize);
            }
            if forward && self.behind(&node, &at, slack) {
                s.stats.behind += 1;
                continue;
            }
            let foot = footprint(node.lo64(), node.hi64(), dmin, &at, hemi, slack);
            if foot.is_some_and(|f| self.occluded(hemi, &f, s)) {
                s.stats.occluded += 1;
                continue;
            }
            let flat = foot.filter(|f| f.cells <= FLAT_CELLS);
            if let Some(f) = flat {
                f.fill(np, &mut s.runs);
            }
            let flat = flat.is_some();
            if flat || node.left == 0 {
                // A leaf, or few cells: every polygon of the subtree (on the node's
                // cells, or each on its own).
                let range = node.first as usize..(node.first + node.len) as usize;
                self.visit(scene, hemi, range, flat, &mut at, forward, slack, s);
            } else {
                let (a, b) = (node.left, node.left + 1);
                let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
                let da = box_distance(na.lo64(), na.hi64(), o);
                let db = box_distance(nb.lo64(), nb.hi64(), o);
                // The nearer last, so that it is taken first.
                if da <= db {
                    s.dfs.extend([(b, db), (a, da)]);
                } else {
                    s.dfs.extend([(a, da), (b, db)]);
                }
            }
        }
        s.scan.stats.tests += s.scan.hits.tests - tests_before;
        hemi.scan_finish(scene, &at, &s.scan.hits, buf);
    }

    /// Tests the polygons of `range` (tree order): on the node's footprint (in
    /// `s.runs`) with `flat`, else each on its own; but not those the grid culls
    /// (wholly behind the patch's plane, with every ring forwards), and scanning as
    /// [`Hemisphere::scan`] does those whose plane passes near the origin (it may
    /// prove them unseen) or that are too near to have a footprint.
    #[allow(clippy::too_many_arguments)]
    fn visit(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        range: Range<usize>,
        flat: bool,
        at: &mut ScanOrigin,
        forward: bool,
        slack: f64,
        s: &mut HierarchyScratch,
    ) {
        let polygons = scene.polygons();
        let (np, per_ring) = (s.np, s.per_ring);
        if flat {
            for r in &s.runs {
                mark(&mut s.dirty, np, per_ring, r.clone());
            }
        }
        for k in range {
            let item = &self.items[k];
            if item.id == at.own {
                continue;
            }
            s.stats.polygons += 1;
            let poly = &polygons[item.id as usize];
            let behind = self.item_behind(&item, poly, at, slack);
            if behind && forward {
                continue;
            }
            let terms = scene.seen(item.id as usize, self.terms[k].at(at.o));
            if terms.num == 0.0 || terms.num.is_nan() {
                continue;
            }
            let own = if behind || (terms.num as f64).abs() <= 100.0 * slack {
                None
            } else if flat {
                Some(false)
            } else {
                let dmin = box_distance(item.lo, item.hi, at.o64);
                let tight = item.triangle.as_ref().and_then(|&(v, grow)| {
                    triangle_footprint(v, grow as f64, dmin, at, hemi, slack, &mut s.own_runs)
                });
                tight
                    .or_else(|| {
                        // A large footprint pays for the scan's own tighter box.
                        let f = footprint(item.lo, item.hi, dmin, at, hemi, slack)
                            .filter(|f| f.cells <= REGION_CELLS)?;
                        f.fill(s.np, &mut s.own_runs);
                        Some(f.cells)
                    })
                    .filter(|&cells| cells <= REGION_CELLS)
                    .map(|_| true)
            };
            let HierarchyScratch {
                scan,
                dirty,
                runs,
                own_runs,
                stats,
                ..
            } = s;
            match own {
                None => {
                    let padded = Some(&self.padded[item.id as usize]);
                    hemi.scan_polygon::<true>(at, poly, item.id, padded, scan, |cells| {
                        mark(dirty, np, per_ring, cells)
                    });
                }
                Some(false) => {
                    stats.flat += 1;
                    scan.hits
                        .test_runs(poly, item.id, &terms, &item.shape, runs);
                }
                Some(true) => {
                    stats.own += 1;
                    for r in own_runs.iter() {
                        mark(dirty, np, per_ring, r.clone());
                    }
                    scan.hits
                        .test_runs(poly, item.id, &terms, &item.shape, own_runs);
                }
            }
        }
    }

    /// Every polygon `ray` crosses, sorted by t (ties by id): [`Scene::all_hits`]'s
    /// answer, from the leaves whose boxes the ray enters.
    fn all_hits(&self, scene: &Scene, ray: &Ray, stack: &mut Vec<(u32, f32)>, out: &mut Vec<Hit>) {
        self.check(scene);
        out.clear();
        let polygons = scene.polygons();
        let o = ray.origin.as_dvec3();
        let t_max = ray.t_max as f64;
        let slack = self.slack(o);
        self.walk_ray(
            ray.origin,
            ray.dir,
            slack,
            stack,
            t_max * (1.0 + 1e-6) + slack,
            |range| {
                for k in range {
                    let id = self.items[k].id;
                    if id == ray.skip {
                        continue;
                    }
                    let h = scene.seen(id as usize, self.terms[k].at(ray.origin));
                    let poly = || &polygons[id as usize];
                    let shape = &self.items[k].shape;
                    if let Some((t, u, v, front)) = shape.hit_from(poly, &h, ray.dir, ray.t_max) {
                        out.push(Hit {
                            polygon: id,
                            u,
                            v,
                            t,
                            front,
                        });
                    }
                }
                t_max * (1.0 + 1e-6) + slack
            },
        );
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
    }

    /// The closest hit of `ray` ([`RayCast::closest_hit`]'s answer: 0 < t < t_max, not
    /// `ray.skip`, ties in t to the lower id), from the leaves whose boxes it enters.
    fn closest_hit(&self, scene: &Scene, ray: &Ray, stack: &mut Vec<(u32, f32)>) -> Option<Hit> {
        self.check(scene);
        let polygons = scene.polygons();
        let o = ray.origin.as_dvec3();
        let slack = self.slack(o);
        let limit = ray.t_max as f64 * (1.0 + 1e-6) + slack;
        let mut best: Option<Hit> = None;
        self.walk_ray(ray.origin, ray.dir, slack, stack, limit, |range| {
            for k in range {
                let item = &self.items[k];
                if item.id == ray.skip {
                    continue;
                }
                // (The polygon's own terms and shape, kept in tree order:
                // `Polygon::intersect`'s answer.)
                let h = scene.seen(item.id as usize, self.terms[k].at(ray.origin));
                let poly = || &polygons[item.id as usize];
                if let Some((t, u, v, front)) = item.shape.hit_from(poly, &h, ray.dir, ray.t_max) {
                    if best.is_none_or(|b| t < b.t || (t == b.t && item.id < b.polygon)) {
                        best = Some(Hit {
                            polygon: item.id,
                            u,
                            v,
                            t,
                            front,
                        });
                    }
                }
            }
            // A polygon met no nearer than the best so far could still win a tie.
            best.map_or(limit, |b| b.t as f64 * (1.0 + 1e-6) + slack)
        });
        best
    }

    /// The tree as a [`RayCast`] on `scene` (the scene it was built for): single rays
    /// through it, for rendering.
    pub fn rays<'a>(&'a self, scene: &'a Scene) -> HierarchyRays<'a> {
        self.check(scene);
        HierarchyRays { tree: self, scene }
    }

    /// Asks the CPU to bring the items and terms of `range` into cache.
    #[inline]
    fn prefetch(&self, range: Range<usize>) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let lines = |bytes: &[u8]| {
                for k in (0..bytes.len()).step_by(64) {
                    // SAFETY: a prefetch only hints; the address is inside the slice.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(bytes.as_ptr().add(k).cast()) };
                }
            };
            let items = &self.items[range.clone()];
            let terms = &self.terms[range];
            // SAFETY: plain data viewed as bytes, for the addresses alone.
            unsafe {
                lines(std::slice::from_raw_parts(
                    items.as_ptr().cast(),
                    std::mem::size_of_val(items),
                ));
                lines(std::slice::from_raw_parts(
                    terms.as_ptr().cast(),
                    std::mem::size_of_val(terms),
                ));
            }
        }
    }

    /// [`Polygon::wholly_behind`] the patch's plane, from the item's box where it
    /// decides.
    fn item_behind(&self, item: &Item, poly: &Polygon, at: &ScanOrigin, slack: f64) -> bool {
        let n = at.own_n;
        let (near, far) = corners_along(item.lo, item.hi, n);
        let margin = 1e-6 * slack;
        if (far - at.o64).dot(n) < -item.reach - margin {
            true
        } else if (near - at.o64).dot(n) >= -item.reach + margin {
            false
        } else {
            poly.wholly_behind(at.o64, n)
        }
    }

    /// True when every polygon of `node` is wholly behind the patch's plane by more
    /// than its reach ([`Polygon::wholly_behind`]): the box's farthest corner forwards
    /// is, with room for f64 rounding.
    fn behind(&self, node: &Node, at: &ScanOrigin, slack: f64) -> bool {
        let (_, far) = corners_along(node.lo64(), node.hi64(), at.own_n);
        (far - at.o64).dot(at.own_n) < -(node.reach as f64) - 1e-6 * slack
    }

    /// True when every cell of the footprint in `s.runs` already holds a hit nearer
    /// than `threshold` (see the module documentation).
    fn occluded(&self, hemi: &Hemisphere, foot: &Footprint, s: &mut HierarchyScratch) -> bool {
        let np = hemi.n_phi();
        let per_ring = np.div_ceil(TILE);
        let threshold = foot.threshold;
        let best = s.scan.hits.best_t();
        for ring in foot.rings.0..=foot.rings.1 {
            for &(a, b) in &foot.spans {
                if b <= a {
                    continue;
                }
                for t in a / TILE..=(b - 1) / TILE {
                    let k = ring * per_ring + t;
                    if s.dirty[k] {
                        let cells = ring * np + t * TILE..ring * np + ((t + 1) * TILE).min(np);
                        s.tile_max[k] = best[cells].iter().copied().fold(0.0, f32::max);
                        s.dirty[k] = false;
                    }
                    if s.tile_max[k] as f64 >= threshold {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Visits the polygons of every leaf whose box (grown by `slack`) the ray from `o`
    /// along `d` enters before `limit`, near boxes first; each visit returns the new
    /// limit.
    fn walk_ray(
        &self,
        o: Vec3,
        d: Vec3,
        slack: f64,
        stack: &mut Vec<(u32, f32)>,
        limit: f64,
        mut leaf: impl FnMut(Range<usize>) -> f64,
    ) {
        let inv = inverse(d);
        let slack = outward(slack, true);
        let mut limit = outward(limit, true);
        stack.clear();
        if let Some(t) = slab(&self.nodes[0], o, inv, slack) {
            stack.push((0, t));
        }
        while let Some((n, t_in)) = stack.pop() {
            if t_in > limit {
                continue;
            }
            let node = &self.nodes[n as usize];
            if node.left == 0 {
                limit = outward(
                    leaf(node.first as usize..(node.first + node.len) as usize),
                    true,
                );
                continue;
            }
            let (a, b) = (node.left, node.left + 1);
            let ta = slab(&self.nodes[a as usize], o, inv, slack);
            let tb = slab(&self.nodes[b as usize], o, inv, slack);
            match (ta, tb) {
                (Some(ta), Some(tb)) if ta <= tb => stack.extend([(b, tb), (a, ta)]),
                (Some(ta), Some(tb)) => stack.extend([(a, ta), (b, tb)]),
                (Some(ta), None) => stack.push((a, ta)),
                (None, Some(tb)) => stack.push((b, tb)),
                (None, None) => {}
            }
        }
    }
}

/// The corners of the box `lo..hi` least and farthest along `n`.
fn corners_along(lo: DVec3, hi: DVec3, n: DVec3) -> (DVec3, DVec3) {
    let pick = |k: usize, up: bool| if (n[k] > 0.0) == up { hi[k] } else { lo[k] };
    (
        DVec3::new(pick(0, false), pick(1, false), pick(2, false)),
        DVec3::new(pick(0, true), pick(1, true), pick(2, true)),
    )
}

/// The footprint of the box `lo..hi` (at distance `dmin`) from the patch centre; None
/// where the box is too near to have one worth testing.
fn footprint(
    lo: DVec3,
    hi: DVec3,
    dmin: f64,
    at: &ScanOrigin,
    hemi: &Hemisphere,
    slack: f64,
) -> Option<Footprint> {
    let threshold = dmin - 4.0 * slack;
    if threshold <= 0.0 {
        return None;
    }
    // The box's bounding sphere, grown by the slack, as seen from the origin.
    let c = 0.5 * (lo + hi) - at.o64;
    let r = 0.5 * (hi - lo).length() + slack;
    let dist = c.length();
    if dist <= r * (1.0 + 1e-9) {
        return None;
    }
    let f = at.frame;
    let cl = DVec3::new(f[0].dot(c), f[1].dot(c), f[2].dot(c));
    // Angles by `atan2_bounded` (within ATAN_ERROR), every bound widened past its error.
    let margin = 1e-6 + 4.0 * slack / dmin + 4.0 * ATAN_ERROR;
    let alpha = asin_bounded(r / dist) + margin;
    let rho = (cl.x * cl.x + cl.y * cl.y).sqrt();
    let theta_c = atan2_bounded(rho, cl.z);
    let (lo, hi) = (theta_c - alpha, theta_c + alpha);
    let spans = if lo <= 0.0 || hi >= PI {
        None
    } else {
        // sin β = sin α / sin θc, with sin α ≤ r / dist + margin and sin θc = ρ / dist.
        let sb = (r + margin * dist) / rho;
        if sb >= 1.0 {
            None
        } else {
            let beta = asin_bounded(sb) + 4.0 * ATAN_ERROR + 1e-9;
            let phi_c = atan2_bounded(cl.y, cl.x);
            hemi.phi_spans(phi_c - beta, phi_c + beta)
        }
    };
    let np = hemi.n_phi();
    let spans =
        spans
            .unwrap_or([(0, np), (0, 0)])
            .map(|(a, b)| if b > a { widen(a, b, np) } else { (0, 0) });
    let rings = hemi.rings(lo.max(0.0), hi);
    let (i0, i1) = (*rings.start(), *rings.end());
    let width: usize = spans.iter().map(|(a, b)| b - a).sum();
    let cells = if i0 > i1 { 0 } else { (i1 - i0 + 1) * width };
    Some(Footprint {
        cells,
        threshold,
        rings: (i0, i1),
        spans,
    })
}

/// A triangle's vertices and how far its inside test reaches past them: twice its
/// reach over the sine of its sharpest half-angle (as the scan pads its boxes).
fn triangle_reach(poly: &Polygon) -> Option<([Vec3; 3], f32)> {
    let v: [Vec3; 3] = poly.vertices().try_into().ok()?;
    let grow = edge_reach(poly, &v.map(|p| p.as_dvec3()));
    Some((v, (grow * (1.0 + 1e-6)) as f32 * 1.001))
}

/// The cells a triangle's hits may lie on, from its vertices' directions (θ and φ
/// bounds, θ's dip along each edge's great circle, margins for its reach, the slack at
/// `dmin` and the angles' errors), into `runs`; None where that box is not reliable (a
/// vertex at or below the tangent plane, or near the pole, or the pole inside), for the
/// caller to fall back on.
fn triangle_footprint(
    v: [Vec3; 3],
    grow: f64,
    dmin: f64,
    at: &ScanOrigin,
    hemi: &Hemisphere,
    slack: f64,
    runs: &mut Vec<Range<usize>>,
) -> Option<usize> {
    if dmin <= 100.0 * (slack + grow) {
        return None;
    }
    let f = at.frame;
    let mut dirs = [DVec3::ZERO; 3];
    let (mut theta, mut phi) = ([0.0f64; 3], [0.0f64; 3]);
    for k in 0..3 {
        let w = v[k].as_dvec3() - at.o64;
        let l = DVec3::new(f[0].dot(w), f[1].dot(w), f[2].dot(w));
        let len = l.length();
        let rho = (l.x * l.x + l.y * l.y).sqrt();
        if l.z <= 1e-3 * len || rho <= 1e-3 * len {
            return None;
        }
        dirs[k] = l / len;
        theta[k] = atan2_bounded(rho, l.z);
        phi[k] = atan2_bounded(l.y, l.x);
    }
    let margin = (grow + 2.0 * slack) / dmin + 1e-6 + 4.0 * ATAN_ERROR;
    // φ along each edge moves monotonically between its ends (no pole inside).
    let mut acc = phi[0];
    let (mut phi_lo, mut phi_hi) = (acc, acc);
    let mut winding = 0.0;
    for k in 0..3 {
        let step = wrap(phi[(k + 1) % 3] - phi[k]);
        if step.abs() > PI - 1e-3 {
            return None;
        }
        winding += step;
        acc += step;
        phi_lo = phi_lo.min(acc);
        phi_hi = phi_hi.max(acc);
    }
    if winding.abs() > PI {
        return None;
    }
    // θ is least at a vertex or where an edge's great circle comes nearest the pole.
    let mut theta_lo = theta.iter().copied().fold(PI, f64::min);
    for k in 0..3 {
        match pole_dip(dirs[k], dirs[(k + 1) % 3]) {
            PoleDip::Ends => {}
            PoleDip::At(q) => {
                theta_lo = theta_lo.min(atan2_bounded((q.x * q.x + q.y * q.y).sqrt(), q.z))
            }
            PoleDip::Unknown => return None,
        }
    }
    let theta_lo = theta_lo - margin;
    let theta_hi = theta.iter().copied().fold(0.0, f64::max) + margin;
    if theta_lo <= 1e-3 {
        return None;
    }
    let sb = margin / theta_lo.sin();
    if sb >= 0.5 {
        return None;
    }
    let phi_margin = asin_bounded(sb) + 4.0 * ATAN_ERROR + 1e-9;
    let spans = hemi.phi_spans(phi_lo - phi_margin, phi_hi + phi_margin)?;
    let np = hemi.n_phi();
    runs.clear();
    let mut cells = 0;
    for i in hemi.rings(theta_lo, theta_hi) {
        for (a, b) in spans {
            if b > a {
                let (a, b) = widen(a, b, np);
                runs.push(i * np + a..i * np + b);
                cells += b - a;
            }
        }
    }
    Some(cells)
}

/// Lanes a run of cells is widened to a multiple of (testing more cells is always
/// exact: the test decides; whole vectors are cheaper than a short run's remainder).
const LANES: usize = 16;

/// The sectors `a..b` of a ring of `np`, widened to a multiple of [`LANES`] (right, or
/// left at the ring's end) where the ring is long enough.
fn widen(a: usize, b: usize, np: usize) -> (usize, usize) {
    let len = (b - a).div_ceil(LANES) * LANES;
    if len > np {
        (a, b)
    } else if a + len <= np {
        (a, a + len)
    } else {
        (np - len, np)
    }
}

/// Marks the tiles of `cells` as changed.
fn mark(dirty: &mut [bool], np: usize, per_ring: usize, cells: Range<usize>) {
    let mut c = cells.start;
    while c < cells.end {
        let ring = c / np;
        let end = cells.end.min((ring + 1) * np);
        let (j0, j1) = (c - ring * np, end - 1 - ring * np);
        dirty[ring * per_ring + j0 / TILE..=ring * per_ring + j1 / TILE].fill(true);
        c = end;
    }
}

/// The distance from `o` to the node's box (0 inside it).
fn box_distance(lo: DVec3, hi: DVec3, o: DVec3) -> f64 {
    (lo - o).max(o - hi).max(DVec3::ZERO).length()
}

/// Where the ray `o + t d` (`inv` = 1 / d, see [`inverse`]) enters the node's box grown
/// by `slack`, if it does at some t ≥ 0.
///
/// In f32: its rounding (a few ulps of the coordinates) is far under the slack the box
/// is grown by, so no box a hit lies in is missed, and the entry is never later than a
/// hit inside the box.
#[inline]
fn slab(node: &Node, o: Vec3, inv: Vec3, slack: f32) -> Option<f32> {
    let a = (node.lo - slack - o) * inv;
    let b = (node.hi + slack - o) * inv;
    let near = a.min(b).max_element().max(0.0);
    let far = a.max(b).min_element();
    (near <= far).then_some(near)
}

/// 1 / d, with a zero component taken as ±1e-30 so that no slab product is NaN (a ray
/// along a slab then has it ±∞ or huge on both sides: inside it, or never).
fn inverse(d: Vec3) -> Vec3 {
    let fix = |x: f32| if x == 0.0 { 1e-30f32.copysign(x) } else { x };
    Vec3::ONE / Vec3::new(fix(d.x), fix(d.y), fix(d.z))
}

/// Builds the subtree of node `index` over `items[first..]` (as many as the node holds:
/// all from `first` on at the root), binned SAH, and returns its box.
fn build(
    boxes: &[(DVec3, DVec3)],
    reach: &[f64],
    items: &mut [PolygonId],
    first: usize,
    index: usize,
    nodes: &mut Vec<Node>,
) {
    let bounds = |ids: &[PolygonId]| {
        ids.iter().fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY, 0.0f64),
            |(lo, hi, r), &i| {
                let (a, b) = boxes[i as usize];
                (lo.min(a), hi.max(b), r.max(reach[i as usize]))
            },
        )
    };
    let (lo, hi, r) = bounds(items);
    nodes[index] = Node {
        lo: Vec3::new(
            outward(lo.x, false),
            outward(lo.y, false),
            outward(lo.z, false),
        ),
        hi: Vec3::new(
            outward(hi.x, true),
            outward(hi.y, true),
            outward(hi.z, true),
        ),
        reach: outward(r, true),
        first: first as u32,
        len: items.len() as u32,
        left: 0,
    };
    if items.len() <= LEAF_SIZE {
        return;
    }
    let centre = |i: PolygonId| {
        let (a, b) = boxes[i as usize];
        0.5 * (a + b)
    };
    let (clo, chi) = items
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            (lo.min(centre(i)), hi.max(centre(i)))
        });
    let extent = chi - clo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = if extent[axis] > 0.0 {
        sah_split(boxes, items, axis, clo[axis], extent[axis], &centre)
    } else {
        None
    };
    let mid = match mid {
        Some(m) => m,
        None => {
            // No useful split by the centres: halve by count, in a fixed order.
            items.sort_unstable_by(|&a, &b| {
                centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b))
            });
            items.len() / 2
        }
    };
    let child = nodes.len();
    nodes.extend([nodes[index]; 2]);
    nodes[index].left = child as u32;
    let (left, right) = items.split_at_mut(mid);
    build(boxes, reach, left, first, child, nodes);
    build(boxes, reach, right, first + mid, child + 1, nodes);
}

/// The binned SAH split of `items` along `axis` (centres from `lo` over `extent`):
/// partitions them and returns the size of the left part, or None if no split is worth
/// having.
fn sah_split(
    boxes: &[(DVec3, DVec3)],
    items: &mut [PolygonId],
    axis: usize,
    lo: f64,
    extent: f64,
    centre: &impl Fn(PolygonId) -> DVec3,
) -> Option<usize> {
    let bin =
        |i: PolygonId| (((centre(i)[axis] - lo) / extent * BINS as f64) as usize).min(BINS - 1);
    let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY, 0usize);
    let mut bins = [empty; BINS];
    for &i in items.iter() {
        let (a, b) = boxes[i as usize];
        let e = &mut bins[bin(i)];
        *e = (e.0.min(a), e.1.max(b), e.2 + 1);
    }
    let area = |lo: DVec3, hi: DVec3| {
        let d = (hi - lo).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    // Areas and counts to the right of each boundary.
    let mut right = [(0.0, 0usize); BINS];
    let mut acc = empty;
    for k in (1..BINS).rev() {
        let e = bins[k];
        acc = (acc.0.min(e.0), acc.1.max(e.1), acc.2 + e.2);
        right[k] = (area(acc.0, acc.1), acc.2);
    }
    let mut best: Option<(f64, usize)> = None;
    let mut acc = empty;
    for k in 1..BINS {
        let e = bins[k - 1];
        acc = (acc.0.min(e.0), acc.1.max(e.1), acc.2 + e.2);
        let (ra, rn) = right[k];
        if acc.2 == 0 || rn == 0 {
            continue;
        }
        let cost = area(acc.0, acc.1) * acc.2 as f64 + ra * rn as f64;
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, k));
        }
    }
    let (_, split) = best?;
    // Partition, keeping a fixed order on each side.
    items.sort_unstable_by_key(|&i| (bin(i) >= split, i));
    Some(items.iter().filter(|&&i| bin(i) < split).count())
}

impl Caster for Hierarchy {
    type Scratch = HierarchyScratch;

    fn scratch(&self) -> HierarchyScratch {
        HierarchyScratch::default()
    }

    fn item_buffer_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        at: Viewpoint,
        scratch: &mut HierarchyScratch,
        buf: &mut ItemBuffer,
    ) {
        self.scan_at(scene, hemi, at, scratch, buf)
    }

    fn closest_hits(
        &self,
        scene: &Scene,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut HierarchyScratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        self.check(scene);
        out.clear();
        let polygons = scene.polygons();
        let own = polygons.get(skip as usize).map(|p| p.normal());
        // The grid's culling: with every ray leaving the plane of `skip` forwards, a
        // polygon wholly behind it is never tested.
        let cull = own.filter(|&n| dirs.iter().all(|d| d.dot(n) > 0.0));
        let o = origin.as_dvec3();
        let slack = self.slack(o);
        let hits = &mut scratch.scan.rays;
        hits.begin_rays(dirs);
        let stack = &mut scratch.stack;
        for (k, d) in dirs.iter().enumerate() {
            self.walk_ray(origin, *d, slack, stack, f64::INFINITY, |range| {
                for i in range {
                    let id = self.items[i].id;
                    let poly: &Polygon = &polygons[id as usize];
                    if id == skip || cull.is_some_and(|n| poly.wholly_behind(o, n.as_dvec3())) {
                        continue;
                    }
                    let terms = scene.seen(id as usize, self.terms[i].at(origin));
                    hits.test_with::<true>(poly, id, &terms, k..k + 1);
                }
                // A polygon met no nearer than the best so far could still win a tie.
                hits.best_t()[k] as f64 * (1.0 + 1e-6) + slack
            });
        }
        scratch.scan.rays.hits_into(polygons, dirs, out);
    }

    fn all_hits_along(
        &self,
        scene: &Scene,
        ray: &Ray,
        scratch: &mut HierarchyScratch,
        out: &mut Vec<Hit>,
    ) {
        self.all_hits(scene, ray, &mut scratch.stack, out)
    }
}

/// The largest error of [`atan2_bounded`] and [`asin_bounded`] in radians (the series'
/// remainder, 2e-8, and f64 rounding, far below; tested against libm).
const ATAN_ERROR: f64 = 1e-7;

/// atan2(y, x) within [`ATAN_ERROR`], by a reduction to |z| ≤ tan(π/8) and eight terms
/// of the alternating series (remainder under 0.415¹⁷ / 17 < 2e-8): what the footprints
/// need, at a fraction of libm's cost.
fn atan2_bounded(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let (ax, ay) = (x.abs(), y.abs());
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    // a = atan(min / max) in [0, π/4].
    let (num, den) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    let z = num / den;
    let (base, w) = if z > 0.414_213_562_373_095_1 {
        (FRAC_PI_4, (z - 1.0) / (z + 1.0))
    } else {
        (0.0, z)
    };
    let w2 = w * w;
    let series = w
        * (1.0
            - w2 * (1.0 / 3.0
                - w2 * (1.0 / 5.0
                    - w2 * (1.0 / 7.0
                        - w2 * (1.0 / 9.0
                            - w2 * (1.0 / 11.0 - w2 * (1.0 / 13.0 - w2 * (1.0 / 15.0))))))));
    let a = base + series;
    let a = if ay <= ax { a } else { FRAC_PI_2 - a };
    let a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 {
        -a
    } else {
        a
    }
}

/// asin(s) for s in [0, 1] within [`ATAN_ERROR`].
fn asin_bounded(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    atan2_bounded(s, (1.0 - s * s).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_angles_are_within_their_error() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut worst = 0.0f64;
        for k in 0..200_000 {
            // Every octant, and magnitudes from tiny to large.
            let scale = 10f64.powi((k % 13) - 6);
            let (y, x) = (next() * scale, next());
            worst = worst.max((atan2_bounded(y, x) - y.atan2(x)).abs());
            let s = next().abs();
            worst = worst.max((asin_bounded(s) - s.asin()).abs());
        }
        for (y, x) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-2.0, -2.0),
        ] {
            worst = worst.max((atan2_bounded(y, x) - f64::atan2(y, x)).abs());
        }
        assert!(asin_bounded(1.0) - std::f64::consts::FRAC_PI_2 < 1e-12);
        assert!(worst < 0.2 * ATAN_ERROR, "worst error {worst:e}");
    }
}
