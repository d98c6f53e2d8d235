//! The two hot loops of evaluation, per instruction set: the layer product C += A·Wᵀ and the
//! sine activation with its forward-mode tangents.
//!
//! A batch block holds up to [`crate::eval::BLOCK_ROWS`] rows (points, and their tangent rows),
//! so each weight is loaded once per block rather than once per point; the SIMD kernels are
//! BLIS-style register tiles (AVX-512: 8 rows × 32 columns in 16 zmm accumulators; AVX2:
//! 6 rows × 16 columns in 12 ymm accumulators) over a packed 32- or 16-column panel of Wᵀ, which
//! is also where f16 weights are widened to f32. The portable kernel is an axpy loop that
//! compilers vectorise for any target (SSE2, NEON, Helium) and is what single points use.
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

/// Row `k` of B as f32: borrowed for f32 weights, widened into `tmp` for f16.
#[inline(always)]
fn b_row<'t>(
    b: Weights<'t>,
    k: usize,
    n0: usize,
    n1: usize,
    n: usize,
    tmp: &'t mut [f32],
) -> &'t [f32] {
    let start = k * n;
    match b {
        Weights::F32(w) => &w[start + n0..start + n1],
        Weights::F16(w) => {
            let out = &mut tmp[..n1 - n0];
            for (o, h) in out.iter_mut().zip(&w[start + n0..start + n1]) {
                *o = h.to_f32();
            }
            out
        }
    }
}

/// Columns `n0..n1` of the product, k outer so each row of B is read (and widened) once.
#[inline(always)]
fn product_columns(p: &Product, c: &mut [f32], row: &mut [f32], n0: usize, n1: usize) {
    for k in 0..p.kdim {
        let brow = b_row(p.b, k, n0, n1, p.n, row);
        for r in 0..p.rows {
            let a = p.a[r * p.kdim + k];
            let crow = &mut c[r * p.n + n0..r * p.n + n1];
            for (cv, bv) in crow.iter_mut().zip(brow) {
                *cv += a * bv;
            }
        }
    }
}

