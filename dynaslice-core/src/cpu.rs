//! The SIMD instruction set level of this CPU: the one run-time decision behind every
//! multiversioned kernel (the core's batch evaluation and the trainer's elementwise loops).
//!
//! Kernels are compiled for a few fixed levels with `#[target_feature]` and chosen when they run,
//! never with `target-cpu=native`, so one binary runs on any x86-64 CPU. Running code compiled
//! for a feature the CPU lacks is undefined behaviour, so each level above
//! [`Level::Portable`] carries a token ([`Avx2`], [`Avx512`]) that only this module makes, and
//! only after detecting every feature of its level. Code compiled for a level is sound to run
//! wherever its token is at hand:
//!
//! ```
//! use dynaslice_core::cpu::Level;
//!
//! fn sum(x: &[f32]) -> f32 {
//!     #[cfg(target_arch = "x86_64")]
//!     #[target_feature(enable = "avx2,fma,f16c")]
//!     fn sum_avx2(x: &[f32]) -> f32 {
//!         x.iter().sum()
//!     }
//!     match Level::detect() {
//!         // SAFETY: the Avx2 token proves avx2, fma and f16c, the features `sum_avx2` enables.
//!         #[cfg(target_arch = "x86_64")]
//!         Level::Avx2(_) => unsafe { sum_avx2(x) },
//!         _ => x.iter().sum(),
//!     }
//! }
//! assert_eq!(sum(&[1.0, 2.0, 3.0]), 6.0);
//! ```
//!
//! A level is the union of the features its kernels need (the core's batch kernels, the
//! trainer's elementwise loops); code compiled for a level may enable any of them, no others:
//! - [`Avx2`]: `avx2`, `fma`, `f16c`;
//! - [`Avx512`]: `avx512f`, `avx512vl`, `avx2`, `fma`, `f16c`.
//!
//! Without the `std` feature nothing is detected: [`Level::detect`] is always
//! [`Level::Portable`], whose kernels use whatever target features the build enables.

/// Proof that this CPU has AVX2, FMA and F16C (8-lane f32 vectors, fused multiply-adds, f16
/// conversions). Only [`Avx2::detect`] makes one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2 {
    // Private: safe code outside this module cannot make a token.
    _detected: (),
}

impl Avx2 {
    /// The token, if this CPU has AVX2, FMA and F16C (never off x86-64 or without `std`).
    pub fn detect() -> Option<Avx2> {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            if std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
                && std::is_x86_feature_detected!("f16c")
            {
                return Some(Avx2 { _detected: () });
            }
        }
        None
    }
}

/// Proof that this CPU has AVX-512 F and VL besides AVX2, FMA and F16C (16-lane f32 vectors).
/// Only [`Avx512::detect`] makes one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx512 {
    // Private: safe code outside this module cannot make a token. The level includes AVX2's.
    _avx2: Avx2,
}

impl Avx512 {
    /// The token, if this CPU has AVX-512 F and VL, AVX2, FMA and F16C (never off x86-64 or
    /// without `std`).
    pub fn detect() -> Option<Avx512> {
        let _avx2 = Avx2::detect()?;
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512vl") {
            return Some(Avx512 { _avx2 });
        }
        None
    }
}

/// An instruction set level the kernels are compiled for; above `Portable`, with the token that
/// proves this CPU has it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// The build target's baseline (SSE2 on x86-64; whatever a no_std build enables).
    Portable,
    /// AVX2, FMA and F16C.
    Avx2(Avx2),
    /// AVX-512 F and VL, AVX2, FMA and F16C.
    Avx512(Avx512),
}

impl Level {
    /// The widest level this CPU has; every kernel chooses by it, so the core and the trainer
    /// agree on what "this CPU" runs.
    pub fn detect() -> Level {
        Avx512::detect()
            .map(Level::Avx512)
            .or_else(|| Avx2::detect().map(Level::Avx2))
            .unwrap_or(Level::Portable)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detect_picks_the_widest_token() {
        let want = match (Avx512::detect(), Avx2::detect()) {
            (Some(cpu), _) => Level::Avx512(cpu),
            (None, Some(cpu)) => Level::Avx2(cpu),
            (None, None) => Level::Portable,
        };
        assert_eq!(Level::detect(), want);
        // Every AVX-512 CPU the level admits has the AVX2 level's features too.
        assert!(Avx512::detect().is_none() || Avx2::detect().is_some());
    }
}
