//! The schedule: which patches are cast exactly and which are estimated from them.
//!
//! The report's (§3.6): each polygon's patch grid scanned by non-overlapping 3 × 3
//! windows; the centre patch is cast exactly, the others estimated from it. A polygon of
//! one patch (a mesh's triangle) has no neighbour of its own, so those are grouped across
//! polygons instead: neighbouring one-patch polygons of one plane (normals within
//! [`crate::MAX_TILT`] of the first one's, the same plane to a thousandth of a window:
//! so within twice that of each other) make a window of
//! about nine patches, whose centre is cast exactly and whose other patches are estimated
//! from it in their own frames, turned about the normal (see [`crate::frame_turn`]).

use crate::estimator::frame_turn;
use glam::DVec3;
use rad_core::PatchId;
use rad_geometry::Scene;
use std::collections::BTreeMap;

/// One window: the patch cast exactly and the patches estimated from it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Window {
    pub centre: PatchId,
    pub estimated: Vec<PatchId>,
}

/// A scene's windows, and the window of each patch.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Schedule {
    windows: Vec<Window>,
    /// By patch: the index of its window.
    window_of: Vec<u32>,
}

impl Schedule {
    /// The schedule of `scene` (see the module's text and [`windows`]).
    pub fn of(scene: &Scene) -> Schedule {
        let windows = windows(scene);
        let mut window_of = vec![u32::MAX; scene.patches().len()];
        for (k, w) in windows.iter().enumerate() {
            for &p in std::iter::once(&w.centre).chain(&w.estimated) {
                window_of[p as usize] = k as u32;
            }
        }
        debug_assert!(
            window_of.iter().all(|&k| k != u32::MAX),
            "every patch in a window"
        );
        Schedule { windows, window_of }
    }

    /// Every window, in the order of [`windows`].
    pub fn windows(&self) -> &[Window] {
        &self.windows
    }

    /// The number of patches of its scene.
    pub fn n_patches(&self) -> usize {
        self.window_of.len()
    }

    /// The index (in [`Schedule::windows`]) of the window holding `patch`.
    pub fn window_of(&self, patch: PatchId) -> usize {
        self.window_of[patch as usize] as usize
    }
}

/// The most patches a window across polygons holds: a group of one plane's neighbours
/// larger than this (a finely cut corner of a mesh) is split in eight until each part
/// holds at most this many.
pub const MAX_WINDOW: usize = 12;

/// The windows of every polygon, in polygon order (a window across polygons where its
/// lowest patch's polygon comes).
///
/// A polygon of several patches: windows start at cell (0, 0) (the corner of the
/// polygon's (u, v) box: its vertex 0 for a parallelogram or triangle) and step by 3
/// cells along u and v without overlapping. At a polygon's far edges a window is cut
/// short (1 or 2 cells wide); its exact patch is the cell nearest the cut window's
/// centre, i.e. cell `start + (width − 1) / 2` on each axis (the first of two, the only
/// one of one). Where that cell has no patch (a clipped polygon), the window's existing
/// patch nearest to it is cast instead (the lowest id on ties).
///
/// Polygons of one patch: their centres binned in cubes of side 3h (h the median of
/// √area over them, so that a cube of a plane holds about nine), the cubes' origin the
/// lowest corner of the centres' box; in each cube, the patches of one plane (normals
/// parallel to the lowest one's within [`crate::MAX_TILT`], within a thousandth of the
/// cube's side of its plane) make
/// a window, split in eight while it holds over [`MAX_WINDOW`]; its exact patch is the
/// one nearest the window's mean centre (the lowest id on ties).
pub fn windows(scene: &Scene) -> Vec<Window> {
    let patches = scene.patches();
    let polygons = scene.polygons();
    // Each polygon's patches: first..end.
    let mut end = vec![0usize; polygons.len()];
    for (k, p) in patches.iter().enumerate() {
        end[p.polygon as usize] = k + 1;
    }
    let range = |idx: usize| {
        let first = polygons[idx].first_patch() as usize;
        first..end[idx].max(first)
    };
    let singles: Vec<PatchId> = (0..polygons.len())
        .filter(|&idx| range(idx).len() == 1)
        .map(|idx| range(idx).start as PatchId)
        .collect();
    // Windows across polygons, by their lowest patch.
    let mut across: BTreeMap<PatchId, Window> = across_polygons(scene, &singles)
        .into_iter()
        .map(|w| (lowest(&w), w))
        .collect();
    let mut out = Vec::new();
    for (idx, poly) in polygons.iter().enumerate() {
        let r = range(idx);
        if r.len() == 1 {
            if let Some(w) = across.remove(&(r.start as PatchId)) {
                out.push(w);
            }
            continue;
        }
        let (nu, nv) = poly.grid();
        let first = r.start;
        // Cell → patch of this polygon.
        let mut cell = vec![PatchId::MAX; (nu * nv) as usize];
        for (k, p) in patches[r].iter().enumerate() {
            cell[(p.cell[1] * nu + p.cell[0]) as usize] = (first + k) as PatchId;
        }
        for j0 in (0..nv).step_by(3) {
            for i0 in (0..nu).step_by(3) {
                let (w, h) = ((nu - i0).min(3), (nv - j0).min(3));
                let (ci, cj) = (i0 + (w - 1) / 2, j0 + (h - 1) / 2);
                let mut members: Vec<(u32, PatchId)> = Vec::new();
                for j in j0..j0 + h {
                    for i in i0..i0 + w {
                        let id = cell[(j * nu + i) as usize];
                        if id != PatchId::MAX {
                            members.push((i.abs_diff(ci) + j.abs_diff(cj), id));
                        }
                    }
                }
                let Some(&(_, centre)) = members.iter().min() else {
                    continue;
                };
                let mut estimated: Vec<PatchId> = members
                    .iter()
                    .map(|m| m.1)
                    .filter(|&p| p != centre)
                    .collect();
                estimated.sort_unstable();
                out.push(Window { centre, estimated });
            }
        }
    }
    debug_assert!(across.is_empty(), "every window across polygons placed");
    out
}

