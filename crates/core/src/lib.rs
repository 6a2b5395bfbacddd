//! Vocabulary shared by every coherad crate: rays, hits, frames, colours, ids and the
//! [`RayCast`] trait through which form-factor code sees an accelerator.
//!
//! - `frame`: [`Frame`], a patch's orthonormal local frame `(t, b, n)`.
//! - `hint`: [`prefetch`], a hint to the CPU.
//! - `ids`: [`PatchId`], [`PolygonId`] and the sentinels that are not patches or polygons.
//! - `ray`: [`Ray`], [`Hit`], the [`RayCast`] trait and [`BoxTree`], a nearest-first tree of boxes.
//! - `rgb`: [`Rgb`] triples for reflectance, emission and radiosity.
//!
//! The crate root holds [`Isa`], the instruction set kernels run with, and [`with_isa!`].

mod frame;
mod hint;
mod ids;
mod ray;
mod rgb;

pub use frame::Frame;
pub use hint::prefetch;
pub use ids::{PatchId, PolygonId, BACK, ESCAPED, HOLE, NO_POLYGON};
pub use ray::{BoxTree, Hit, Ray, RayCast};
pub use rgb::Rgb;

pub use glam::Vec3;

/// Calls a kernel compiled for the instruction set `$isa` (an [`Isa`], checked against
/// the CPU: see [`Isa::checked`]): `with_isa!(isa, |ISA| fn(a: A = value, ...) -> R {
/// body })` defines a function of those arguments with that set's target features and
/// `ISA` bound to the set as a constant (so the body may pick const-generic variants
/// by it; the dead ones are removed), and calls it with the values. Every
/// `#[inline(always)]` function the body calls is compiled for the set too: one body,
/// three builds, no hand-written `#[target_feature]` wrapper. The builds perform the
/// same IEEE operations in the same order (no FMA contraction), so they give the same
/// bits unless the body itself chooses otherwise by `ISA`.
///
/// The inputs are real arguments, as they were to the hand-written wrappers: LLVM sees
/// slices as `noalias` parameters and vectorises as before. Each value is a plain
/// variable (the macro takes identifiers only), so that no unsafe operation can hide in
/// an argument of the unsafe call. (A first form that ran a
/// closure under the target features instead made faithful estimates 4.5 times slower
/// and the scan's span test 15 %: measured, and removed.)
///
/// ```
/// use rad_core::{with_isa, Isa};
/// #[inline(always)]
/// fn double(x: &mut [f32]) {
///     x.iter_mut().for_each(|v| *v *= 2.0);
/// }
/// let mut xs = [1.0f32; 64];
/// let x = &mut xs[..];
/// with_isa!(Isa::detect(), |ISA| fn(x: &mut [f32] = x) {
///     double(x)
/// });
/// assert_eq!(xs[63], 2.0);
/// ```
#[macro_export]
macro_rules! with_isa {
    ($isa:expr, |$name:ident| fn($($arg:ident: $ty:ty = $val:ident),* $(,)?) $(-> $ret:ty)? $body:block) => {{
        match $crate::Isa::checked($isa) {
            #[cfg(target_arch = "x86_64")]
            $crate::Isa::Avx512 => {
                #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma")]
                #[allow(clippy::too_many_arguments)]
                fn compiled_for_avx512($($arg: $ty),*) $(-> $ret)? {
                    #[allow(non_upper_case_globals, dead_code)]
                    const $name: $crate::Isa = $crate::Isa::Avx512;
                    $body
                }
                // SAFETY: the CPU runs AVX-512 (checked above).
                unsafe { compiled_for_avx512($($val),*) }
            }
            #[cfg(target_arch = "x86_64")]
            $crate::Isa::Avx2 => {
                #[target_feature(enable = "avx2,fma")]
                #[allow(clippy::too_many_arguments)]
                fn compiled_for_avx2($($arg: $ty),*) $(-> $ret)? {
                    #[allow(non_upper_case_globals, dead_code)]
                    const $name: $crate::Isa = $crate::Isa::Avx2;
                    $body
                }
                // SAFETY: the CPU runs AVX2 and FMA (checked above).
                unsafe { compiled_for_avx2($($val),*) }
            }
            _ => {
                #[allow(clippy::too_many_arguments)]
                fn baseline($($arg: $ty),*) $(-> $ret)? {
                    #[allow(non_upper_case_globals, dead_code)]
                    const $name: $crate::Isa = $crate::Isa::Base;
                    $body
                }
                baseline($($val),*)
            }
        }
    }};
}

/// The vector instruction sets kernels are compiled for (baseline, and under
/// `#[target_feature]` through [`with_isa!`]), one chosen at run time. Every build performs the same IEEE
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

    /// The widest set this CPU offers (detected once).
    pub fn supported() -> Isa {
        static SUPPORTED: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *SUPPORTED.get_or_init(Isa::probe)
    }

    /// `self`, after checking that this CPU runs it.
    ///
    /// # Panics
    /// If it does not (a kernel compiled for it would be undefined behaviour there).
    #[inline]
    pub fn checked(self) -> Isa {
        assert!(
            self <= Isa::supported(),
            "{self:?} is not available on this CPU"
        );
        self
    }

    fn probe() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let fma = has!("fma");
            let avx512 =
                has!("avx512f") && has!("avx512vl") && has!("avx512dq") && has!("avx512bw");
            // (The AVX-512 builds use AVX2 and FMA too: `Isa` is ordered.)
            if fma && has!("avx2") && avx512 {
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
