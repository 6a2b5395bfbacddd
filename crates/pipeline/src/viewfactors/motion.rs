//! View factors over a motion ([`rad_geometry::Motion`]): each step's scene made from
//! the one as written, its hemisphere rows from the step before's item buffers
//! ([`rad_hemisphere::moved_area_rows`]: only what may change is cast again), its
//! closed-form pairs anew; each step's factors the very ones [`super::view_factors`]
//! gives that step's scene in the motion's unit ([`Motion::unit`]), to the bit (tested).

use super::{exact_pairs, row_patches, view_factors_with, ViewFactorConfig, ViewFactors};
use crate::moving::{MotionRows, StepRows};
use crate::Error;
use rad_geometry::{Motion, Scene, SceneDesc};
use rad_hemisphere::{Hemisphere, RecastStats};

/// One step's view factors, and what its rows cost.
#[derive(Clone, Debug)]
pub struct StepViewFactors {
    pub step: usize,
    pub name: String,
    pub vf: ViewFactors,
    pub recast: RecastStats,
    /// Polygons of the step that moved since the step before (all, for the first).
    pub moved_polygons: usize,
    /// The step's scene's fingerprint, as solution files store it.
    pub scene_hash: String,
}

/// The view factors of every step of `motion` over `desc` (whose scene as written is
/// `cut`: each step's polygons are cut as its), in order, each handed to `each` as it
/// is made (so that a caller may write it before the next is begun).
/// `progress(step, patches)` follows the rows of each step.
pub fn view_factors_over_motion(
    desc: &SceneDesc,
    cut: &Scene,
    motion: &Motion,
    hemi: &Hemisphere,
    opts: &ViewFactorConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
    each: &mut dyn FnMut(StepViewFactors) -> Result<(), Error>,
) -> Result<(), Error> {
    let mut steps = MotionRows::new(desc, cut, motion)?;
    for k in 0..motion.steps.len() {
        let scene = steps.scene(k)?;
        let pairs = exact_pairs(&scene, opts)?;
        let wanted = pairs.as_ref().map(|p| p.obstructed.as_slice());
        let patches: Vec<u32> = row_patches(&scene)
            .into_iter()
            .filter(|&p| {
                let polygon = scene.patches()[p as usize].polygon as usize;
                wanted.is_none_or(|w| w[polygon])
            })
            .collect();
        let step_progress = |n: usize| progress(k, n);
        let StepRows {
            rows,
            recast,
            moved_polygons,
        } = steps.rows(
            &scene,
            opts.caster,
            hemi,
            opts.origins,
            &patches,
            &step_progress,
        )?;
        let mut rows = Some(rows);
        let vf = view_factors_with(&scene, opts, pairs.as_ref(), &mut |sink| {
            rows.take().into_iter().flatten().try_for_each(|r| sink(&r))
        })?;
        each(StepViewFactors {
            step: k,
            name: motion.steps[k].name.clone(),
            vf,
            recast,
            moved_polygons,
            scene_hash: format!("fnv1a64:{:016x}", crate::scene_file::fingerprint(&scene)),
        })?;
        steps.passed(scene);
    }
    Ok(())
}
