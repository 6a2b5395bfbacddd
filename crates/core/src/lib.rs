//! Vocabulary shared by every coherad crate: rays, hits, frames, colours, ids and the
//! [`RayCast`] trait through which form-factor code sees an accelerator.

mod frame;
mod ray;
mod rgb;

pub use frame::Frame;
pub use ray::{Hit, Ray, RayCast, NO_POLYGON};
pub use rgb::Rgb;

pub use glam::Vec3;

/// Index of a polygon in its scene.
pub type PolygonId = u32;
/// Index of a patch (one texel of a polygon's patch texture) in its scene.
pub type PatchId = u32;
