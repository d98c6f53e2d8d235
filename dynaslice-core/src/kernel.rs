//! The two hot loops of evaluation, per instruction set: the layer product C += A·Wᵀ and the
//! sine activation with its forward-mode tangents.
//!
//! A batch block holds up to [`crate::eval::BLOCK_ROWS`] rows (points, and their tangent rows),
//! so each weight is loaded once per block rather than once per point; the SIMD kernels are
//! BLIS-style register tiles (AVX-512: 8 rows × 32 columns in 16 zmm accumulators; AVX2:
//! 6 rows × 16 columns in 12 ymm accumulators) over a packed 32- or 16-column panel of Wᵀ, which
//! is also where f16 weights are widened to f32. A narrow last panel (e.g. the K output
//! columns) is zero-padded and its tiles read and write C through lane masks. The portable
//! kernel is an axpy loop that compilers vectorise for any target (SSE2, NEON, Helium) and is
//! what single points use. Measurements: docs/performance.md.
//!
//! With the `std` feature the AVX kernels are chosen at run time (never `target-cpu=native`);
//! without it, only when the build enables the target features at compile time.

use crate::model::Weights;
use crate::sine::{sin, sin_cos};

/// C[r][0..n] += Σ_k A[r][k] · B[k][0..n] for r < rows, with A row-major (`rows × kdim`), B the
/// layer's Wᵀ (`kdim × n`) and C row-major (`rows × n`).
pub(crate) struct Product<'a, 'w> {
    pub a: &'a [f32],
    pub rows: usize,
    pub kdim: usize,
    pub b: Weights<'w>,
    pub n: usize,
}

impl Product<'_, '_> {
    /// True when every slice is long enough for the product: the kernels check this once and
    /// then index without further checks.
    fn fits(&self, c: &[f32]) -> bool {
        self.a.len() >= self.rows * self.kdim
            && self.b.len() >= self.kdim * self.n
            && c.len() >= self.rows * self.n
    }
}

/// The kernels of one instruction set.
#[derive(Clone, Copy)]
pub(crate) struct Kernels {
    /// Name reported by benchmarks.
    pub name: &'static str,
    /// C += A·B; `panel` and `row` are scratch of at least `MAX_WIDTH * 32` and `MAX_WIDTH`.
    pub product: fn(&Product, &mut [f32], &mut [f32], &mut [f32]),
    /// Sine activation of `points` primal rows of `width` values and multiplication of their
    /// `n_tan` tangent row groups by the cosine (ḣ' = cos z ⊙ ż); `cos` is `width` scratch.
    pub activate: fn(&mut [f32], usize, usize, usize, &mut [f32]),
}

/// Portable kernels (any target).
pub(crate) const PORTABLE: Kernels = Kernels {
    name: "portable",
    product: product_portable,
    activate: activate_generic,
};

/// The best kernels for this CPU.
pub(crate) fn best() -> Kernels {
    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    {
        use core::sync::atomic::{AtomicU8, Ordering};
        static CHOICE: AtomicU8 = AtomicU8::new(0);
        let choice = match CHOICE.load(Ordering::Relaxed) {
            0 => {
                let c = if std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("f16c")
                    && std::is_x86_feature_detected!("fma")
                {
                    3
                } else if std::is_x86_feature_detected!("avx2")
                    && std::is_x86_feature_detected!("fma")
                    && std::is_x86_feature_detected!("f16c")
                {
                    2
                } else {
                    1
                };
                CHOICE.store(c, Ordering::Relaxed);
                c
            }
            c => c,
        };
        match choice {
            3 => x86::AVX512,
            2 => x86::AVX2,
            _ => PORTABLE,
        }
    }
    #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
    {
        PORTABLE
    }
}

