//! What a hemisphere sees, and from where: the item buffer (a patch id and a distance a
//! cell) and the viewpoint it is made at.

use rad_core::{PatchId, PolygonId, Vec3};
use rad_geometry::Scene;

/// Where a hemisphere stands: a point on a polygon (a patch's centre, or any point of
/// its patch when rows are averaged over several origins); the hemisphere takes the
/// polygon's frame, and its rays skip the polygon.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewpoint {
    pub point: Vec3,
    pub polygon: PolygonId,
}

impl Viewpoint {
    /// The centre of `patch`, on its polygon.
    pub fn of_patch(scene: &Scene, patch: PatchId) -> Viewpoint {
        let p = &scene.patches()[patch as usize];
        Viewpoint {
            point: p.center,
            polygon: p.polygon,
        }
    }
}

/// What each cell of one hemisphere sees: a patch id (or [`rad_core::ESCAPED`],
/// [`rad_core::BACK`]) and the distance R to it (infinite for escaped rays).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ItemBuffer {
    pub patch: Vec<PatchId>,
    pub dist: Vec<f32>,
}
