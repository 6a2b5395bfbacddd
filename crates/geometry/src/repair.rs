//! `--repair`: mesh files as they come. Vertices closer than a tolerance are welded;
//! faces that welding collapses, and exact duplicates, are dropped; each connected
//! piece's faces are oriented consistently across the edges they share (a closed piece
//! outward by its signed volume, unless it encloses the whole scene, a room, which
//! faces inward; an open piece the way most of its faces already face); and of two
//! faces folded onto each other across a shared edge (coplanar, overlapping), the
//! folded one is dropped. [`survey`] says what [`repair`] would change, for warnings.
//!
//! No crate is used: the mesh crates we looked at (tri-mesh, meshopt) either want a
//! manifold mesh to start from or do not orient; the work is sorting edges and a walk.

use crate::clip::{clip_convex, plane_frame, polygon_area_centroid};
use crate::overlap::{NORMAL_TOLERANCE, OVERLAP_FRACTION, PLANE_TOLERANCE};
use crate::scene::SceneDesc;
use glam::DVec3;
use rustc_hash::FxHashMap;
use std::collections::hash_map::Entry;

/// Vertices closer than this fraction of the scene's bounding-box diagonal are welded,
/// unless a distance is given.
pub const WELD_RELATIVE: f64 = 1e-6;

/// The welding grid's cell, in welding distances: large enough that most positions
/// lie in one cell only, small enough that a cell holds few.
const WELD_CELL: f64 = 8.0;

/// How many changed faces a [`Repair`] names.
pub const REPAIR_EXAMPLES: usize = 5;

/// What [`repair`] changed (or, from [`survey`], would change).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Repair {
    /// The welding distance used, in scene units.
    pub weld_tolerance: f64,
    /// Distinct vertex positions moved onto another within the tolerance.
    pub welded: usize,
    /// Faces dropped because welding left them fewer than 3 distinct vertices.
    pub collapsed: usize,
    /// Faces dropped as exact duplicates (the same vertices, either winding) of an
    /// earlier face.
    pub duplicates: usize,
    /// Faces dropped as folded onto a coplanar neighbour across a shared edge.
    pub folded: usize,
    /// Faces whose winding was reversed.
    pub flipped: usize,
    /// Connected pieces (faces joined by edges that exactly two faces share).
    pub pieces: usize,
    /// Pieces that are closed (every edge shared by exactly two faces).
    pub closed: usize,
    /// Closed pieces that enclose the whole scene, and so face inward.
    pub enclosures: usize,
    /// Shared edges that no orientation makes consistent (a Möbius band, a Klein bottle).
    pub unorientable: usize,
    /// The first [`REPAIR_EXAMPLES`] changed faces, named with what happened.
    pub examples: Vec<String>,
}

impl Repair {
    /// Faces dropped, for every reason.
    pub fn dropped(&self) -> usize {
        self.collapsed + self.duplicates + self.folded
    }

    /// Whether any face or vertex changes.
    pub fn changes(&self) -> bool {
        self.dropped() + self.flipped + self.welded > 0
    }
}

/// Repairs `desc` in place (see the module's header); `weld` is the welding distance in
/// scene units (default [`WELD_RELATIVE`] of the bounding-box diagonal; 0 welds only
/// positions equal to the bit). Faces with a non-finite vertex are left for validation
/// to name.
pub fn repair(desc: &mut SceneDesc, weld: Option<f64>) -> Repair {
    let plan = Plan::of(desc, weld);
    plan.apply(desc);
    plan.report
}

/// What [`repair`] would change, `desc` unchanged.
pub fn survey(desc: &SceneDesc, weld: Option<f64>) -> Repair {
    Plan::of(desc, weld).report
}

/// A face's edge: (lower vertex id, higher, the face, whether the face runs it from
/// lower to higher).
type Edge = (u32, u32, u32, bool);

/// The edges' groups that share their ends.
fn by_ends(edges: &[Edge]) -> impl Iterator<Item = &[Edge]> {
    edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1))
}

/// An edge's ends.
fn fold_ends(e: &Edge) -> (u32, u32) {
    (e.0, e.1)
}

/// Why a face is dropped.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fate {
    Keep,
    Collapsed,
    DuplicateOf(usize),
    FoldedOnto(usize),
}

/// The repair of one scene, worked out before anything changes.
struct Plan {
    /// Vertex positions after welding, by vertex id.
    positions: Vec<DVec3>,
    /// Face f's vertex ids (welded, repeats removed): `ids[start[f]..start[f + 1]]`;
    /// faces left out (non-finite) have none.
    start: Vec<usize>,
    ids: Vec<u32>,
    fate: Vec<Fate>,
    flip: Vec<bool>,
    report: Repair,
}