/// A window's lowest patch.
fn lowest(w: &Window) -> PatchId {
    w.estimated.first().map_or(w.centre, |&e| e.min(w.centre))
}

/// The windows of the one-patch polygons' patches `singles` (see [`windows`]).
fn across_polygons(scene: &Scene, singles: &[PatchId]) -> Vec<Window> {
    if singles.is_empty() {
        return Vec::new();
    }
    let patches = scene.patches();
    let centre = |p: PatchId| patches[p as usize].center.as_dvec3();
    let mut sizes: Vec<f64> = singles
        .iter()
        .map(|&p| patches[p as usize].area.sqrt())
        .collect();
    sizes.sort_unstable_by(f64::total_cmp);
    let side = 3.0 * sizes[sizes.len() / 2];
    let lo = singles
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |m, &p| m.min(centre(p)));
    // Cubes, in key order; patches in id order within each.
    let mut cubes: BTreeMap<[i64; 3], Vec<PatchId>> = BTreeMap::new();
    for &p in singles {
        let k = ((centre(p) - lo) / side).floor();
        cubes
            .entry([k.x as i64, k.y as i64, k.z as i64])
            .or_default()
            .push(p);
    }
    let mut out = Vec::new();
    for (key, members) in cubes {
        let box_lo = lo + DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) * side;
        for plane in planes(scene, &members, side) {
            split(scene, plane, box_lo, side, 0, &mut out);
        }
    }
    out
}

/// `members` (in id order) by plane: each joins the first group whose lowest patch's
/// polygon has a parallel normal ([`frame_turn`]) and whose plane it lies on to within
/// a thousandth of `side`.
fn planes(scene: &Scene, members: &[PatchId], side: f64) -> Vec<Vec<PatchId>> {
    let patches = scene.patches();
    let mut groups: Vec<Vec<PatchId>> = Vec::new();
    for &p in members {
        let pp = &patches[p as usize];
        let joins = |g: &Vec<PatchId>| {
            let q = &patches[g[0] as usize];
            let n = scene.polygons()[q.polygon as usize].frame().n.as_dvec3();
            frame_turn(scene, q.polygon, pp.polygon).is_some()
                && (pp.center.as_dvec3() - q.center.as_dvec3()).dot(n).abs() <= 1e-3 * side
        };
        match groups.iter_mut().find(|g| joins(g)) {
            Some(g) => g.push(p),
            None => groups.push(vec![p]),
        }
    }
    groups
}

/// Windows of one plane's `members` (in id order) within the cube at `lo` of side
/// `side`: one, or the cube's eight halves' while it holds over [`MAX_WINDOW`].
fn split(
    scene: &Scene,
    members: Vec<PatchId>,
    lo: DVec3,
    side: f64,
    depth: u32,
    out: &mut Vec<Window>,
) {
    let patches = scene.patches();
    let centre = |p: PatchId| patches[p as usize].center.as_dvec3();
    // (Depth 30 halves the cube a billion times: centres still together then are
    // windows of MAX_WINDOW in id order.)
    if members.len() > MAX_WINDOW && depth < 30 {
        let half = side / 2.0;
        let mut parts: [Vec<PatchId>; 8] = Default::default();
        for &p in &members {
            let c = centre(p) - lo;
            let bit = |x: f64| usize::from(x >= half);
            parts[bit(c.x) | bit(c.y) << 1 | bit(c.z) << 2].push(p);
        }
        for (k, part) in parts.into_iter().enumerate() {
            if !part.is_empty() {
                let at = |b: usize| if k >> b & 1 == 1 { half } else { 0.0 };
                let sub = lo + DVec3::new(at(0), at(1), at(2));
                split(scene, part, sub, half, depth + 1, out);
            }
        }
        return;
    }
    for chunk in members.chunks(MAX_WINDOW) {
        let mean = chunk.iter().map(|&p| centre(p)).sum::<DVec3>() / chunk.len() as f64;
        let (_, centre_patch) = chunk
            .iter()
            .map(|&p| (centre(p).distance_squared(mean), p))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .expect("a non-empty chunk");
        let estimated = chunk
            .iter()
            .copied()
            .filter(|&p| p != centre_patch)
            .collect();
        out.push(Window {
            centre: centre_patch,
            estimated,
        });
    }
}
