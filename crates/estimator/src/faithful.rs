//! Faithful mode, the report's estimation: every point of H1 splatted into H2
//! (z-buffered, module `splat`), then the holes filled (module `holes`).

use crate::config::EstimatorConfig;
use crate::estimator::{motion, with_thread_buffer, Estimator};
use crate::holes::fill_holes_with;
use crate::source::SourceHemisphere;
use crate::splat::{splat, Points, Splat, Turned};
use crate::zbuffer::ZBuffer;
use rad_core::{Isa, PatchId};
use rad_geometry::Scene;
use rad_hemisphere::{ItemBuffer, Viewpoint};

/// An estimated hemisphere: what each cell of H2 sees, with the holes that were filled.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    pub items: ItemBuffer,
    /// Cells nothing landed in (before filling), and their share of the form factor.
    pub holes: usize,
    pub hole_ff: f64,
}

thread_local! {
    /// Faithful mode's z-buffer, kept between estimates.
    static Z: std::cell::RefCell<ZBuffer> = std::cell::RefCell::new(ZBuffer::default());
}

impl Estimator<'_> {
    /// Estimates H2 at patch `to` from `src`, the report's way (no rays), into `out`
    /// (reusing its buffers). `to` is on `src`'s polygon, or on one whose normal points
    /// the same way ([`crate::frame_turn`]).
    pub fn faithful(
        &self,
        scene: &Scene,
        src: &SourceHemisphere,
        to: PatchId,
        config: &EstimatorConfig,
        out: &mut Estimate,
    ) {
        self.faithful_at(scene, src, Viewpoint::of_patch(scene, to), config, out)
    }

    /// [`Estimator::faithful`] at any point of a polygon (in its frame).
    pub fn faithful_at(
        &self,
        scene: &Scene,
        src: &SourceHemisphere,
        to: Viewpoint,
        config: &EstimatorConfig,
        out: &mut Estimate,
    ) {
        let (m, alpha) = motion(scene, src.viewpoint(scene), to);
        let turned = (alpha != 0.0).then(|| Turned::new(&self.trig, alpha));
        let points = Points {
            dist: &src.items().dist,
            values: &src.items().patch,
            cells: &[],
            extras: &[],
            ring_max: src.ring_max(self.hemi),
        };
        let items = &mut out.items;
        let splat_into = |z: &mut ZBuffer| {
            let (ids, dist) = (&mut items.patch, Some(&mut items.dist));
            let t = &self.trig;
            let job = Splat {
                trig: t,
                src,
                m: &m,
                turned: turned.as_ref(),
                config,
                rough: false,
                points,
            };
            splat(job, |id| id, ids, dist, z, &mut Vec::new());
        };
        with_thread_buffer(&Z, splat_into);
        // H1's cell in the direction of H2's cell c (the nearest whole sector turn).
        let n_phi = self.hemi.n_phi();
        let k = (alpha / self.hemi.d_phi()).round() as i64;
        let h1_cell = |c: usize| {
            let (i, l) = (c / n_phi, (c % n_phi) as i64);
            i * n_phi + (l - k).rem_euclid(n_phi as i64) as usize
        };
        let (holes, hole_ff) = fill_holes_with(
            Isa::detect(),
            self.hemi,
            &mut out.items.patch,
            config.fill,
            |c| src.items().patch[h1_cell(c)],
        );
        out.holes = holes;
        out.hole_ff = hole_ff;
    }
}