/// f16 → f32, exact, branch-free so that loops over slices vectorise on any target (`half`'s
/// conversion is a call per element unless F16C is enabled at compile time, which made f16
/// weights several times slower than f32 on the portable path).
///
/// The exponent and mantissa bits shifted into f32 position read as the value times 2⁻¹¹²
/// (the difference of the exponent biases), for normal and subnormal halves alike, so one
/// exact multiplication by 2¹¹² rescales both; infinities and NaNs get the all-ones exponent.
#[inline(always)]
pub(crate) fn widen(h: half::f16) -> f32 {
    const MAGNITUDE_ONES: u32 = 0x7fff;
    const HALF_INF: u32 = 0x7c00;
    const TWO_POW_112: f32 = 5.192_297e33;
    let bits = h.to_bits() as u32;
    let magnitude = bits & MAGNITUDE_ONES;
    let scaled = f32::from_bits(magnitude << 13) * TWO_POW_112;
    let unsigned = if magnitude >= HALF_INF {
        (magnitude << 13) | 0x7f80_0000
    } else {
        scaled.to_bits()
    };
    f32::from_bits(unsigned | (bits & 0x8000) << 16)
}

/// Row `k` of B as f32: borrowed for f32 weights, widened into `tmp` for f16.
#[inline(always)]
fn b_row<'t>(b: Weights<'t>, k: usize, n: usize, tmp: &'t mut [f32]) -> &'t [f32] {
    let start = k * n;
    match b {
        Weights::F32(w) => &w[start..start + n],
        Weights::F16(w) => {
            let out = &mut tmp[..n];
            for (o, &h) in out.iter_mut().zip(&w[start..start + n]) {
                *o = widen(h);
            }
            out
        }
    }
}

/// k outer so each row of B is read (and widened) once.
fn product_portable(p: &Product, c: &mut [f32], _panel: &mut [f32], row: &mut [f32]) {
    if !p.fits(c) {
        return;
    }
    for k in 0..p.kdim {
        let brow = b_row(p.b, k, p.n, row);
        for r in 0..p.rows {
            let a = p.a[r * p.kdim + k];
            for (cv, bv) in c[r * p.n..(r + 1) * p.n].iter_mut().zip(brow) {
                *cv += a * bv;
            }
        }
    }
}
#[inline(always)]
fn activate_generic(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
    let (primal, tangents) = buf.split_at_mut(points * width);
    let cos = &mut cos[..width];
    for (p, z) in primal.chunks_exact_mut(width).enumerate() {
        if n_tan == 0 {
            z.iter_mut().for_each(|v| *v = sin(*v));
            continue;
        }
        for (v, c) in z.iter_mut().zip(cos.iter_mut()) {
            (*v, *c) = sin_cos(*v);
        }
        for d in 0..n_tan {
            let start = (d * points + p) * width;
            for (t, c) in tangents[start..start + width].iter_mut().zip(cos.iter()) {
                *t *= c;
            }
        }
    }
}

#[cfg(all(feature = "std", target_arch = "x86_64"))]
mod x86 {
    //! AVX2 and AVX-512 register-tile kernels.
    //!
    //! Safety: these functions are only reachable through [`AVX2`] and [`AVX512`], which
    //! [`super::best`] hands out only after detecting the target features they enable.
    use super::{activate_generic, widen, Kernels, Product};
    use crate::model::Weights;
    use core::arch::x86_64::*;

    pub(crate) const AVX512: Kernels = Kernels {
        name: "avx512",
        product: product_avx512,
        activate: activate_avx512,
    };
    pub(crate) const AVX2: Kernels = Kernels {
        name: "avx2",
        product: product_avx2,
        activate: activate_avx2,
    };

    fn product_avx512(p: &Product, c: &mut [f32], panel: &mut [f32], row: &mut [f32]) {
        // SAFETY: AVX512 is only handed out after avx512f, f16c and fma were detected.
        unsafe { product_tiled_avx512(p, c, panel, row) }
    }
    fn product_avx2(p: &Product, c: &mut [f32], panel: &mut [f32], row: &mut [f32]) {
        // SAFETY: AVX2 is only handed out after avx2, fma and f16c were detected.
        unsafe { product_tiled_avx2(p, c, panel, row) }
    }
    fn activate_avx512(
        buf: &mut [f32],
        points: usize,
        n_tan: usize,
        width: usize,
        cos: &mut [f32],
    ) {
        // SAFETY: as above; the body is plain Rust compiled with wider vectors.
        unsafe { activate_512(buf, points, n_tan, width, cos) }
    }
    fn activate_avx2(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        // SAFETY: as above.
        unsafe { activate_256(buf, points, n_tan, width, cos) }
    }

