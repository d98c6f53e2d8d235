//! Branch-free single-precision sine and cosine that compilers vectorise.
//!
//! Every hidden unit of a SIREN costs one sine (and, with derivatives, one cosine): at width 256
//! that is 256 sines per layer per point, which with libm's scalar `sinf` would cost more than
//! the layer's matrix product. This implementation has no branches, table look-ups or calls, so a
//! loop over a slice compiles to SIMD code for whatever target features the caller enables.
//!
//! Method (Cody & Waite; coefficients fitted here by Remez exchange, see below):
//! 1. sin x: n = round(x/π) via the 1.5·2²³ magic-number trick, which also leaves the parity
//!    of n in the lowest bit of the sum; cos x: n = m + ½ with m = round(x/π − ½).
//! 2. r = x − n·π with π split into three parts whose leading part has 8 significant bits, so
//!    n·P1 is exact for |n| < 2¹⁵; r ∈ [−π/2, π/2].
//! 3. r is clamped to ±[`R_MAX`] (see below), a no-op wherever the reduction is exact.
//! 4. sin x = (−1)ⁿ·S(r) and cos x = cos(mπ + π/2 + r) = (−1)ᵐ⁺¹·S(r), with S the odd
//!    degree-9 minimax polynomial of sin on [−π/2, π/2] (absolute error 2.9·10⁻⁸ in exact
//!    arithmetic); the sign is one XOR.
//!
//! Reducing by π rather than π/2 needs no quadrant swap, so [`sin`] alone evaluates one
//! polynomial (the f-only path of evaluation, about half the work of [`sin_cos`]) and has the
//! same bits as `sin_cos(x).0`: f evaluated with or without derivatives is bit-identical, which
//! hosts rely on. Cosine reuses the sine polynomial on its own reduction rather than an even
//! polynomial on the sine's r: near r = ±π/2 such a polynomial sums terms of size 1 to a result
//! near 0 and lost 1.7·10⁻⁷ (measured), where S(r) keeps its relative accuracy.
//!
//! S's coefficients are the Remez minimax fit of sin r − r on the basis r³, r⁵, r⁷, r⁹ over
//! [0, π/2], computed in 40-digit arithmetic and rounded to f32.
//!
//! Every a·b + c is a [`MulAdd`]: two roundings in the portable kernels (single points, any
//! target: the same bits on x86-64 and a Cortex-M4F), one fused instruction in the SIMD
//! kernels, so each of the sine's eight a·b + c is one instruction instead of two.
//!
//! Accuracy (measured by `sine::tests::accuracy_against_libm`, against f64 `libm::sin`/`cos`
//! over 2·10⁶ points): max absolute error on |x| ≤ 100 (the range of SIREN pre-activations)
//! 1.19·10⁻⁷ (sin) and 1.15·10⁻⁷ (cos) with separate roundings, 1.30·10⁻⁷ and 1.27·10⁻⁷ fused,
//! about 2 ulp near ±1 (the rounding of r² and r³ at |r| ≈ π/2, where r³·S₁… is 0.57);
//! ≤ 4·10⁻⁶ on |x| ≤ 10⁴; `sinf`'s own error is ≤ 6·10⁻⁸. The network's own f32 sums of 64 to
//! 512 products round at about 10⁻⁶. Beyond |x| ≈ 10⁵ the reduction loses accuracy, and beyond
//! |x| ≈ 1.3·10⁷ (|x/π| ≥ 2²², where the magic-number rounding stops) r is no longer small: it
//! grows like |x|·2⁻²⁴ and S(r) would grow like r⁹, to ±∞ and then NaN in the next layer (a query
//! at x = 10⁹ mm gave NaN). Clamping r to ±[`R_MAX`] keeps every finite x's result in
//! [−1.0001, 1.0001] at the cost of one min and one max; NaN and ±∞ still give NaN.

