//! Rows over a motion ([`rad_geometry::Motion`]), shared by view factors and solves:
//! each step's scene made from the one as written (in the motion's unit), its rows
//! from the step before's item buffers ([`rad_hemisphere::moved_area_rows_from`]: only
//! what may change is cast again), the same rows, to the bit, as a whole computation of
//! that step's scene.

use crate::rows::check_rows;
use crate::{rows_with_caster, CasterJob, CasterKind, Error, SceneFile};
use rad_geometry::{Motion, Scene, SceneDesc};
use rad_hemisphere::{
    moved_area_rows_from, moved_polygons, Caster, Hemisphere, KeptBuffers, RecastStats, Row,
};

/// The most bytes of item buffers (run-length coded) and rows kept from one step for
/// the next: past them, patches are cast whole at the next step (the same factors).
pub const MOTION_KEEP_BYTES: usize = 1536 << 20;

/// Step `k` of `motion` over `scene` (loaded from `desc`), in the motion's `unit`
/// ([`Motion::unit`]), as a scene file named for the step: "PATH at step K (NAME)".
/// Its fingerprint is the one a solution of the step records.
pub fn step_scene_file(
    (scene, desc): (&SceneFile, &SceneDesc),
    motion: &Motion,
    unit: f64,
    k: usize,
) -> Result<SceneFile, Error> {
    let step = motion.step_scene(desc, &scene.scene, k, unit)?;
    let name = &motion.steps[k].name;
    Ok(SceneFile::of_scene(
        format!("{} at step {k} ({name})", scene.path.display()),
        step,
    ))
}

/// What carries from one step of a motion to the next: the item buffers and the scene.
pub(crate) struct MotionRows<'a> {
    desc: &'a SceneDesc,
    cut: &'a Scene,
    motion: &'a Motion,
    unit: f64,
    kept: KeptBuffers,
    before: Option<Scene>,
}

/// One step's rows and what they cost.
pub(crate) struct StepRows {
    pub rows: Vec<Row>,
    pub recast: RecastStats,
    /// Polygons that moved since the step before (all, at the first step).
    pub moved_polygons: usize,
}

impl<'a> MotionRows<'a> {
    /// Over `motion` of `desc`, whose scene as written is `cut` (each step's polygons
    /// are cut as its); the motion checked against the scene.
    pub fn new(desc: &'a SceneDesc, cut: &'a Scene, motion: &'a Motion) -> Result<Self, Error> {
        motion.check(desc)?;
        Ok(MotionRows {
            desc,
            cut,
            motion,
            unit: motion.unit(desc),
            kept: KeptBuffers::with_budget(MOTION_KEEP_BYTES),
            before: None,
        })
    }

    /// Step `k`'s scene, in the motion's unit.
    pub fn scene(&self, k: usize) -> Result<Scene, Error> {
        Ok(self.motion.step_scene(self.desc, self.cut, k, self.unit)?)
    }

    /// The rows of `patches` of `scene` (the next step's, from [`Self::scene`]) from
    /// `origins`² hemispheres a patch, cast with `caster` where a patch is cast whole.
    /// Hand the scene to [`Self::passed`] before the next step.
    pub fn rows(
        &mut self,
        scene: &Scene,
        caster: CasterKind,
        hemi: &Hemisphere,
        origins: u32,
        patches: &[u32],
        progress: &(dyn Fn(usize) + Sync),
    ) -> Result<StepRows, Error> {
        let moved = match &self.before {
            Some(b) => Some(moved_polygons(b.for_rows()?, scene.for_rows()?)),
            None => None,
        };
        let moved_polygons = moved
            .as_ref()
            .map_or(scene.polygons().len(), |m| m.iter().filter(|&&x| x).count());
        let (rows, recast) = if patches.is_empty() {
            self.kept = KeptBuffers::with_budget(MOTION_KEEP_BYTES);
            (Vec::new(), RecastStats::default())
        } else {
            let job = Step {
                // (The scan of a few polygons costs a few single rays' worth a cell; a
                // hierarchy or grid over a mesh, tens.)
                whole_from: if caster == CasterKind::Scan {
                    0.05
                } else {
                    0.25
                },
                hemi,
                origins,
                patches,
                moved: moved.as_deref(),
                kept: &mut self.kept,
                progress,
            };
            rows_with_caster(scene, caster, job)?
        };
        Ok(StepRows {
            rows,
            recast,
            moved_polygons,
        })
    }

    /// `scene`, whose rows were made last, becomes the step before.
    pub fn passed(&mut self, scene: Scene) {
        self.before = Some(scene);
    }
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
