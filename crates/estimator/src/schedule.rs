//! The report's schedule (§3.6): each polygon's patch grid scanned by non-overlapping
//! 3 × 3 windows; the centre patch is cast exactly, the others estimated from it.

use rad_core::PatchId;
use rad_geometry::Scene;

/// One window: the patch cast exactly and the patches estimated from it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Window {
    pub centre: PatchId,
    pub estimated: Vec<PatchId>,
}

/// The windows of every polygon, polygon by polygon.
///
/// Windows start at cell (0, 0) (the corner of the polygon's (u, v) box: its vertex 0
/// for a parallelogram or triangle) and step by 3 cells along u and v without overlapping. At a polygon's far
/// edges a window is cut short (1 or 2 cells wide); its exact patch is the cell nearest
/// the cut window's centre, i.e. cell `start + (width − 1) / 2` on each axis (the first
/// of two, the only one of one). Where that cell has no patch (a clipped polygon), the
/// window's existing patch nearest to it is cast instead (the lowest id on ties).
pub fn windows(scene: &Scene) -> Vec<Window> {
    let mut out = Vec::new();
    let patches = scene.patches();
    for (idx, poly) in scene.polygons().iter().enumerate() {
        let (nu, nv) = poly.grid();
        let first = poly.first_patch() as usize;
        let end = patches[first..]
            .iter()
            .position(|p| p.polygon as usize != idx)
            .map_or(patches.len(), |k| first + k);
        // Cell → patch of this polygon.
        let mut cell = vec![PatchId::MAX; (nu * nv) as usize];
        for (k, p) in patches[first..end].iter().enumerate() {
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
    out
}
