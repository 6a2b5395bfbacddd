//! Reciprocity A_i F_ij = A_j F_ji over the pairs of a set of rows.

use crate::stats::Summary;
use rad_geometry::Scene;
use rad_hemisphere::Row;
use serde::Serialize;
use std::collections::HashMap;

/// The distribution of `|A_i F_ij − A_j F_ji| / (A_i F_ij)` over ordered pairs (i, j)
/// whose rows are both given and with `F_ij > 0`, and the share of pairs within the
/// discretisation bound (see [`discretisation_bound`]).
#[derive(Clone, Debug, Serialize)]
pub struct Reciprocity {
    pub rows: usize,
    pub rel_error: Summary,
    /// Pairs seen by at least `min_cells` cells both ways, and their distribution.
    pub min_cells: f64,
    pub rel_error_resolved: Summary,
    /// Share of resolved pairs within the bound.
    pub within_bound: f64,
}

/// Relative discrepancy of one pair beside the number of cells that see each side.
#[derive(Clone, Copy, Debug)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    pub rel: f64,
    /// Cells (in units of the mean cell's ΔF) behind F_ij and F_ji.
    pub cells: (f64, f64),
}

/// The pairs of `rows`; `n_cells` is the hemisphere's number of cells.
pub fn pairs(scene: &Scene, rows: &[Row], n_cells: usize) -> Vec<Pair> {
    let index: HashMap<u32, usize> = rows.iter().enumerate().map(|(k, r)| (r.patch, k)).collect();
    let mut out = Vec::new();
    for r in rows {
        let a_i = scene.patches()[r.patch as usize].area;
        for &(j, f_ij) in &r.entries {
            let Some(&k) = index.get(&j) else { continue };
            let f_ji = rows[k].get(r.patch);
            let a_j = scene.patches()[j as usize].area;
            let rel = (a_i * f_ij - a_j * f_ji).abs() / (a_i * f_ij);
            out.push(Pair {
                i: r.patch,
                j,
                rel,
                cells: (f_ij * n_cells as f64, f_ji * n_cells as f64),
            });
        }
    }
    out
}

/// Worst-case sampling error of a form factor made of `cells` cells: a patch seen
/// through about N cells has a boundary about 4√N cells long, each misjudged by at most
/// half its ΔF, so the relative error is at most 2/√N; a pair's reciprocity error adds
/// both directions' errors, plus `point_vs_area`, the gap between the point-to-patch
/// values themselves (the report takes the point value for the patch's).
pub fn discretisation_bound(cells: (f64, f64), point_vs_area: f64) -> f64 {
    2.0 / cells.0.sqrt() + 2.0 / cells.1.sqrt() + point_vs_area
}

/// Summary of `pairs`, with `point_vs_area(i, j)` the pair's point-value asymmetry.
pub fn summarise(
    pairs: &[Pair],
    rows: usize,
    min_cells: f64,
    point_vs_area: impl Fn(u32, u32) -> f64,
) -> Reciprocity {
    let all: Vec<f64> = pairs.iter().map(|p| p.rel).collect();
    let resolved: Vec<&Pair> = pairs
        .iter()
        .filter(|p| p.cells.0.min(p.cells.1) >= min_cells)
        .collect();
    let within = resolved
        .iter()
        .filter(|p| p.rel <= discretisation_bound(p.cells, point_vs_area(p.i, p.j)))
        .count();
    Reciprocity {
        rows,
        rel_error: Summary::of(&all),
        min_cells,
        rel_error_resolved: Summary::of(&resolved.iter().map(|p| p.rel).collect::<Vec<_>>()),
        within_bound: if resolved.is_empty() {
            1.0
        } else {
            within as f64 / resolved.len() as f64
        },
    }
}

/// `|F_ij − F_ji| / F_ij` of the unoccluded point-to-patch values (Lambert both ways,
/// areas equal or not: `A_i F_ij` against `A_j F_ji`): the part of a pair's reciprocity
/// error that the point approximation itself carries, exact where the pair sees each
/// other whole (as in the cube), an estimate of that part where occluders intervene.
pub fn point_asymmetry(scene: &Scene, i: u32, j: u32) -> f64 {
    let (pi, pj) = (&scene.patches()[i as usize], &scene.patches()[j as usize]);
    let f = |p: &rad_geometry::Patch, q: &rad_geometry::Patch| {
        let corners: Vec<glam::DVec3> = q.corners.iter().map(|c| c.as_dvec3()).collect();
        rad_hemisphere::point_to_polygon_form_factor(
            p.center.as_dvec3(),
            p.normal.as_dvec3(),
            &corners,
        )
    };
    let (aij, aji) = (pi.area * f(pi, pj), pj.area * f(pj, pi));
    if aij > 0.0 {
        (aij - aji).abs() / aij
    } else {
        0.0
    }
}
