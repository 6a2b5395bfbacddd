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

/// The vector instruction sets kernels are compiled for (baseline, and under
/// `#[target_feature]`), one chosen at run time. Every build performs the same IEEE
/// operations in the same order (no contraction into FMA), so all give the same bits;
/// a kernel that fuses where the CPU can must show that its answers do not change.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// What the target guarantees (SSE2 on x86_64).
    Base,
    /// AVX2 and FMA: 8 lanes of f32.
    Avx2,
    /// AVX-512 (F, VL, DQ, BW) and FMA: 16 lanes, 32 vector registers, mask registers.
    Avx512,
}

impl Isa {
    /// The set the kernels use (decided once): the widest this CPU offers, capped by
    /// the environment variable `COHERAD_ISA` (`base`, `avx2` or `avx512`; any other
    /// value, or none, caps nothing), for timing one build against another. The results
    /// are the same bits either way.
    pub fn detect() -> Isa {
        static ISA: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *ISA.get_or_init(|| {
            let cap = match std::env::var("COHERAD_ISA").as_deref() {
                Ok("base") => Isa::Base,
                Ok("avx2") => Isa::Avx2,
                _ => Isa::Avx512,
            };
            Isa::supported().min(cap)
        })
    }

    /// The widest set this CPU offers.
    pub fn supported() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let fma = has!("fma");
            if fma && has!("avx512f") && has!("avx512vl") && has!("avx512dq") && has!("avx512bw") {
                return Isa::Avx512;
            }
            if fma && has!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Base
    }

    /// Every set this CPU runs, narrowest first (for tests that compare the builds).
    pub fn available() -> Vec<Isa> {
        [Isa::Base, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|&i| i <= Isa::supported())
            .collect()
    }
}
