//! View factors over a motion ([`rad_geometry::Motion`]): each step's scene made from
//! the one as written, its hemisphere rows from the step before's item buffers
//! ([`rad_hemisphere::moved_area_rows`]: only what may change is cast again), its
//! closed-form pairs anew; each step's factors the very ones [`super::view_factors`]
//! gives that step's scene in the motion's unit ([`Motion::unit`]), to the bit (tested).

use super::{exact_pairs, row_patches, view_factors_with, ViewFactorConfig, ViewFactors};
use crate::rows::check_rows;
use crate::{rows_with_caster, CasterJob, Error};
use rad_geometry::{Motion, Scene, SceneDesc};
use rad_hemisphere::{
    moved_area_rows_from, moved_polygons, Caster, Hemisphere, KeptBuffers, RecastStats, Row,
};

/// The most bytes of item buffers (run-length coded) and rows kept from one step for
/// the next: past them, patches are cast whole at the next step (the same factors).
pub const MOTION_KEEP_BYTES: usize = 1536 << 20;

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
    motion.check(desc)?;
    let mut kept = KeptBuffers::with_budget(MOTION_KEEP_BYTES);
    let mut before: Option<Scene> = None;
    let unit = motion.unit(desc);
    for k in 0..motion.steps.len() {
        let scene = motion.step_scene(desc, cut, k, unit)?;
        let pairs = exact_pairs(&scene, opts)?;
        let wanted = pairs.as_ref().map(|p| p.obstructed.as_slice());
        let patches: Vec<u32> = row_patches(&scene)
            .into_iter()
            .filter(|&p| {
                let polygon = scene.patches()[p as usize].polygon as usize;
                wanted.is_none_or(|w| w[polygon])
            })
            .collect();
        let moved = match &before {
            Some(b) => Some(moved_polygons(b.for_rows()?, scene.for_rows()?)),
            None => None,
        };
        let n_moved = moved
            .as_ref()
            .map_or(scene.polygons().len(), |m| m.iter().filter(|&&x| x).count());
        let step_progress = |n: usize| progress(k, n);
        let (rows, recast) = if patches.is_empty() {
            kept = KeptBuffers::with_budget(MOTION_KEEP_BYTES);
            (Vec::new(), RecastStats::default())
        } else {
            let job = Step {
                // (The scan of a few polygons costs a few single rays' worth a cell; a
                // hierarchy or grid over a mesh, tens.)
                whole_from: if opts.caster == crate::CasterKind::Scan {
                    0.05
                } else {
                    0.25
                },
                hemi,
                origins: opts.origins,
                patches: &patches,
                moved: moved.as_deref(),
                kept: &mut kept,
                progress: &step_progress,
            };
            rows_with_caster(&scene, opts.caster, job)?
        };
        let mut rows = Some(rows);
        let vf = view_factors_with(&scene, opts, pairs.as_ref(), &mut |sink| {
            rows.take().into_iter().flatten().try_for_each(|r| sink(&r))
        })?;
        each(StepViewFactors {
            step: k,
            name: motion.steps[k].name.clone(),
            vf,
            recast,
            moved_polygons: n_moved,
            scene_hash: format!("fnv1a64:{:016x}", crate::scene_file::fingerprint(&scene)),
        })?;
        before = Some(scene);
    }
    Ok(())
}

/// One step's rows: the job's caster for patches cast whole, the wide BVH for cells
/// cast ray by ray.
struct Step<'a> {
    whole_from: f64,
    hemi: &'a Hemisphere,
    origins: u32,
    patches: &'a [u32],
    moved: Option<&'a [bool]>,
    kept: &'a mut KeptBuffers,
    progress: &'a (dyn Fn(usize) + Sync),
}

impl CasterJob for Step<'_> {
    type Out = (Vec<Row>, RecastStats);
    fn run<C: Caster>(self, scene: &Scene, caster: &C) -> Result<Self::Out, Error> {
        let rays = rad_accel::WideBvh::new(scene);
        let made = moved_area_rows_from(
            (scene, caster, &rays, self.hemi),
            self.patches,
            self.origins,
            self.moved,
            self.kept,
            self.whole_from,
            self.progress,
        )?;
        check_rows(&made.0)?;
        Ok(made)
    }
}