const FRAC_1_PI: f32 = core::f32::consts::FRAC_1_PI;
/// 1.5·2²³: adding it rounds a float below 2²² to an integer, held in the low mantissa bits.
const ROUND_MAGIC: f32 = 12_582_912.0;
const P1: f32 = 3.140_625;
const P2: f32 = 9.675_026e-4;
const P3: f32 = 1.509_958e-7;
const S1: f32 = -1.666_666_6e-1;
const S2: f32 = 8.333_257e-3;
const S3: f32 = -1.982_344_3e-4;
const S4: f32 = 2.634_800_5e-6;
/// Bound on the reduced argument: above π/2 plus the reduction's rounding (so it changes no
/// result where the reduction is exact), and where S is still within 10⁻⁴ of ±1.
pub const R_MAX: f32 = 1.6;

/// How a·b + c is evaluated: the portable kernels round twice (bit-identical on every target);
/// the SIMD kernels (and the trainer's) use one fused multiply-add instruction.
pub trait MulAdd {
    /// a·b + c.
    fn mul_add(a: f32, b: f32, c: f32) -> f32;
}

/// a·b + c with two roundings (Rust never fuses them implicitly).
pub struct Separate;

impl MulAdd for Separate {
    #[inline(always)]
    fn mul_add(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

/// a·b + c with one rounding (`f32::mul_add`): one instruction where the calling function
/// enables the `fma` target feature (or on aarch64), a slow software fused multiply-add
/// elsewhere, so use it only in code compiled for such targets.
#[cfg(feature = "std")]
pub struct Fused;

#[cfg(feature = "std")]
impl MulAdd for Fused {
    #[inline(always)]
    fn mul_add(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

/// S(x − n·π)·(−1)ⁿ for n = round(x/π) (`HALF = false`: sin x), or for n = m + ½,
/// m = round(x/π − ½), times −1 (`HALF = true`: cos x).
#[inline(always)]
fn reduced_sine<M: MulAdd, const HALF: bool>(x: f32) -> f32 {
    let shifted = if HALF {
        M::mul_add(x, FRAC_1_PI, -0.5) + ROUND_MAGIC
    } else {
        M::mul_add(x, FRAC_1_PI, ROUND_MAGIC)
    };
    // (−1)ⁿ for sin; (−1)ᵐ⁺¹ for cos.
    let sign = (shifted.to_bits() << 31) ^ if HALF { 0x8000_0000 } else { 0 };
    let n = if HALF {
        (shifted - ROUND_MAGIC) + 0.5
    } else {
        shifted - ROUND_MAGIC
    };
    let r = M::mul_add(-n, P3, M::mul_add(-n, P2, M::mul_add(-n, P1, x)));
    // Comparisons, not f32::clamp: NaN passes through (both are false) and each compiles to
    // one max/min instruction.
    let r = if r > R_MAX { R_MAX } else { r };
    let r = if r < -R_MAX { -R_MAX } else { r };
    let r2 = r * r;
    let p = M::mul_add(r2, M::mul_add(r2, M::mul_add(r2, S4, S3), S2), S1);
    let s = M::mul_add(r * r2, p, r);
    f32::from_bits(s.to_bits() ^ sign)
}

/// [`sin_cos`] with the given multiply-add.
#[inline(always)]
pub fn sin_cos_with<M: MulAdd>(x: f32) -> (f32, f32) {
    (reduced_sine::<M, false>(x), reduced_sine::<M, true>(x))
}

/// [`sin`] with the given multiply-add.
#[inline(always)]
pub fn sin_with<M: MulAdd>(x: f32) -> f32 {
    reduced_sine::<M, false>(x)
}

/// sin(x) and cos(x).
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    sin_cos_with::<Separate>(x)
}

/// sin(x): one reduction and one polynomial, the same bits as `sin_cos(x).0`.
#[inline(always)]
pub fn sin(x: f32) -> f32 {
    sin_with::<Separate>(x)
}

/// Replaces every element by its sine.
#[inline(always)]
pub fn sin_in_place(values: &mut [f32]) {
    for v in values {
        *v = sin(*v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_error(lo: f32, hi: f32, n: usize) -> (f64, f64) {
        let (a, b) = max_error_with::<Separate>(lo, hi, n);
        #[cfg(feature = "std")]
        let (a, b) = {
            let (c, d) = max_error_with::<Fused>(lo, hi, n);
            (a.max(c), b.max(d))
        };
        (a, b)
    }

    fn max_error_with<M: MulAdd>(lo: f32, hi: f32, n: usize) -> (f64, f64) {
        let (mut es, mut ec) = (0.0f64, 0.0f64);
        for i in 0..=n {
            let x = lo + (hi - lo) * (i as f32 / n as f32);
            let (s, c) = sin_cos_with::<M>(x);
            es = es.max((s as f64 - libm::sin(x as f64)).abs());
            ec = ec.max((c as f64 - libm::cos(x as f64)).abs());
        }
        (es, ec)
    }

    #[test]
    fn accuracy_against_libm() {
        let (s, c) = max_error(-100.0, 100.0, 1_000_000);
        assert!(s <= 1.4e-7 && c <= 1.4e-7, "|x|<=100: sin {s:e}, cos {c:e}");
        let (s, c) = max_error(-1e4, 1e4, 1_000_000);
        assert!(s <= 4e-6 && c <= 4e-6, "|x|<=1e4: sin {s:e}, cos {c:e}");
    }

    #[test]
    fn reduction_boundaries_and_specials() {
        // Multiples of π/4 straddle both reductions' rounding boundaries (x/π and x/π − ½ at
        // half-integers), where n changes and r jumps from +π/2 to −π/2.
        for k in -64..=64 {
            let x = k as f32 * core::f32::consts::FRAC_PI_4;
            for x in [x.next_down(), x, x.next_up()] {
                let (s, c) = sin_cos(x);
                assert!((s as f64 - libm::sin(x as f64)).abs() < 2e-7, "sin({x})");
                assert!((c as f64 - libm::cos(x as f64)).abs() < 2e-7, "cos({x})");
            }
        }
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            #[cfg(feature = "std")]
            let (s, c) = {
                let (fs, fc) = sin_cos_with::<Fused>(x);
                assert!(fs.is_nan() && fc.is_nan(), "fused sin_cos({x})");
                (s, c)
            };
            assert!(s.is_nan() && c.is_nan(), "sin_cos({x}) = ({s}, {c})");
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }

    /// Every finite argument, however far beyond the exact reduction, gives a bounded result:
    /// unbounded sines became ±∞ and NaN one layer later.
    #[test]
    fn every_finite_argument_gives_a_bounded_result() {
        let bounded = |x: f32| {
            let check = |(s, c): (f32, f32)| s.abs() <= 1.0001 && c.abs() <= 1.0001;
            #[cfg(feature = "std")]
            let fused = check(sin_cos_with::<Fused>(x));
            #[cfg(not(feature = "std"))]
            let fused = true;
            check(sin_cos(x)) && fused && sin(x).abs() <= 1.0001
        };
        // Every binade from the smallest normal to f32::MAX, 64 mantissas each, both signs.
        let sweep =
            (1u32..=254).flat_map(|e| (0..64).map(move |m| f32::from_bits(e << 23 | m << 17)));
        let specials = [f32::MAX, 1e9, 4_294_967_297.0, 1e30, 1e38];
        for x in sweep.chain(specials) {
            for x in [x, -x] {
                assert!(bounded(x), "sin_cos({x:e}) = {:?}", sin_cos(x));
            }
        }
    }

    #[test]
    fn sin_alone_has_the_bits_of_sin_cos() {
        let specials = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-40,
            f32::MAX,
            f32::NAN,
            f32::INFINITY,
        ];
        let sweep = (-200_000..=200_000).map(|i| i as f32 * 7.3e-3);
        let wide = (-2000..=2000).map(|i| i as f32 * 61.7);
        for x in specials.into_iter().chain(sweep).chain(wide) {
            let (a, b) = (sin(x), sin_cos(x).0);
            assert!(
                a.to_bits() == b.to_bits(),
                "sin({x:e}) = {a:e}, sin_cos: {b:e}"
            );
            #[cfg(feature = "std")]
            {
                let (a, b) = (sin_with::<Fused>(x), sin_cos_with::<Fused>(x).0);
                assert!(
                    a.to_bits() == b.to_bits(),
                    "fused sin({x:e}) = {a:e}, {b:e}"
                );
            }
        }
    }
}
