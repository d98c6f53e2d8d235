//! Branch-free single-precision sine and cosine that compilers vectorise.
//!
//! Every hidden unit of a SIREN costs one sine (and, with derivatives, one cosine): at width 256
//! that is 256 sines per layer per point, which with libm's scalar `sinf` would cost more than
//! the layer's matrix product. This implementation has no branches, table look-ups or calls, so a
//! loop over a slice compiles to SIMD code for whatever target features the caller enables.
//!
//! Method (Cody & Waite; polynomials from Cephes `sinf.c`/`cosf.c`):
//! 1. k = round(x · 2/π) via the 1.5·2²³ magic-number trick, which also leaves k mod 4 (the
//!    quadrant) in the low bits of the sum.
//! 2. r = x − k·π/2 with π/2 split into three parts whose leading part has 8 significant bits,
//!    so k·P1 is exact for |k| < 2¹⁶.
//! 3. Degree-7 sine and degree-8 cosine minimax polynomials on r ∈ [−π/4, π/4], then swap and
//!    negate by quadrant with bit operations.
//!
//! Accuracy (measured by `sine::tests::accuracy_against_libm`, against f64 `libm::sin`/`cos`
//! over 2·10⁶ points): max absolute error ≤ 1.2·10⁻⁷ on |x| ≤ 100 (the range of SIREN
//! pre-activations) and ≤ 4·10⁻⁶ on |x| ≤ 10⁴; `sinf`'s own error is ≤ 6·10⁻⁸. Beyond
//! |x| ≈ 10⁵ the reduction loses accuracy (results stay in [−1, 1]). NaN or ±∞ give NaN.

const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
/// 1.5·2²³: adding it rounds a float below 2²² to an integer, held in the low mantissa bits.
const ROUND_MAGIC: f32 = 12_582_912.0;
const P1: f32 = 1.570_312_5;
const P2: f32 = 4.837_513e-4;
const P3: f32 = 7.549_79e-8;
const S1: f32 = -1.666_665_5e-1;
const S2: f32 = 8.332_161e-3;
const S3: f32 = -1.951_529_6e-4;
const C1: f32 = 4.166_664_6e-2;
const C2: f32 = -1.388_731_6e-3;
const C3: f32 = 2.443_315_7e-5;

/// sin(x) and cos(x) together (they share the range reduction).
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let shifted = x * FRAC_2_PI + ROUND_MAGIC;
    let quadrant = shifted.to_bits();
    let k = shifted - ROUND_MAGIC;
    let r = ((x - k * P1) - k * P2) - k * P3;
    let r2 = r * r;
    let s = r + r * r2 * (S1 + r2 * (S2 + r2 * S3));
    let c = 1.0 - 0.5 * r2 + r2 * r2 * (C1 + r2 * (C2 + r2 * C3));
    // Quadrant q: sin x = (s, c, −s, −c)[q], cos x = (c, −s, −c, s)[q].
    let swap = quadrant & 1 != 0;
    let (sv, cv) = if swap { (c, s) } else { (s, c) };
    let sin_sign = (quadrant & 2) << 30;
    let cos_sign = (quadrant.wrapping_add(1) & 2) << 30;
    (
        f32::from_bits(sv.to_bits() ^ sin_sign),
        f32::from_bits(cv.to_bits() ^ cos_sign),
    )
}

/// sin(x) alone.
#[inline(always)]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
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
        let (mut es, mut ec) = (0.0f64, 0.0f64);
        for i in 0..=n {
            let x = lo + (hi - lo) * (i as f32 / n as f32);
            let (s, c) = sin_cos(x);
            es = es.max((s as f64 - libm::sin(x as f64)).abs());
            ec = ec.max((c as f64 - libm::cos(x as f64)).abs());
        }
        (es, ec)
    }

    #[test]
    fn accuracy_against_libm() {
        let (s, c) = max_error(-100.0, 100.0, 1_000_000);
        assert!(s <= 1.2e-7 && c <= 1.2e-7, "|x|<=100: sin {s:e}, cos {c:e}");
        let (s, c) = max_error(-1e4, 1e4, 1_000_000);
        assert!(s <= 4e-6 && c <= 4e-6, "|x|<=1e4: sin {s:e}, cos {c:e}");
    }

    #[test]
    fn quadrant_boundaries_and_specials() {
        for k in -64..=64 {
            let x = k as f32 * core::f32::consts::FRAC_PI_4;
            let (s, c) = sin_cos(x);
            assert!((s as f64 - libm::sin(x as f64)).abs() < 2e-7, "sin({x})");
            assert!((c as f64 - libm::cos(x as f64)).abs() < 2e-7, "cos({x})");
        }
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "sin_cos({x}) = ({s}, {c})");
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
    }
}