impl Plan {
    fn of(desc: &SceneDesc, weld: Option<f64>) -> Plan {
        let faces = &desc.polygons;
        let finite = |f: usize| faces[f].vertices.iter().all(|v| v.is_finite());
        let (lo, hi) = faces
            .iter()
            .enumerate()
            .filter(|&(f, _)| finite(f))
            .flat_map(|(_, p)| p.vertices.iter())
            .fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &v| (lo.min(v), hi.max(v)),
            );
        let diagonal = if lo.x <= hi.x {
            (hi - lo).length()
        } else {
            0.0
        };
        let tolerance = weld.unwrap_or(WELD_RELATIVE * diagonal).max(0.0);
        let mut report = Repair {
            weld_tolerance: tolerance,
            ..Repair::default()
        };
        // Distinct positions (bit for bit, -0 as 0), in file order, then welded.
        let refs = faces.iter().map(|p| p.vertices.len()).sum::<usize>();
        let mut index: FxHashMap<[u64; 3], u32> =
            FxHashMap::with_capacity_and_hasher(refs / 4, Default::default());
        let mut positions = Vec::new();
        let mut raw = Vec::new();
        let mut start = vec![0usize];
        for (f, face) in faces.iter().enumerate() {
            if finite(f) {
                for &v in &face.vertices {
                    let key = (v + DVec3::ZERO).to_array().map(f64::to_bits);
                    let id = *index.entry(key).or_insert_with(|| {
                        positions.push(v);
                        (positions.len() - 1) as u32
                    });
                    raw.push(id);
                }
            }
            start.push(raw.len());
        }
        drop(index);
        let rep = weld_positions(&positions, tolerance);
        report.welded = rep
            .iter()
            .enumerate()
            .filter(|&(v, &r)| r as usize != v)
            .count();
        let positions: Vec<DVec3> = rep.iter().map(|&r| positions[r as usize]).collect();
        // Each face's welded ids, repeats removed, and the same sorted (the key of
        // duplicates, either winding); collapsed and duplicate faces dropped.
        let mut welded = Vec::with_capacity(raw.len());
        let mut sorted = Vec::with_capacity(raw.len());
        let mut welded_start = vec![0usize];
        for f in 0..faces.len() {
            let from = welded.len();
            for &v in &raw[start[f]..start[f + 1]] {
                if welded.len() == from || welded[welded.len() - 1] != rep[v as usize] {
                    welded.push(rep[v as usize]);
                }
            }
            while welded.len() > from + 1 && welded[from] == welded[welded.len() - 1] {
                welded.pop();
            }
            sorted.extend_from_slice(&welded[from..]);
            sorted[from..].sort_unstable();
            welded_start.push(welded.len());
        }
        let mut ids = Vec::with_capacity(welded.len());
        let mut kept_start = vec![0usize];
        let mut fate = vec![Fate::Keep; faces.len()];
        let mut seen: FxHashMap<&[u32], usize> =
            FxHashMap::with_capacity_and_hasher(faces.len(), Default::default());
        for f in 0..faces.len() {
            let range = welded_start[f]..welded_start[f + 1];
            if range.len() < 3 && distinct(&raw[start[f]..start[f + 1]]) >= 3 {
                fate[f] = Fate::Collapsed;
                report.collapsed += 1;
            } else if range.len() >= 3 {
                match seen.entry(&sorted[range.clone()]) {
                    Entry::Occupied(first) => {
                        fate[f] = Fate::DuplicateOf(*first.get());
                        report.duplicates += 1;
                    }
                    Entry::Vacant(slot) => {
                        slot.insert(f);
                        ids.extend_from_slice(&welded[range]);
                    }
                }
            }
            kept_start.push(ids.len());
        }
        drop(seen);
        let mut plan = Plan {
            positions,
            start: kept_start,
            ids,
            flip: vec![false; faces.len()],
            fate,
            report,
        };
        let mut edges = plan.edges();
        plan.drop_folded(&edges, diagonal);
        edges.retain(|e| plan.fate[e.2 as usize] == Fate::Keep);
        plan.orient(&edges, diagonal);
        plan.name_changes(desc);
        plan
    }

    /// Face f's vertex ids as in the file, welded; none for a face dropped or left out.
    fn face(&self, f: usize) -> &[u32] {
        if self.fate[f] == Fate::Keep {
            &self.ids[self.start[f]..self.start[f + 1]]
        } else {
            &[]
        }
    }

    /// Face f's vertex ids as it will be wound (the first kept, the rest reversed if it
    /// is turned over).
    fn wound(&self, f: usize) -> impl Iterator<Item = u32> + '_ {
        let face = self.face(f);
        let turned = self.flip[f];
        (0..face.len()).map(move |k| {
            if turned && k > 0 {
                face[face.len() - k]
            } else {
                face[k]
            }
        })
    }

    /// Face f's unit normal (as it will be wound), zero if it has no area.
    fn normal(&self, f: usize) -> DVec3 {
        let mut w = self.wound(f).map(|v| self.positions[v as usize]);
        let Some(o) = w.next() else {
            return DVec3::ZERO;
        };
        let mut n = DVec3::ZERO;
        let mut last: Option<DVec3> = None;
        for p in w {
            if let Some(q) = last {
                n += (q - o).cross(p - o);
            }
            last = Some(p);
        }
        n.normalize_or_zero()
    }

    /// Edges of the faces kept, sorted.
    fn edges(&self) -> Vec<Edge> {
        let mut edges = Vec::with_capacity(self.ids.len());
        for f in 0..self.fate.len() {
            let face = self.face(f);
            for k in 0..face.len() {
                let (a, b) = (face[k], face[(k + 1) % face.len()]);
                edges.push((a.min(b), a.max(b), f as u32, a < b));
            }
        }
        edges.sort_unstable();
        edges
    }

    /// Orients each piece (see the module's header).
    fn orient(&mut self, edges: &[Edge], diagonal: f64) {
        let n = self.fate.len();
        // Faces across edges that exactly two faces share, with whether they run the
        // same way there (then one of the two must turn), as compressed rows; faces
        // with another edge are open.
        let mut open = vec![false; n];
        let mut first = vec![0u32; n + 1];
        let manifold = |group: &[Edge]| matches!(group, [a, b] if a.2 != b.2);
        for group in by_ends(edges) {
            if manifold(group) {
                group.iter().for_each(|e| first[e.2 as usize + 1] += 1);
            } else {
                group.iter().for_each(|e| open[e.2 as usize] = true);
            }
        }
        for f in 0..n {
            first[f + 1] += first[f];
        }
        let mut links = vec![(0u32, false); first[n] as usize];
        let mut fill = first.clone();
        for group in by_ends(edges).filter(|g| manifold(g)) {
            let (a, b) = (group[0], group[1]);
            for (x, y) in [(a, b), (b, a)] {
                links[fill[x.2 as usize] as usize] = (y.2, a.3 == b.3);
                fill[x.2 as usize] += 1;
            }
        }
        let links = |f: usize| &links[first[f] as usize..first[f + 1] as usize];
        let (lo, hi) = self.bounds(0..n);
        let live = (0..n).filter(|&f| !self.face(f).is_empty()).count();
        let mut piece_of = vec![u32::MAX; n];
        for seed in 0..n {
            if piece_of[seed] != u32::MAX || self.face(seed).is_empty() {
                continue;
            }
            let piece = self.report.pieces as u32;
            self.report.pieces += 1;
            piece_of[seed] = piece;
            let mut members = vec![seed];
            let mut k = 0;
            while k < members.len() {
                let f = members[k];
                k += 1;
                for &(g, same) in links(f) {
                    let want = self.flip[f] ^ same;
                    if piece_of[g as usize] == u32::MAX {
                        piece_of[g as usize] = piece;
                        self.flip[g as usize] = want;
                        members.push(g as usize);
                    } else if self.flip[g as usize] != want && f < g as usize {
                        self.report.unorientable += 1;
                    }
                }
            }
            let turn = if members.iter().all(|&f| !open[f]) {
                self.report.closed += 1;
                let (plo, phi) = self.bounds(members.iter().copied());
                let room = members.len() < live
                    && (plo - lo).abs().max_element() <= 1e-9 * diagonal
                    && (phi - hi).abs().max_element() <= 1e-9 * diagonal;
                let volume = self.volume(&members);
                if room {
                    self.report.enclosures += 1;
                    volume > 0.0
                } else {
                    volume < 0.0
                }
            } else {
                2 * members.iter().filter(|&&f| self.flip[f]).count() > members.len()
            };
            for &f in &members {
                self.flip[f] ^= turn;
            }
        }
        self.report.flipped = self.flip.iter().filter(|&&t| t).count();
    }

    fn bounds(&self, faces: impl Iterator<Item = usize>) -> (DVec3, DVec3) {
        faces.flat_map(|f| self.face(f).iter()).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &v| {
                let p = self.positions[v as usize];
                (lo.min(p), hi.max(p))
            },
        )
    }

    /// The signed volume the faces enclose as they will be wound (positive: outward).
    fn volume(&self, faces: &[usize]) -> f64 {
        let o = self.positions[self.face(faces[0])[0] as usize];
        let mut six = 0.0;
        for &f in faces {
            let mut w = self.wound(f).map(|v| self.positions[v as usize] - o);
            let Some(p0) = w.next() else { continue };
            let mut last: Option<DVec3> = None;
            for p in w {
                if let Some(q) = last {
                    six += p0.dot(q.cross(p));
                }
                last = Some(p);
            }
        }
        six / 6.0
    }

    /// Of two faces sharing an edge, coplanar and overlapping, drops the folded one:
    /// the one whose neighbours across its other edges turn furthest from it (a face
    /// with no such neighbour first), then the smaller, then the later. Before the faces are
    /// oriented, so that a piece is closed or not without the folds.
    fn drop_folded(&mut self, edges: &[Edge], diagonal: f64) {
        let normals: Vec<DVec3> = (0..self.fate.len()).map(|f| self.normal(f)).collect();
        let tolerance = PLANE_TOLERANCE * diagonal.max(f64::MIN_POSITIVE);
        for group in by_ends(edges) {
            for (i, a) in group.iter().enumerate() {
                for b in &group[i + 1..] {
                    let (f, g) = (a.2 as usize, b.2 as usize);
                    if self.fate[f] != Fate::Keep || self.fate[g] != Fate::Keep || f == g {
                        continue;
                    }
                    let (nf, ng) = (normals[f], normals[g]);
                    let facing = nf.dot(ng).signum();
                    if (nf - facing * ng).length() > NORMAL_TOLERANCE {
                        continue;
                    }
                    let origin = self.positions[self.face(f)[0] as usize];
                    let flat = self
                        .face(g)
                        .iter()
                        .all(|&v| nf.dot(self.positions[v as usize] - origin).abs() <= tolerance);
                    if !flat {
                        continue;
                    }
                    if self.either_side(f, g, fold_ends(a), nf) {
                        continue;
                    }
                    let (shared, af, ag) = self.shared_area(f, g, nf, facing < 0.0);
                    if shared <= OVERLAP_FRACTION * af.min(ag) {
                        continue;
                    }
                    let fold = fold_ends(a);
                    let tf = self.turn(edges, &normals, f, fold);
                    let tg = self.turn(edges, &normals, g, fold);
                    let folded = if tf != tg {
                        if tf < tg {
                            f
                        } else {
                            g
                        }
                    } else if af != ag {
                        if af < ag {
                            f
                        } else {
                            g
                        }
                    } else {
                        g
                    };
                    let onto = f + g - folded;
                    self.fate[folded] = Fate::FoldedOnto(onto);
                    self.report.folded += 1;
                }
            }
        }
    }

    /// How far the faces across face h's edges other than `fold` turn from it: the
    /// least dot product of the normals (a face that runs the edge the same way as h is
    /// wound against it, and its normal is turned to compare the two as a consistently
    /// wound surface would); -inf if there are none.
    fn turn(&self, edges: &[Edge], normals: &[DVec3], h: usize, fold: (u32, u32)) -> f64 {
        let face = self.face(h);
        let mut least = None::<f64>;
        for k in 0..face.len() {
            let (a, b) = (face[k], face[(k + 1) % face.len()]);
            let ends = (a.min(b), a.max(b));
            if ends == fold {
                continue;
            }
            let from = edges.partition_point(|e| (e.0, e.1) < ends);
            for e in edges[from..].iter().take_while(|e| (e.0, e.1) == ends) {
                if e.2 as usize != h {
                    let dot = normals[h].dot(normals[e.2 as usize]);
                    let dot = if e.3 == (a < b) { -dot } else { dot };
                    least = Some(least.map_or(dot, |l| l.min(dot)));
                }
            }
        }
        least.unwrap_or(f64::NEG_INFINITY)
    }

    /// Whether faces f and g (convex, in the plane of normal `n`) lie on either side of
    /// the line through their shared edge `ends`, and so cannot overlap: most faces
    /// that share an edge, settled without clipping.
    fn either_side(&self, f: usize, g: usize, ends: (u32, u32), n: DVec3) -> bool {
        let (a, b) = (
            self.positions[ends.0 as usize],
            self.positions[ends.1 as usize],
        );
        let across = n.cross(b - a);
        let side = |h: usize| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &v in self.face(h) {
                let d = across.dot(self.positions[v as usize] - a);
                (lo, hi) = (lo.min(d), hi.max(d));
            }
            (lo, hi)
        };
        let ((flo, fhi), (glo, ghi)) = (side(f), side(g));
        (flo >= 0.0 && ghi <= 0.0) || (fhi <= 0.0 && glo >= 0.0)
    }

    /// The area faces f and g share in f's plane (g reversed if it faces the other
    /// way), and each one's area.
    fn shared_area(&self, f: usize, g: usize, normal: DVec3, reverse: bool) -> (f64, f64, f64) {
        let (ex, ey) = plane_frame(normal);
        let o = self.positions[self.face(f)[0] as usize];
        let flat = |h: usize| -> Vec<[f64; 2]> {
            self.wound(h)
                .map(|v| {
                    let d = self.positions[v as usize] - o;
                    [d.dot(ex), d.dot(ey)]
                })
                .collect()
        };
        let a = flat(f);
        let mut b = flat(g);
        if reverse {
            b.reverse();
        }
        let area = |p: &[[f64; 2]]| polygon_area_centroid(p).0.abs();
        (area(&clip_convex(&a, &b)), area(&a), area(&b))
    }

    /// Names the first changed faces: those dropped, then those turned over.
    fn name_changes(&mut self, desc: &SceneDesc) {
        let name = |f: usize| &desc.polygons[f].name;
        let dropped = (0..self.fate.len()).filter(|&f| self.fate[f] != Fate::Keep);
        let turned = (0..self.fate.len()).filter(|&f| self.fate[f] == Fate::Keep && self.flip[f]);
        for f in dropped.chain(turned).take(REPAIR_EXAMPLES) {
            let what = match self.fate[f] {
                Fate::Collapsed => "dropped: welding left it fewer than 3 vertices".to_string(),
                Fate::DuplicateOf(g) => format!("dropped: a duplicate of {:?}", name(g)),
                Fate::FoldedOnto(g) => format!("dropped: folded onto {:?}", name(g)),
                Fate::Keep => "turned over".to_string(),
            };
            self.report.examples.push(format!("{:?} {what}", name(f)));
        }
    }

    fn apply(&self, desc: &mut SceneDesc) {
        let faces = std::mem::take(&mut desc.polygons);
        for (f, mut face) in faces.into_iter().enumerate() {
            if self.fate[f] != Fate::Keep {
                continue;
            }
            if !self.face(f).is_empty() {
                face.vertices = self.wound(f).map(|v| self.positions[v as usize]).collect();
            }
            desc.polygons.push(face);
        }
    }
}

