//! Elementwise loops compiled three times (AVX-512, AVX2+FMA, baseline) and picked at run time
//! by [`dynaslice_core::cpu::Level`], the decision the core's batch kernels take too.
//!
//! The sine activations and their backward are a fifth of a training step when compiled for the
//! x86-64 baseline (SSE2, 4 lanes); the same plain Rust compiled with AVX-512 enabled runs 16
//! lanes. `target-cpu=native` would do this for the whole crate but ties the binary to the
//! build machine, so only these loops are multiversioned.

/// Defines `fn $name(args)` that runs `$body` with the widest instruction set the CPU has.
///
/// Written `fn $name<M: MulAdd>(args)`, the body may name `M`, the multiply-add of
/// `dynaslice_core::sine`: `Fused` in the AVX variants (one FMA instruction), `Separate` in the
/// baseline one (where `f32::mul_add` would be a software routine).
macro_rules! multiversion {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $body:block) => {
        $crate::simd::multiversion! {
            $(#[$meta])* $vis fn $name<M: MulAdd>($($arg: $ty),*) $body
        }
    };
    ($(#[$meta:meta])* $vis:vis fn $name:ident<$m:ident: MulAdd>($($arg:ident: $ty:ty),* $(,)?)
     $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) {
            #[cfg_attr(not(target_arch = "x86_64"), allow(unused_imports))]
            use dynaslice_core::sine::{Fused, MulAdd, Separate};
            #[inline(always)]
            #[allow(clippy::extra_unused_type_parameters)] // the bodies that need no sine
            fn generic<$m: MulAdd>($($arg: $ty),*) $body
            #[cfg(target_arch = "x86_64")]
            {
                use dynaslice_core::cpu::Level;
                #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
                fn avx512($($arg: $ty),*) {
                    generic::<Fused>($($arg),*)
                }
                #[target_feature(enable = "avx2,fma")]
                fn avx2($($arg: $ty),*) {
                    generic::<Fused>($($arg),*)
                }
                match Level::detect() {
                    // SAFETY: the token proves the CPU has every feature `avx512` enables.
                    Level::Avx512(_) => return unsafe { avx512($($arg),*) },
                    // SAFETY: the token proves the CPU has every feature `avx2` enables.
                    Level::Avx2(_) => return unsafe { avx2($($arg),*) },
                    Level::Portable => {}
                }
            }
            generic::<Separate>($($arg),*)
        }
    };
}

pub(crate) use multiversion;
