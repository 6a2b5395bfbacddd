//! The brute-force reference: every ray against every polygon.

use rad_core::{Hit, Ray, RayCast};
use rad_geometry::Scene;

/// Tests every polygon for every ray. The reference the voxel grid is checked against.
pub struct BruteForce<'s> {
    scene: &'s Scene,
}

impl<'s> BruteForce<'s> {
    pub fn new(scene: &'s Scene) -> Self {
        BruteForce { scene }
    }
}

impl RayCast for BruteForce<'_> {
    /// Brute force keeps no state between rays.
    type Scratch = ();

    fn new_scratch(&self) {}

    fn closest_hit(&self, ray: &Ray, _: &mut ()) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (idx, poly) in self.scene.polygons().iter().enumerate() {
            if idx as u32 == ray.skip {
                continue;
            }
            if let Some((t, u, v, front)) = poly.intersect(ray.origin, ray.dir, t_max) {
                t_max = t;
                best = Some(Hit {
                    polygon: idx as u32,
                    u,
                    v,
                    t,
                    front,
                });
            }
        }
        best
    }

    fn all_hits(&self, ray: &Ray, _: &mut (), out: &mut Vec<Hit>) {
        self.scene.all_hits(ray, out)
    }
}