fn product_portable(p: &Product, c: &mut [f32], _panel: &mut [f32], row: &mut [f32]) {
    if p.fits(c) {
        product_columns(p, c, row, 0, p.n);
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
    use super::{activate_generic, product_columns, Kernels, Product};
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

    /// Copies columns `j0..j0 + nr` of B into `panel` (`kdim × nr`, contiguous), widening f16.
    #[inline(always)]
    fn pack(b: Weights, kdim: usize, n: usize, j0: usize, nr: usize, panel: &mut [f32]) {
        for k in 0..kdim {
            let dst = &mut panel[k * nr..(k + 1) * nr];
            match b {
                Weights::F32(w) => dst.copy_from_slice(&w[k * n + j0..k * n + j0 + nr]),
                Weights::F16(w) => {
                    for (d, h) in dst.iter_mut().zip(&w[k * n + j0..k * n + j0 + nr]) {
                        *d = h.to_f32();
                    }
                }
            }
        }
    }

    macro_rules! tiled_product {
        ($name:ident, $tile:ident, $feat:literal, $vec:ty, $lanes:literal, $nvec:literal, $mr:literal,
         $load:ident, $store:ident, $set1:ident, $fmadd:ident) => {
            /// Register tile: rows `r0..r0 + R` × the packed panel's columns.
            ///
            /// # Safety
            /// The CPU has the enabled features; `a` holds rows `r0..r0+R` of `kdim` values,
            /// `panel` holds `kdim × lanes·nvec` values and `c` rows `r0..r0+R` of `ldc` values
            /// from column `j0`.
            #[target_feature(enable = $feat)]
            #[inline]
            unsafe fn $tile<const R: usize>(
                a: *const f32,
                kdim: usize,
                panel: *const f32,
                c: *mut f32,
                ldc: usize,
            ) {
                const NR: usize = $lanes * $nvec;
                // SAFETY: the caller guarantees every pointer offset below is in bounds.
                unsafe {
                    let mut acc: [[$vec; $nvec]; R] = [[core::mem::zeroed(); $nvec]; R];
                    for (r, acc_r) in acc.iter_mut().enumerate() {
                        for (v, acc_rv) in acc_r.iter_mut().enumerate() {
                            *acc_rv = $load(c.add(r * ldc + v * $lanes));
                        }
                    }
                    for k in 0..kdim {
                        let mut bv: [$vec; $nvec] = [core::mem::zeroed(); $nvec];
                        for (v, b) in bv.iter_mut().enumerate() {
                            *b = $load(panel.add(k * NR + v * $lanes));
                        }
                        for (r, acc_r) in acc.iter_mut().enumerate() {
                            let av = $set1(*a.add(r * kdim + k));
                            for (acc_rv, b) in acc_r.iter_mut().zip(&bv) {
                                *acc_rv = $fmadd(av, *b, *acc_rv);
                            }
                        }
                    }
                    for (r, acc_r) in acc.iter().enumerate() {
                        for (v, acc_rv) in acc_r.iter().enumerate() {
                            $store(c.add(r * ldc + v * $lanes), *acc_rv);
                        }
                    }
                }
            }

            #[target_feature(enable = $feat)]
            fn $name(p: &Product, c: &mut [f32], panel: &mut [f32], row: &mut [f32]) {
                const NR: usize = $lanes * $nvec;
                if !p.fits(c) || panel.len() < p.kdim * NR {
                    return;
                }
                let n_full = p.n / NR * NR;
                for j0 in (0..n_full).step_by(NR) {
                    pack(p.b, p.kdim, p.n, j0, NR, panel);
                    let mut r0 = 0;
                    while r0 < p.rows {
                        let left = p.rows - r0;
                        // SAFETY: `fits` checked A and C hold `rows` rows; r0 + R <= rows and
                        // j0 + NR <= n, and the panel holds kdim × NR values.
                        unsafe {
                            let a = p.a.as_ptr().add(r0 * p.kdim);
                            let cp = c.as_mut_ptr().add(r0 * p.n + j0);
                            let pp = panel.as_ptr();
                            match left {
                                l if l >= $mr => $tile::<$mr>(a, p.kdim, pp, cp, p.n),
                                1 => $tile::<1>(a, p.kdim, pp, cp, p.n),
                                2 => $tile::<2>(a, p.kdim, pp, cp, p.n),
                                3 => $tile::<3>(a, p.kdim, pp, cp, p.n),
                                4 => $tile::<4>(a, p.kdim, pp, cp, p.n),
                                5 => $tile::<5>(a, p.kdim, pp, cp, p.n),
                                6 => $tile::<6>(a, p.kdim, pp, cp, p.n),
                                _ => $tile::<7>(a, p.kdim, pp, cp, p.n),
                            }
                        }
                        r0 += left.min($mr);
                    }
                }
                if n_full < p.n {
                    product_columns(p, c, row, n_full, p.n);
                }
            }
        };
    }

    tiled_product!(
        product_tiled_avx512,
        tile_avx512,
        "avx512f,avx2,fma,f16c",
        __m512,
        16,
        2,
        8,
        _mm512_loadu_ps,
        _mm512_storeu_ps,
        _mm512_set1_ps,
        _mm512_fmadd_ps
    );
    tiled_product!(
        product_tiled_avx2,
        tile_avx2,
        "avx2,fma,f16c",
        __m256,
        8,
        2,
        6,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_set1_ps,
        _mm256_fmadd_ps
    );
}

#[cfg(test)]
pub(crate) fn all_available() -> impl Iterator<Item = Kernels> {
    let best = best();
    [PORTABLE]
        .into_iter()
        .chain((best.name != PORTABLE.name).then_some(best))
}
