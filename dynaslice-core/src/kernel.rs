//! The hot loops of evaluation, per instruction set: the first layer, the layer product
//! C = A·Wᵀ + b and the sine activation with its forward-mode tangents.
//!
//! A batch block holds up to [`crate::eval::BLOCK_ROWS`] rows (points, and their tangent rows),
//! so each weight is loaded once per block rather than once per point; the SIMD kernels are
//! BLIS-style register tiles (AVX-512: 8 rows × 32 columns in 16 zmm accumulators; AVX2:
//! 6 rows × 16 columns in 12 ymm accumulators) over a packed 32- or 16-column panel of Wᵀ, which
//! is also where f16 weights are widened to f32. A last panel of one vector or less (the K ≤ 16
//! output columns of most models) is packed one vector wide and tiled with twice the rows, so
//! no multiply-add runs on padding (half the output layer's work at K = 8 on AVX-512). The accumulators start from the bias (primal
//! rows) or zero (tangent rows), so C is written once and never read. A narrow last panel (e.g.
//! the K output columns) is zero-padded and its tiles write C through lane masks. The portable
//! kernel is an axpy loop that compilers vectorise for any target (SSE2, NEON, Helium) and is
//! what single points use. Measurements: docs/performance.md.
//!
//! With the `std` feature the AVX kernels are chosen at run time by [`Level::detect`] (never
//! `target-cpu=native`); without it, the portable kernels use whatever target features the build
//! enables.

use crate::cpu::Level;
use crate::layout::INPUT_DIM;
use crate::model::Weights;
use crate::sine::{sin_cos_with, sin_with, MulAdd, Separate};

/// C[r][0..n] = β_r + Σ_k A[r][k] · B[k][0..n] for r < rows, with A row-major (`rows × kdim`),
/// B the layer's Wᵀ (`kdim × n`), C row-major (`rows × n`), and β_r the bias for the first
/// `bias_rows` rows (the primal rows: z = Wh + b) and zero for the rest (tangents: ż = Wḣ).
pub(crate) struct Product<'a, 'w> {
    pub a: &'a [f32],
    pub rows: usize,
    pub kdim: usize,
    pub b: Weights<'w>,
    pub n: usize,
    pub bias: &'a [f32],
    pub bias_rows: usize,
}

impl Product<'_, '_> {
    /// True when every slice is long enough for the product: the kernels check this once and
    /// then index without further checks.
    fn fits(&self, c: &[f32]) -> bool {
        self.a.len() >= self.rows * self.kdim
            && self.b.len() >= self.kdim * self.n
            && self.bias.len() >= self.n
            && c.len() >= self.rows * self.n
    }
}

/// The first layer's inputs: `w` holds rows W_x, W_y, W_z, W_t, φ of `width` scalars each
/// (Eq. 2), applied to `inputs` (normalised x, y, z, t) with W_t clamped to ±`omega_t_max`
/// (Eq. 4); the first `n_tan` inputs carry tangents.
pub(crate) struct FirstLayer<'a, 'w> {
    pub w: Weights<'w>,
    pub omega_t_max: f32,
    pub inputs: &'a [[f32; INPUT_DIM]],
    pub n_tan: usize,
    pub width: usize,
}

/// Columns of the first layer computed per pass: one AVX-512 vector, two AVX2 vectors, so the
/// five weight rows of a chunk stay in registers.
const FIRST_CHUNK: usize = 16;

/// The kernels of one instruction set.
#[derive(Clone, Copy)]
pub(crate) struct Kernels {
    /// Name reported by benchmarks.
    pub name: &'static str,
    /// The first layer's pre-activations into `out`: z = φ + Σ_d W_d u_d for every point
    /// (primal rows), then W_d as the tangent rows of input d (∂z/∂u_d = W_d).
    pub first_layer: fn(&FirstLayer, &mut [f32]),
    /// C = A·B + β; `panel` and `row` are scratch of at least `MAX_WIDTH * 32` and `MAX_WIDTH`.
    pub product: fn(&Product, &mut [f32], &mut [f32], &mut [f32]),
    /// Sine activation of `points` primal rows of `width` values and multiplication of their
    /// `n_tan` tangent row groups by the cosine (ḣ' = cos z ⊙ ż); `cos` is `width` scratch.
    pub activate: fn(&mut [f32], usize, usize, usize, &mut [f32]),
}

