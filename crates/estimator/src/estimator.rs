//! The estimator and its motion: the per-cell tables of one resolution, shared by both
//! modes, and the motion from a source patch's centre to a target's.

use crate::cell_trig::CellTrig;
use crate::reproject::Motion;
use rad_core::PolygonId;
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, Viewpoint};
use std::cell::RefCell;
use std::thread::LocalKey;

/// The motion from `from` to `to`, in `to`'s polygon's frame, and the turn α of that
/// frame from `from`'s (0 on one polygon; see [`frame_turn`]). Viewpoints on polygons
/// whose planes are not parallel get their frames' turn about `to`'s normal all the
/// same: callers estimate only where [`frame_turn`] allows.
pub(crate) fn motion(scene: &Scene, from: Viewpoint, to: Viewpoint) -> (Motion, f64) {
    let frame = scene.polygons()[to.polygon as usize].frame();
    let d = frame.local_from_world(to.point - from.point);
    let alpha = if from.polygon == to.polygon {
        0.0
    } else {
        turn_of(scene, from.polygon, to.polygon)
    };
    (Motion::new([d.x as f64, d.y as f64, d.z as f64]), alpha)
}

/// The largest angle between two polygons' normals (radians) for which a hemisphere on
/// one is estimated from the other's: their frames are then taken to differ by a turn
/// about the normal alone. At 180 × 720 a cell spans 8.7e-3 rad each way; a tilt of
/// 1e-3 rad moves a direction by at most an eighth of a cell, and the estimates resolve
/// each cell in the destination's own frame (improved mode) or land points a cell off
/// at worst near cell edges (faithful mode).
pub const MAX_TILT: f64 = 1e-3;

/// Whether a hemisphere on polygon `to` may be estimated from one on polygon `from`:
/// `Some(α)` when their normals point the same way to within [`MAX_TILT`], α the turn
/// about the normal that takes `from`'s frame to `to`'s (a direction at azimuth φ in
/// `from`'s frame is at φ + α in `to`'s; 0 for one polygon); `None` otherwise.
pub fn frame_turn(scene: &Scene, from: PolygonId, to: PolygonId) -> Option<f64> {
    if from == to {
        return Some(0.0);
    }
    let polygons = scene.polygons();
    let (f1, f2) = (
        polygons[from as usize].frame(),
        polygons[to as usize].frame(),
    );
    let (n1, n2) = (f1.n.as_dvec3(), f2.n.as_dvec3());
    let parallel = n1.dot(n2) > 0.0 && n1.cross(n2).length() <= MAX_TILT.sin();
    parallel.then(|| turn_of(scene, from, to))
}

/// The turn α about `to`'s normal from `from`'s frame to `to`'s: `from`'s first axis
/// is at azimuth α in `to`'s frame.
fn turn_of(scene: &Scene, from: PolygonId, to: PolygonId) -> f64 {
    let polygons = scene.polygons();
    let (t1, f2) = (
        polygons[from as usize].frame().t.as_dvec3(),
        polygons[to as usize].frame(),
    );
    t1.dot(f2.b.as_dvec3()).atan2(t1.dot(f2.t.as_dvec3()))
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