/// How many distinct ids a face has.
fn distinct(face: &[u32]) -> usize {
    let mut ids = face.to_vec();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

/// For each position, the first (in order) within `tolerance` of it, through chains of
/// such pairs; 0 welds nothing.
///
/// Positions are hashed into cubic cells of [`WELD_CELL`] tolerances; a position is
/// compared with those in its own cell and in the neighbouring cells it lies within
/// `tolerance` of (one cell for most positions, not 27).
fn weld_positions(positions: &[DVec3], tolerance: f64) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..positions.len() as u32).collect();
    if tolerance <= 0.0 || !tolerance.is_finite() {
        return parent;
    }
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    let size = WELD_CELL * tolerance;
    let mut grid: FxHashMap<[i64; 3], Vec<u32>> = FxHashMap::default();
    for (v, &p) in positions.iter().enumerate() {
        let scaled = p / size;
        let c = scaled.floor().to_array().map(|c| c as i64);
        // Along each axis: this cell, and the one below or above if p is that near.
        let reach = scaled.to_array().map(|x| {
            let frac = x - x.floor();
            let near = tolerance / size;
            (-i64::from(frac <= near), i64::from(frac >= 1.0 - near))
        });
        for dx in reach[0].0..=reach[0].1 {
            for dy in reach[1].0..=reach[1].1 {
                for dz in reach[2].0..=reach[2].1 {
                    let key = [
                        c[0].wrapping_add(dx),
                        c[1].wrapping_add(dy),
                        c[2].wrapping_add(dz),
                    ];
                    for &u in grid.get(&key).map(Vec::as_slice).unwrap_or(&[]) {
                        if positions[u as usize].distance(p) <= tolerance {
                            let (ru, rv) = (root(&mut parent, u), root(&mut parent, v as u32));
                            parent[ru.max(rv) as usize] = ru.min(rv);
                        }
                    }
                }
            }
        }
        grid.entry(c).or_default().push(v as u32);
    }
    (0..positions.len() as u32)
        .map(|v| root(&mut parent, v))
        .collect()
}