/// Portable kernels (any target).
pub(crate) const PORTABLE: Kernels = Kernels {
    name: "portable",
    first_layer: first_layer_generic,
    product: product_portable,
    activate: activate_generic::<Separate>,
};

/// The kernels of `level`: the AVX sets are reachable only through its token.
pub(crate) fn for_level(level: Level) -> Kernels {
    match level {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        Level::Avx512(cpu) => x86::avx512(cpu),
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        Level::Avx2(cpu) => x86::avx2(cpu),
        // Off x86-64 or without `std` no token can be made: `Level::detect` is `Portable`.
        _ => PORTABLE,
    }
}

/// The best kernels for this CPU.
pub(crate) fn best() -> Kernels {
    for_level(Level::detect())
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

/// `w` as f32 into `out` (as many values as both hold).
pub(crate) fn widen_into(w: Weights, out: &mut [f32]) {
    match w {
        Weights::F32(src) => out.iter_mut().zip(src).for_each(|(o, &v)| *o = v),
        Weights::F16(src) => out.iter_mut().zip(src).for_each(|(o, &h)| *o = widen(h)),
    }
}

/// One pass over the output in chunks of [`FIRST_CHUNK`] columns; the sum is taken in the
/// order φ, x, y, z, t on every path, so all kernels give the same bits.
#[inline(always)]
fn first_layer_generic(l: &FirstLayer, out: &mut [f32]) {
    let (points, width) = (l.inputs.len(), l.width);
    if l.w.len() < (INPUT_DIM + 1) * width || out.len() < points * (1 + l.n_tan) * width {
        return;
    }
    let m = l.omega_t_max;
    for j0 in (0..width).step_by(FIRST_CHUNK) {
        let cols = FIRST_CHUNK.min(width - j0);
        let mut w = [[0.0f32; FIRST_CHUNK]; INPUT_DIM + 1];
        for (d, wd) in w.iter_mut().enumerate() {
            widen_into(l.w.sub(d * width + j0, cols), wd);
        }
        w[3].iter_mut().for_each(|v| *v = v.clamp(-m, m));
        let [wx, wy, wz, wt, phi] = &w;
        for (p, u) in l.inputs.iter().enumerate() {
            let z = &mut out[p * width + j0..p * width + j0 + cols];
            let terms = phi.iter().zip(wx).zip(wy).zip(wz).zip(wt);
            for (zv, ((((f, a), b), c), d)) in z.iter_mut().zip(terms) {
                *zv = f + u[0] * a + u[1] * b + u[2] * c + u[3] * d;
            }
        }
        for (d, wd) in w.iter().enumerate().take(l.n_tan) {
            for p in 0..points {
                let start = ((1 + d) * points + p) * width + j0;
                out[start..start + cols].copy_from_slice(&wd[..cols]);
            }
        }
    }
}

/// k outer so each row of B is read (and widened) once.
fn product_portable(p: &Product, c: &mut [f32], _panel: &mut [f32], row: &mut [f32]) {
    if !p.fits(c) {
        return;
    }
    for (r, c_row) in c[..p.rows * p.n].chunks_exact_mut(p.n).enumerate() {
        if r < p.bias_rows {
            c_row.copy_from_slice(&p.bias[..p.n]);
        } else {
            c_row.fill(0.0);
        }
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
fn activate_generic<M: MulAdd>(
    buf: &mut [f32],
    points: usize,
    n_tan: usize,
    width: usize,
    cos: &mut [f32],
) {
    let (primal, tangents) = buf.split_at_mut(points * width);
    let cos = &mut cos[..width];
    for (p, z) in primal.chunks_exact_mut(width).enumerate() {
        if n_tan == 0 {
            z.iter_mut().for_each(|v| *v = sin_with::<M>(*v));
            continue;
        }
        for (v, c) in z.iter_mut().zip(cos.iter_mut()) {
            (*v, *c) = sin_cos_with::<M>(*v);
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
    //! SAFETY: every function here enables features of one [`Level`](crate::cpu::Level) only
    //! (`avx2,fma,f16c`, or `avx512f,avx2,fma,f16c` of AVX-512's) and is reachable only through
    //! the table [`avx2`] or [`avx512`] returns, which take the token that `crate::cpu` makes
    //! only after detecting every feature of the level. The tables and the safe wrappers in
    //! them are private to this module, so no other path leads to these functions.
    use super::{activate_generic, first_layer_generic, widen, FirstLayer, Kernels, Product};
    use crate::cpu::{Avx2, Avx512};
    use crate::model::Weights;
    use crate::sine::Fused;
    use core::arch::x86_64::*;

    /// The AVX-512 kernels, for a CPU that has them.
    pub(crate) fn avx512(_: Avx512) -> Kernels {
        AVX512
    }

    /// The AVX2 kernels, for a CPU that has them.
    pub(crate) fn avx2(_: Avx2) -> Kernels {
        AVX2
    }

    const AVX512: Kernels = Kernels {
        name: "avx512",
        first_layer: first_layer_avx512,
        product: product_avx512,
        activate: activate_avx512,
    };
    const AVX2: Kernels = Kernels {
        name: "avx2",
        first_layer: first_layer_avx2,
        product: product_avx2,
        activate: activate_avx2,
    };

    fn product_avx512(p: &Product, c: &mut [f32], panel: &mut [f32], row: &mut [f32]) {
        // SAFETY: only in the table `avx512` returns for an Avx512 token (module note).
        unsafe { product_tiled_avx512(p, c, panel, row) }
    }
    fn product_avx2(p: &Product, c: &mut [f32], panel: &mut [f32], row: &mut [f32]) {
        // SAFETY: only in the table `avx2` returns for an Avx2 token (module note).
        unsafe { product_tiled_avx2(p, c, panel, row) }
    }
    fn activate_avx512(
        buf: &mut [f32],
        points: usize,
        n_tan: usize,
        width: usize,
        cos: &mut [f32],
    ) {
        // SAFETY: as for `product_avx512`; the body is plain Rust compiled with wider vectors.
        unsafe { activate_512(buf, points, n_tan, width, cos) }
    }
    fn activate_avx2(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        // SAFETY: as for `product_avx2`.
        unsafe { activate_256(buf, points, n_tan, width, cos) }
    }

    fn first_layer_avx512(l: &FirstLayer, out: &mut [f32]) {
        // SAFETY: as for `product_avx512`; the body is plain Rust compiled with wider vectors.
        unsafe { first_layer_512(l, out) }
    }
    fn first_layer_avx2(l: &FirstLayer, out: &mut [f32]) {
        // SAFETY: as for `product_avx2`.
        unsafe { first_layer_256(l, out) }
    }
    #[target_feature(enable = "avx512f,avx2,fma,f16c")]
    fn first_layer_512(l: &FirstLayer, out: &mut [f32]) {
        first_layer_generic(l, out)
    }
    #[target_feature(enable = "avx2,fma,f16c")]
    fn first_layer_256(l: &FirstLayer, out: &mut [f32]) {
        first_layer_generic(l, out)
    }

    #[target_feature(enable = "avx512f,avx2,fma,f16c")]
    fn activate_512(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        activate_generic::<Fused>(buf, points, n_tan, width, cos)
    }
    #[target_feature(enable = "avx2,fma,f16c")]
    fn activate_256(buf: &mut [f32], points: usize, n_tan: usize, width: usize, cos: &mut [f32]) {
        activate_generic::<Fused>(buf, points, n_tan, width, cos)
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
        // run-time length called memmove once per row: 15% of the time at width 256; an
        // element-wise zip over the fixed-length chunks compiled to 32 scalar moves per row,
        // 20% of the instructions of a 64-wide layer).
        if let (Some(dst), Some(src)) = (dst.first_chunk_mut::<NR>(), src.first_chunk::<NR>()) {
            *dst = src.map(conv);
        } else {
            let (dst, pad) = dst.split_at_mut(src.len());
            dst.iter_mut().zip(src).for_each(|(d, &x)| *d = conv(x));
            pad.fill(0.0);
        }
    }

    /// One packed column panel of Wᵀ as the tiles read it: `kdim × 2·lanes` values at `data`,
    /// the lane masks of the columns that exist, and those columns' bias.
    struct Panel<V, M> {
        data: *const f32,
        masks: [M; 2],
        bias: [V; 2],
    }

    macro_rules! tiled_product {
        ($name:ident, $tile:ident, $step:ident, $feat:literal, $vec:ty, $lanes:literal,
         $mr:literal, $mask:ty, $mask_for:ident, $storec:ident,
         $load:ident, $zero:ident, $set1:ident, $fmadd:ident) => {
            /// Register tile (returns R, the rows it took): rows `r0..r0 + R` × NV vectors of the packed panel's columns,
            /// starting from the panel's bias in the first `bias_rows` rows and from zero in
            /// the others, writing C only where the panel's masks are set (the last panel may
            /// be narrow).
            ///
            /// # Safety
            /// The CPU has the enabled features; `a` holds R rows of `kdim` values, the panel
            /// holds `kdim × NV·lanes` values and `c` R rows of `ldc` values, of which the
            /// masked columns exist.
            #[target_feature(enable = $feat)]
            #[inline]
            unsafe fn $tile<const R: usize, const NV: usize>(
                a: *const f32,
                kdim: usize,
                panel: &Panel<$vec, $mask>,
                c: *mut f32,
                ldc: usize,
                bias_rows: usize,
            ) -> usize {
                let data = panel.data;
                // SAFETY: the caller guarantees every pointer offset below is in bounds.
                unsafe {
                    let mut acc: [[$vec; NV]; R] = core::array::from_fn(|r| {
                        core::array::from_fn(|v| {
                            if r < bias_rows {
                                panel.bias[v]
                            } else {
                                $zero()
                            }
                        })
                    });
                    for k in 0..kdim {
                        let b: [$vec; NV] =
                            core::array::from_fn(|v| $load(data.add((k * NV + v) * $lanes)));
                        for (r, acc_r) in acc.iter_mut().enumerate() {
                            let av = $set1(*a.add(r * kdim + k));
                            for (acc_rv, bv) in acc_r.iter_mut().zip(b) {
                                *acc_rv = $fmadd(av, bv, *acc_rv);
                            }
                        }
                    }
                    for (r, acc_r) in acc.iter().enumerate() {
                        for (v, acc_rv) in acc_r.iter().enumerate() {
                            $storec(c.add(r * ldc + v * $lanes), panel.masks[v], *acc_rv);
                        }
                    }
                }
                R
            }

            /// One tile over the first of the `left` rows at `a` and `c`; returns the rows it
            /// took. One-vector panels take twice the rows: the same accumulator count.
            ///
            /// # Safety
            /// As for the tile, with `left` rows in `a` and `c`.
            #[target_feature(enable = $feat)]
            #[inline]
            unsafe fn $step<const NV: usize>(
                left: usize,
                a: *const f32,
                kdim: usize,
                panel: &Panel<$vec, $mask>,
                c: *mut f32,
                ldc: usize,
                bias_rows: usize,
            ) -> usize {
                let (k, pp, n, nb) = (kdim, panel, ldc, bias_rows);
                // SAFETY: every arm's R is at most `left`.
                unsafe {
                    match left {
                        l if NV == 1 && l >= 2 * $mr => {
                            $tile::<{ 2 * $mr }, NV>(a, k, pp, c, n, nb)
                        }
                        l if l >= $mr => $tile::<$mr, NV>(a, k, pp, c, n, nb),
                        1 => $tile::<1, NV>(a, k, pp, c, n, nb),
                        2 => $tile::<2, NV>(a, k, pp, c, n, nb),
                        3 => $tile::<3, NV>(a, k, pp, c, n, nb),
                        4 => $tile::<4, NV>(a, k, pp, c, n, nb),
                        5 => $tile::<5, NV>(a, k, pp, c, n, nb),
                        6 => $tile::<6, NV>(a, k, pp, c, n, nb),
                        // AVX-512 only (mr = 8): left = 7.
                        _ => $tile::<7, NV>(a, k, pp, c, n, nb),
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
                    // A last panel of at most one vector (e.g. K ≤ 16 output columns) is
                    // packed one vector wide, so no multiply-add runs on padding columns.
                    let narrow = cols <= $lanes;
                    if narrow {
                        pack::<$lanes>(p.b, p.kdim, p.n, j0, cols, panel);
                    } else {
                        pack::<NR>(p.b, p.kdim, p.n, j0, cols, panel);
                    }
                    let mut bias = [0.0f32; NR];
                    bias[..cols].copy_from_slice(&p.bias[j0..j0 + cols]);
                    let packed = Panel {
                        data: panel.as_ptr(),
                        masks: [$mask_for(cols), $mask_for(cols.saturating_sub($lanes))],
                        // SAFETY: `bias` holds NR = 2·lanes values.
                        bias: unsafe { [$load(bias.as_ptr()), $load(bias.as_ptr().add($lanes))] },
                    };
                    let mut r0 = 0;
                    while r0 < p.rows {
                        let left = p.rows - r0;
                        let nb = p.bias_rows.saturating_sub(r0);
                        // SAFETY: `fits` checked A and C hold `rows` rows; a step takes at most
                        // `left` rows, the masks cover only columns j0..j0 + cols <= n, and
                        // the panel holds kdim × NR values (kdim × lanes when narrow).
                        r0 += unsafe {
                            let a = p.a.as_ptr().add(r0 * p.kdim);
                            let cp = c.as_mut_ptr().add(r0 * p.n + j0);
                            if narrow {
                                $step::<1>(left, a, p.kdim, &packed, cp, p.n, nb)
                            } else {
                                $step::<2>(left, a, p.kdim, &packed, cp, p.n, nb)
                            }
                        };
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
    unsafe fn store8(p: *mut f32, m: __m256i, v: __m256) {
        // SAFETY: the caller guarantees the masked lanes are writable.
        unsafe { _mm256_maskstore_ps(p, m, v) }
    }

    tiled_product!(
        product_tiled_avx512,
        tile_avx512,
        step_avx512,
        "avx512f,avx2,fma,f16c",
        __m512,
        16,
        8,
        __mmask16,
        mask16,
        store16,
        _mm512_loadu_ps,
        _mm512_setzero_ps,
        _mm512_set1_ps,
        _mm512_fmadd_ps
    );
    tiled_product!(
        product_tiled_avx2,
        tile_avx2,
        step_avx2,
        "avx2,fma,f16c",
        __m256,
        8,
        6,
        __m256i,
        mask8,
        store8,
        _mm256_loadu_ps,
        _mm256_setzero_ps,
        _mm256_set1_ps,
        _mm256_fmadd_ps
    );
}

/// Every kernel set this CPU can run (an AVX-512 machine also tests the AVX2 kernels).
#[cfg(all(test, feature = "std"))]
pub(crate) fn all_available() -> impl Iterator<Item = Kernels> {
    use crate::cpu::{Avx2, Avx512};
    let avx2 = Avx2::detect().map(|cpu| for_level(Level::Avx2(cpu)));
    let avx512 = Avx512::detect().map(|cpu| for_level(Level::Avx512(cpu)));
    [PORTABLE].into_iter().chain(avx2).chain(avx512)
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
