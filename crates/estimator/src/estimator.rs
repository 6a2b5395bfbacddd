//! The estimator and its motion: the per-cell tables of one resolution, shared by both
//! modes, and the motion from a source patch's centre to a target's.

use crate::cell_trig::CellTrig;
use crate::reproject::Motion;
use rad_core::PatchId;
use rad_geometry::Scene;
use rad_hemisphere::Hemisphere;
use std::cell::RefCell;
use std::thread::LocalKey;

/// The motion from `from`'s centre to `to`'s, in their polygon's frame.
pub(crate) fn motion(scene: &Scene, from: PatchId, to: PatchId) -> Motion {
    let (a, b) = (
        &scene.patches()[from as usize],
        &scene.patches()[to as usize],
    );
    let frame = scene.polygons()[a.polygon as usize].frame();
    let d = frame.local_from_world(b.center - a.center);
    Motion::new([d.x as f64, d.y as f64, d.z as f64])
}

/// Estimates hemispheres of one resolution: holds the per-cell tables.
#[derive(Clone, Debug)]
pub struct Estimator<'h> {
    pub(crate) hemi: &'h Hemisphere,
    pub(crate) trig: CellTrig,
    /// The tables of strides 2 ..= `MAX_GUESS_STRIDE`, made on first use.
    strided: [std::sync::OnceLock<CellTrig>; crate::config::MAX_GUESS_STRIDE as usize - 1],
}

impl<'h> Estimator<'h> {
    pub fn new(hemi: &'h Hemisphere) -> Estimator<'h> {
        Estimator {
            hemi,
            trig: CellTrig::new(hemi),
            strided: Default::default(),
        }
    }

    /// The tables of the grid s times coarser, s the largest stride up to `stride`
    /// (and `MAX_GUESS_STRIDE`) that divides the resolution both ways.
    pub(crate) fn trig_strided(&self, stride: usize) -> &CellTrig {
        let h = self.hemi;
        let max = stride.min(self.strided.len() + 1);
        match (2..=max)
            .rev()
            .find(|&s| h.n_theta().is_multiple_of(s) && h.n_phi().is_multiple_of(s))
        {
            Some(s) => self.strided[s - 2].get_or_init(|| CellTrig::strided(h, s)),
            None => &self.trig,
        }
    }

    pub fn hemisphere(&self) -> &'h Hemisphere {
        self.hemi
    }
}

/// Runs `f` with this thread's buffer in `key`, or with a fresh one if it is in use (a
/// caster that ran another estimate on this thread from inside its own call).
pub(crate) fn with_thread_buffer<T: Default, R>(
    key: &'static LocalKey<RefCell<T>>,
    f: impl FnOnce(&mut T) -> R,
) -> R {
    key.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buffer) => f(&mut buffer),
        Err(_) => f(&mut T::default()),
    })
}
