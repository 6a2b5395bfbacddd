//! Rows of a scene by a [`RowMethod`]: the one place that turns a method's name into
//! casters and the estimator.

use crate::{default_estimator, default_grid, CasterKind, Error, RowMethod};
use rad_accel::VoxelGrid;
use rad_core::PatchId;
use rad_estimator::{estimate_rows, EstimateStats, Source};
use rad_geometry::Scene;
use rad_hemisphere::{compute_rows, Caster, Hemisphere, Hierarchy, Row, Scan};

/// Rows made by one method.
#[derive(Clone, Debug)]
pub struct Rows {
    pub method: RowMethod,
    /// In the order of the patches asked for.
    pub rows: Vec<Row>,
    /// Per row: the patch it was estimated from, or `None` for a row cast exactly (a
    /// window's centre, or a patch improved mode cast after abandoning its estimate).
    pub sources: Vec<Option<PatchId>>,
    /// Counts of an estimated run (all exact for an exact one).
    pub stats: EstimateStats,
}

/// The rows of `patches` by `method`, in parallel (rayon's current pool), the same
/// whatever the thread count; `progress(n)` is called with the number of rows done so
/// far (after each row, or each window of estimated rows).
pub fn rows(
    scene: &Scene,
    hemi: &Hemisphere,
    method: RowMethod,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rows, Error> {
    let made = match method.caster() {
        CasterKind::Scan => rows_with(scene, &Scan, hemi, method, patches, progress),
        CasterKind::Grid => {
            let grid = VoxelGrid::build(scene, &default_grid())?;
            rows_with(scene, &grid, hemi, method, patches, progress)
        }
        CasterKind::Hierarchy => {
            let tree = Hierarchy::new(scene);
            rows_with(scene, &tree, hemi, method, patches, progress)
        }
    }?;
    // (Form factors are sums of finite delta form factors: a non-finite one is a bug.)
    for r in &made.rows {
        let values = r.entries.iter().map(|e| e.1).chain([r.back, r.escaped]);
        if let Some(v) = values.into_iter().find(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("a form factor of patch {}", r.patch),
                value: v,
                place: "its row",
            });
        }
    }
    Ok(made)
}

fn rows_with<C: Caster>(
    scene: &Scene,
    caster: &C,
    hemi: &Hemisphere,
    method: RowMethod,
    patches: &[PatchId],
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rows, Error> {
    match method.mode() {
        None => {
            let rows = compute_rows(scene, caster, hemi, patches, progress)?;
            let n = rows.len();
            Ok(Rows {
                method,
                rows,
                sources: vec![None; n],
                stats: EstimateStats {
                    exact: n,
                    ..EstimateStats::default()
                },
            })
        }
        Some(mode) => {
            let config = default_estimator(mode);
            let (rows, stats) = estimate_rows(scene, caster, hemi, &config, patches, progress)?;
            let sources = rows
                .iter()
                .map(|r| match r.source {
                    Source::Exact | Source::ExactFallback { .. } => None,
                    Source::Estimated { from } => Some(from),
                })
                .collect();
            Ok(Rows {
                method,
                rows: rows.into_iter().map(|r| r.row).collect(),
                sources,
                stats,
            })
        }
    }
}