    #[target_feature(enable = "avx512f,avx2,fma,f16c")]
    fn activate_512(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        activate_generic(buf, points, n_tan, width, cos)
    }
    #[target_feature(enable = "avx2,fma,f16c")]
    fn activate_256(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        activate_generic(buf, points, n_tan, width, cos)
    }

    /// Copies columns `j0..j0 + cols` of B into `panel` (`kdim × NR`, contiguous), widening
    /// f16 and padding a narrow last panel with zeros so the tiles always run full width.
    #[inline(always)]
    fn pack<const NR: usize>(
        b: Weights,
        kdim: usize,
        n: usize,
        j0: usize,
        cols: usize,
        panel: &mut [f32],
    ) {
        for (k, dst) in panel[..kdim * NR].chunks_exact_mut(NR).enumerate() {
            let src = k * n + j0..k * n + j0 + cols;
            match b {
                Weights::F32(w) => pack_row::<NR, _>(dst, &w[src], |x| x),
                Weights::F16(w) => pack_row::<NR, _>(dst, &w[src], widen),
            }
        }
    }

    /// One row of a panel: `src` converted, then zeros up to NR.
    #[inline(always)]
    fn pack_row<const NR: usize, T: Copy>(dst: &mut [f32], src: &[T], conv: impl Fn(T) -> f32) {
        // A full row has a fixed length, which compiles to a few vector moves (a copy of
        // run-time length called memmove once per row: 15% of the time at width 256).
        if let (Some(dst), Some(src)) = (dst.first_chunk_mut::<NR>(), src.first_chunk::<NR>()) {
            dst.iter_mut().zip(src).for_each(|(d, &x)| *d = conv(x));
        } else {
            let (dst, pad) = dst.split_at_mut(src.len());
            dst.iter_mut().zip(src).for_each(|(d, &x)| *d = conv(x));
            pad.fill(0.0);
        }
    }

    macro_rules! tiled_product {
        ($name:ident, $tile:ident, $feat:literal, $vec:ty, $lanes:literal, $mr:literal,
         $mask:ty, $mask_for:ident, $loadc:ident, $storec:ident,
         $load:ident, $set1:ident, $fmadd:ident) => {
            /// Register tile: rows `r0..r0 + R` × two vectors of the packed panel's columns,
            /// reading and writing C only where `masks` are set (the last panel may be narrow).
            ///
            /// # Safety
            /// The CPU has the enabled features; `a` holds R rows of `kdim` values, `panel`
            /// holds `kdim × 2·lanes` values and `c` R rows of `ldc` values, of which the
            /// masked columns exist.
            #[target_feature(enable = $feat)]
            #[inline]
            unsafe fn $tile<const R: usize>(
                a: *const f32,
                kdim: usize,
                panel: *const f32,
                c: *mut f32,
                ldc: usize,
                masks: [$mask; 2],
            ) {
                const NR: usize = 2 * $lanes;
                // SAFETY: the caller guarantees every pointer offset below is in bounds.
                unsafe {
                    let mut acc: [[$vec; 2]; R] = core::array::from_fn(|r| {
                        core::array::from_fn(|v| $loadc(c.add(r * ldc + v * $lanes), masks[v]))
                    });
                    for k in 0..kdim {
                        let b0 = $load(panel.add(k * NR));
                        let b1 = $load(panel.add(k * NR + $lanes));
                        for (r, acc_r) in acc.iter_mut().enumerate() {
                            let av = $set1(*a.add(r * kdim + k));
                            acc_r[0] = $fmadd(av, b0, acc_r[0]);
                            acc_r[1] = $fmadd(av, b1, acc_r[1]);
                        }
                    }
                    for (r, acc_r) in acc.iter().enumerate() {
                        for (v, acc_rv) in acc_r.iter().enumerate() {
                            $storec(c.add(r * ldc + v * $lanes), masks[v], *acc_rv);
                        }
                    }
                }
            }

            #[target_feature(enable = $feat)]
            fn $name(p: &Product, c: &mut [f32], panel: &mut [f32], _row: &mut [f32]) {
                const NR: usize = 2 * $lanes;
                if !p.fits(c) || panel.len() < p.kdim * NR {
                    return;
                }
                for j0 in (0..p.n).step_by(NR) {
                    let cols = NR.min(p.n - j0);
                    pack::<NR>(p.b, p.kdim, p.n, j0, cols, panel);
                    let masks = [$mask_for(cols), $mask_for(cols.saturating_sub($lanes))];
                    let mut r0 = 0;
                    while r0 < p.rows {
                        let left = p.rows - r0;
                        // SAFETY: `fits` checked A and C hold `rows` rows; r0 + R <= rows, the
                        // masks cover only columns j0..j0 + cols <= n, and the panel holds
                        // kdim × NR values.
                        unsafe {
                            let a = p.a.as_ptr().add(r0 * p.kdim);
                            let cp = c.as_mut_ptr().add(r0 * p.n + j0);
                            let pp = panel.as_ptr();
                            let (k, n) = (p.kdim, p.n);
                            match left {
                                l if l >= $mr => $tile::<$mr>(a, k, pp, cp, n, masks),
                                1 => $tile::<1>(a, k, pp, cp, n, masks),
                                2 => $tile::<2>(a, k, pp, cp, n, masks),
                                3 => $tile::<3>(a, k, pp, cp, n, masks),
                                4 => $tile::<4>(a, k, pp, cp, n, masks),
                                5 => $tile::<5>(a, k, pp, cp, n, masks),
                                6 => $tile::<6>(a, k, pp, cp, n, masks),
                                _ => $tile::<7>(a, k, pp, cp, n, masks),
                            }
                        }
                        r0 += left.min($mr);
                    }
                }
            }
        };
    }

