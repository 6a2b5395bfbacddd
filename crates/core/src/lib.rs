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

/// Whether this CPU has AVX2, for kernels compiled twice (baseline and
/// `#[target_feature(enable = "avx2")]`) and chosen at run time. Both builds perform
/// the same IEEE operations in the same order, so they give the same bits.
pub fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