    /// Lanes `0..cols` of a 16-lane vector.
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn mask16(cols: usize) -> __mmask16 {
        (((1u32 << cols.min(16)) - 1) & 0xffff) as __mmask16
    }
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn load16(p: *const f32, m: __mmask16) -> __m512 {
        // SAFETY: the caller guarantees the masked lanes are readable.
        unsafe { _mm512_maskz_loadu_ps(m, p) }
    }
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn store16(p: *mut f32, m: __mmask16, v: __m512) {
        // SAFETY: the caller guarantees the masked lanes are writable.
        unsafe { _mm512_mask_storeu_ps(p, m, v) }
    }

    /// Lanes `0..cols` of an 8-lane vector (all bits of a lane set).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn mask8(cols: usize) -> __m256i {
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        _mm256_cmpgt_epi32(_mm256_set1_epi32(cols.min(8) as i32), lane)
    }
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn load8(p: *const f32, m: __m256i) -> __m256 {
        // SAFETY: the caller guarantees the masked lanes are readable.
        unsafe { _mm256_maskload_ps(p, m) }
    }
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn store8(p: *mut f32, m: __m256i, v: __m256) {
        // SAFETY: the caller guarantees the masked lanes are writable.
        unsafe { _mm256_maskstore_ps(p, m, v) }
    }

    tiled_product!(
        product_tiled_avx512,
        tile_avx512,
        "avx512f,avx2,fma,f16c",
        __m512,
        16,
        8,
        __mmask16,
        mask16,
        load16,
        store16,
        _mm512_loadu_ps,
        _mm512_set1_ps,
        _mm512_fmadd_ps
    );
    tiled_product!(
        product_tiled_avx2,
        tile_avx2,
        "avx2,fma,f16c",
        __m256,
        8,
        6,
        __m256i,
        mask8,
        load8,
        store8,
        _mm256_loadu_ps,
        _mm256_set1_ps,
        _mm256_fmadd_ps
    );
}

/// Every kernel set this CPU can run (an AVX-512 machine also tests the AVX2 kernels).
#[cfg(all(test, feature = "std"))]
pub(crate) fn all_available() -> impl Iterator<Item = Kernels> {
    let best = best();
    #[cfg(target_arch = "x86_64")]
    let avx2 = (best.name == x86::AVX512.name).then_some(x86::AVX2);
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = None;
    [PORTABLE]
        .into_iter()
        .chain(avx2)
        .chain((best.name != PORTABLE.name).then_some(best))
}

#[cfg(test)]
mod tests {
    use super::widen;
    use half::f16;

    #[test]
    fn widen_is_exact_for_every_half() {
        for bits in 0..=u16::MAX {
            let h = f16::from_bits(bits);
            let (got, want) = (widen(h), h.to_f32());
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "{bits:#06x}: {got:e} vs {want:e}"
            );
        }
    }
}
