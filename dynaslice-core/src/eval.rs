//! Evaluation of f, ∇ₓf and ∂f/∂t at world points, one at a time or in batches.
//!
//! Derivatives are exact, by forward-mode tangents (never finite differences): each sine layer
//! carries the primal h and its tangents ḣ_d = ∂h/∂u_d for the inputs u_d ∈ {x, y, z, t}:
//!
//! ```text
//! z = Wh + b,   ż_d = W ḣ_d,   h' = sin z,   ḣ'_d = cos z ⊙ ż_d       (Eq. 1)
//! ```
//!
//! with ḣ_d of the input the unit vector e_d, so the first layer's tangents are its weight
//! columns: ω_x for x, y, z and clamp(ω_t, ±ω_t^max) for t (Eq. 2, 4). Rows are stacked as
//! [H; Ḣ_x; Ḣ_y; Ḣ_z (; Ḣ_t)] so that a layer is one matrix product for all of them.
//!
//! Cost per point (multiply-adds): `Layout::macs_per_point()` for f, 4x for f and ∇ₓf, 5x with
//! ∂f/∂t; plus one sine (and one cosine with derivatives) per hidden unit. No query allocates,
//! and the work is fixed by the layout: there are no data-dependent loops.
//!
//! NaN or infinite inputs propagate: every channel of such a point is NaN (and its label
//! [`crate::UNDEFINED_LABEL`]). Every finite point and time gives finite f, ∇ₓf and ∂f/∂t and a
//! defined label: points far outside the training domain are evaluated like any other (the
//! network extrapolates), up to [`crate::domain::NORMALISED_LIMIT`] half-extents, beyond which
//! the coordinate is clamped ([`crate::Domain::normalise`]); the sine stays bounded for any
//! finite pre-activation ([`crate::sine`]).

use crate::format::MAX_WIDTH;
use crate::kernel::{self, widen_into, FirstLayer, Kernels, Product};
use crate::label::argmin_label;
use crate::layout::INPUT_DIM;
use crate::model::{Model, Weights};
use crate::Error;

/// Rows of one batch block: 64 points for f, 16 points with ∇ₓf (4 rows each), 12 points with
/// ∇ₓf and ∂f/∂t (5 rows each).
pub(crate) const BLOCK_ROWS: usize = 64;
/// Widest packed column panel of the SIMD kernels.
const PANEL_COLS: usize = 32;

/// Which derivatives to carry.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Tangents {
    None = 0,
    Space = 3,
    SpaceTime = 4,
}

/// Working memory of the batch functions (≈ 330 KiB for [`MAX_WIDTH`] = 512).
///
/// The core never allocates: put one in a `static` (firmware), in a `Box` ([`Scratch::boxed`]
/// with the `std` feature), or one per thread. Its contents between calls are meaningless.
#[repr(C, align(64))]
pub struct Scratch {
    a: [f32; BLOCK_ROWS * MAX_WIDTH],
    b: [f32; BLOCK_ROWS * MAX_WIDTH],
    panel: [f32; PANEL_COLS * MAX_WIDTH],
    bias: [f32; MAX_WIDTH],
    row: [f32; MAX_WIDTH],
}

// SAFETY: all fields are f32 arrays, for which all-zero bytes are a valid value.
unsafe impl bytemuck::Zeroable for Scratch {}

impl Scratch {
    /// A zeroed scratch (large: place it in a `static` or on a big stack).
    pub const fn new() -> Scratch {
        Scratch {
            a: [0.0; BLOCK_ROWS * MAX_WIDTH],
            b: [0.0; BLOCK_ROWS * MAX_WIDTH],
            panel: [0.0; PANEL_COLS * MAX_WIDTH],
            bias: [0.0; MAX_WIDTH],
            row: [0.0; MAX_WIDTH],
        }
    }

    /// A zeroed scratch on the heap, built in place (never on the stack).
    #[cfg(feature = "std")]
    pub fn boxed() -> std::boxed::Box<Scratch> {
        bytemuck::zeroed_box()
    }
}

impl Default for Scratch {
    fn default() -> Self {
        Scratch::new()
    }
}

/// Borrowed working buffers of one forward pass: the layer inputs and outputs (`a`, `b`), the
/// packed weight panel of the SIMD kernels, the current layer's bias widened to f32, and one
/// row of scratch (the activation's cosines; the portable product's widened weight row).
struct Buffers<'s> {
    a: &'s mut [f32],
    b: &'s mut [f32],
    panel: &'s mut [f32],
    bias: &'s mut [f32],
    row: &'s mut [f32],
}

/// Where a batch writes its answers; `f` is required, derivatives are optional.
pub(crate) struct Outputs<'o> {
    f: &'o mut [f32],
    grad: Option<&'o mut [[f32; 3]]>,
    dfdt: Option<&'o mut [f32]>,
}

impl Model<'_> {
    /// The K signed distances f(x, t) at world point `x` and world time `t`.
    /// `f.len()` must be K.
    pub fn eval(&self, x: [f32; 3], t: f32, f: &mut [f32]) -> Result<(), Error> {
        self.point(x, t, Outputs::new(f, None, None))
    }

    /// f and its exact spatial gradients: `grad[k]` = ∇ₓf^k in world units.
    /// `f.len()` and `grad.len()` must be K.
    pub fn eval_grad(
        &self,
        x: [f32; 3],
        t: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
    ) -> Result<(), Error> {
        self.point(x, t, Outputs::new(f, Some(grad), None))
    }

    /// f, ∇ₓf and ∂f/∂t (world units per world time unit). Every slice must have K entries.
    pub fn eval_jacobian(
        &self,
        x: [f32; 3],
        t: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) -> Result<(), Error> {
        self.point(x, t, Outputs::new(f, Some(grad), Some(dfdt)))
    }

    /// The Eq. 11 label at (x, t): 0 for background, k for class k, or
    /// [`crate::UNDEFINED_LABEL`] for a NaN or infinite query. See [`argmin_label`] for ties.
    pub fn label(&self, x: [f32; 3], t: f32) -> u32 {
        let mut f = [0.0f32; crate::format::MAX_CLASSES];
        let k = self.num_classes();
        match self.eval(x, t, &mut f[..k]) {
            Ok(()) => argmin_label(&f[..k]),
            Err(_) => crate::UNDEFINED_LABEL,
        }
    }

    /// f at many points: `xyz[i]`, `t[i]` → `f[i*K..(i+1)*K]`. The hot path for meshing and
    /// label volumes (SIMD kernels chosen at run time with the `std` feature).
    pub fn eval_batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        f: &mut [f32],
    ) -> Result<(), Error> {
        self.batch(scratch, xyz, t, Outputs::new(f, None, None))
    }

    /// f and ∇ₓf at many points: `grad[i*K + k]` = ∇ₓf^k at point i.
    pub fn eval_grad_batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        f: &mut [f32],
        grad: &mut [[f32; 3]],
    ) -> Result<(), Error> {
        self.batch(scratch, xyz, t, Outputs::new(f, Some(grad), None))
    }

    /// f, ∇ₓf and ∂f/∂t at many points (the surface normal velocity needs all three).
    pub fn eval_jacobian_batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) -> Result<(), Error> {
        self.batch(scratch, xyz, t, Outputs::new(f, Some(grad), Some(dfdt)))
    }

    /// Eq. 11 labels at many points (`labels.len()` = number of points).
    pub fn label_batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        labels: &mut [u32],
    ) -> Result<(), Error> {
        check_len(t.len(), xyz.len())?;
        check_len(labels.len(), xyz.len())?;
        let k = self.num_classes();
        self.blocks(
            kernel::best(),
            scratch,
            xyz,
            t,
            Tangents::None,
            |first, points, out| {
                for (label, f) in labels[first..first + points]
                    .iter_mut()
                    .zip(out.chunks_exact(k))
                {
                    *label = argmin_label(f);
                }
            },
        );
        Ok(())
    }

    fn point(&self, x: [f32; 3], t: f32, out: Outputs) -> Result<(), Error> {
        // The stack buffers are sized by the rows the query needs, so a value-only query
        // reserves 1/5 of what a jacobian does (≈ 8 KiB instead of 24 KiB at MAX_WIDTH).
        match out.check(self.num_classes(), 1)? {
            Tangents::None => self.point_rows::<1>(x, t, Tangents::None, out),
            Tangents::Space => self.point_rows::<4>(x, t, Tangents::Space, out),
            Tangents::SpaceTime => self.point_rows::<5>(x, t, Tangents::SpaceTime, out),
        }
        Ok(())
    }

    /// One point through the portable kernels with `ROWS = 1 + tangents` stack rows. Never
    /// inlined: inlined into `point`, all three instances would share the largest frame.
    #[inline(never)]
    fn point_rows<const ROWS: usize>(&self, x: [f32; 3], t: f32, tangents: Tangents, out: Outputs) {
        let mut a = [[0.0f32; MAX_WIDTH]; ROWS];
        let mut b = [[0.0f32; MAX_WIDTH]; ROWS];
        let mut bias = [0.0f32; MAX_WIDTH];
        let mut row = [0.0f32; MAX_WIDTH];
        let buffers = Buffers {
            a: a.as_flattened_mut(),
            b: b.as_flattened_mut(),
            panel: &mut [],
            bias: &mut bias,
            row: &mut row,
        };
        let input = [self.domain.normalise(x, t)];
        let result = self.forward(kernel::PORTABLE, &input, tangents, buffers);
        self.write_outputs(result, 0, 1, tangents, out);
    }

    fn batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        mut out: Outputs,
    ) -> Result<(), Error> {
        check_len(t.len(), xyz.len())?;
        let tangents = out.check(self.num_classes(), xyz.len())?;
        self.blocks(
            kernel::best(),
            scratch,
            xyz,
            t,
            tangents,
            |first, points, result| {
                self.write_outputs(result, first, points, tangents, out.reborrow());
            },
        );
        Ok(())
    }

    /// Runs the network over blocks of points and hands each block's output rows to `sink`
    /// as (index of the block's first point, points in the block, rows).
    fn blocks(
        &self,
        kernels: Kernels,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        tangents: Tangents,
        mut sink: impl FnMut(usize, usize, &[f32]),
    ) {
        let per_block = BLOCK_ROWS / (1 + tangents as usize);
        let mut inputs = [[0.0f32; INPUT_DIM]; BLOCK_ROWS];
        for (block, (xs, ts)) in xyz.chunks(per_block).zip(t.chunks(per_block)).enumerate() {
            for ((input, x), &t) in inputs.iter_mut().zip(xs).zip(ts) {
                *input = self.domain.normalise(*x, t);
            }
            let buffers = Buffers {
                a: &mut scratch.a,
                b: &mut scratch.b,
                panel: &mut scratch.panel,
                bias: &mut scratch.bias,
                row: &mut scratch.row,
            };
            let rows = self.forward(kernels, &inputs[..xs.len()], tangents, buffers);
            sink(block * per_block, xs.len(), rows);
        }
    }

    /// One forward pass over `inputs` (normalised) with their tangents; returns the output
    /// rows [F; Ḟ_x; Ḟ_y; Ḟ_z (; Ḟ_t)], each `points × K`, in normalised units.
    ///
    /// Relies on: `inputs.len() * (1 + tangents) <= rows the buffers hold`, and the model's
    /// validated layout (weights hold `param_count` scalars, widths ≤ MAX_WIDTH).
    fn forward<'s>(
        &self,
        kernels: Kernels,
        inputs: &[[f32; INPUT_DIM]],
        tangents: Tangents,
        buf: Buffers<'s>,
    ) -> &'s [f32] {
        let layout = &self.layout;
        let points = inputs.len();
        let n_tan = tangents as usize;
        let rows = points * (1 + n_tan);
        let Buffers {
            a,
            b,
            panel,
            bias,
            row,
        } = buf;
        let (mut cur, mut next) = (a, b);

        // First sine layer (Eq. 2, 4): z = ω_x x + clamp(ω_t) t + φ, tangents = its columns.
        let (_, width) = layout.layer_dims(0);
        let w0 = self
            .weights
            .sub(layout.layer_offset(0), (INPUT_DIM + 1) * width);
        let first = FirstLayer {
            w: w0,
            omega_t_max: self.omega_t_max,
            inputs,
            n_tan,
            width,
        };
        (kernels.first_layer)(&first, cur);
        (kernels.activate)(&mut cur[..rows * width], points, n_tan, width, row);

        // Hidden sine layers, then the affine output layer.
        for l in 1..layout.num_layers() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let offset = layout.layer_offset(l);
            let bias = weight_row(
                self.weights.sub(offset + fan_in * fan_out, fan_out),
                0,
                fan_out,
                bias,
            );
            let product = Product {
                a: &cur[..rows * fan_in],
                rows,
                kdim: fan_in,
                b: self.weights.sub(offset, fan_in * fan_out),
                n: fan_out,
                bias,
                bias_rows: points,
            };
            (kernels.product)(&product, next, panel, row);
            if l < layout.num_sine_layers() {
                (kernels.activate)(&mut next[..rows * fan_out], points, n_tan, fan_out, row);
            }
            core::mem::swap(&mut cur, &mut next);
        }
        &cur[..rows * layout.num_classes()]
    }

    /// Scales one block's output rows to world units and stores them from point `first` on.
    fn write_outputs(
        &self,
        rows: &[f32],
        first: usize,
        points: usize,
        tangents: Tangents,
        out: Outputs,
    ) {
        let k = self.num_classes();
        let factors = self.domain.derivative_factors();
        let sigma = self.domain.output_scale;
        let group = |d: usize| &rows[d * points * k..(d + 1) * points * k];
        for (dst, src) in out.f[first * k..(first + points) * k]
            .iter_mut()
            .zip(group(0))
        {
            *dst = sigma * src;
        }
        if let Some(grad) = out.grad {
            for (i, g) in grad[first * k..(first + points) * k].iter_mut().enumerate() {
                *g = core::array::from_fn(|d| factors[d] * group(1 + d)[i]);
            }
        }
        if let (Some(dfdt), Tangents::SpaceTime) = (out.dfdt, tangents) {
            for (dst, src) in dfdt[first * k..(first + points) * k]
                .iter_mut()
                .zip(group(4))
            {
                *dst = factors[3] * src;
            }
        }
    }
}

impl<'o> Outputs<'o> {
    /// The buffers of one query: `f` always, each derivative where the caller asks for it.
    #[inline]
    fn new(
        f: &'o mut [f32],
        grad: Option<&'o mut [[f32; 3]]>,
        dfdt: Option<&'o mut [f32]>,
    ) -> Outputs<'o> {
        Outputs { f, grad, dfdt }
    }

    /// Checks every buffer holds `points · K` entries; returns the tangents they need.
    fn check(&self, k: usize, points: usize) -> Result<Tangents, Error> {
        let n = points.checked_mul(k).ok_or(Error::BufferLength {
            expected: usize::MAX,
            got: 0,
        })?;
        check_len(self.f.len(), n)?;
        if let Some(g) = &self.grad {
            check_len(g.len(), n)?;
        }
        if let Some(d) = &self.dfdt {
            check_len(d.len(), n)?;
            return Ok(Tangents::SpaceTime);
        }
        Ok(if self.grad.is_some() {
            Tangents::Space
        } else {
            Tangents::None
        })
    }

    fn reborrow(&mut self) -> Outputs<'_> {
        Outputs::new(self.f, self.grad.as_deref_mut(), self.dfdt.as_deref_mut())
    }
}

fn check_len(got: usize, expected: usize) -> Result<(), Error> {
    if got == expected {
        Ok(())
    } else {
        Err(Error::BufferLength { expected, got })
    }
}

/// Row `r` (of `len` scalars) of a weight block, copied to f32 in `tmp`.
fn weight_row<'t>(w: Weights, r: usize, len: usize, tmp: &'t mut [f32]) -> &'t [f32] {
    let out = &mut tmp[..len];
    widen_into(w.sub(r * len, len), out);
    out
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::format::{ModelWriter, WeightType};
    use crate::kernel::all_available;
    use std::{vec, vec::Vec};

    fn points(n: usize) -> (Vec<[f32; 3]>, Vec<f32>) {
        let xyz = (0..n).map(|i| {
            let s = i as f32 * 0.618;
            [s.sin() * 0.9, (1.3 * s).cos() * 0.8, (0.7 * s).sin() * 0.95]
        });
        (
            xyz.collect(),
            (0..n).map(|i| (i as f32 * 0.37).fract()).collect(),
        )
    }

    /// Every kernel's batch jacobian equals the single-point path. Both sum the same products
    /// in a different order (and the SIMD kernels fuse multiply-adds), so they agree to a few
    /// f32 ulps of the accumulated magnitudes: 2e-4 relative to max(1, |value|) is ample for
    /// these width-≤64 networks and far below any real discrepancy (a wrong index changes
    /// values by O(1)).
    #[test]
    fn batch_kernels_match_single_points() {
        // Widths chosen to exercise full tiles, remainder columns and remainder rows.
        for (widths, k) in [
            (&[64u32, 64, 64][..], 3u32),
            (&[40, 37][..], 1),
            (&[32][..], 40),
        ] {
            let bytes = ModelWriter::random_siren(widths, k, 11).to_bytes();
            let model = Model::from_bytes(&bytes).unwrap();
            let k = k as usize;
            let n = 77; // not a multiple of any block size
            let (xyz, t) = points(n);
            let mut want = (Vec::new(), Vec::new(), Vec::new());
            for (x, &t) in xyz.iter().zip(&t) {
                let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
                model.eval_jacobian(*x, t, &mut f, &mut g, &mut d).unwrap();
                want.0.extend(f);
                want.1.extend(g.iter().flatten().copied());
                want.2.extend(d);
            }
            // Every row count per block (64, 16·4, 12·5) and its remainder (77 points).
            let modes = [Tangents::None, Tangents::Space, Tangents::SpaceTime];
            for (kernels, tangents) in all_available().flat_map(|k| modes.map(|m| (k, m))) {
                let mut scratch = Scratch::boxed();
                let (mut f, mut g, mut d) =
                    (vec![0.0; n * k], vec![[0.0; 3]; n * k], vec![0.0; n * k]);
                model.blocks(
                    kernels,
                    &mut scratch,
                    &xyz,
                    &t,
                    tangents,
                    |first, points, rows| {
                        let out = Outputs {
                            f: &mut f,
                            grad: (tangents != Tangents::None).then_some(&mut g[..]),
                            dfdt: (tangents == Tangents::SpaceTime).then_some(&mut d[..]),
                        };
                        model.write_outputs(rows, first, points, tangents, out);
                    },
                );
                let got_g: Vec<f32> = g.iter().flatten().copied().collect();
                let checks = [
                    ("f", &f, &want.0),
                    ("grad", &got_g, &want.1),
                    ("dfdt", &d, &want.2),
                ];
                let outputs = match tangents {
                    Tangents::None => 1,
                    Tangents::Space => 2,
                    Tangents::SpaceTime => 3,
                };
                for (name, got, want) in checks.into_iter().take(outputs) {
                    for (i, (a, b)) in got.iter().zip(want.iter()).enumerate() {
                        assert!(
                            (a - b).abs() <= 2e-4 * b.abs().max(1.0),
                            "{} {name}[{i}]: {a} vs {b}",
                            kernels.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn public_batch_forms_agree_with_each_other() {
        let bytes = ModelWriter::random_siren(&[48, 48], 2, 5).to_bytes();
        let model = Model::from_bytes(&bytes).unwrap();
        let (xyz, t) = points(50);
        let mut s = Scratch::boxed();
        let mut f1 = vec![0.0; 100];
        let (mut f2, mut g2) = (vec![0.0; 100], vec![[0.0; 3]; 100]);
        let mut labels = vec![0u32; 50];
        model.eval_batch(&mut s, &xyz, &t, &mut f1).unwrap();
        model
            .eval_grad_batch(&mut s, &xyz, &t, &mut f2, &mut g2)
            .unwrap();
        model.label_batch(&mut s, &xyz, &t, &mut labels).unwrap();
        for i in 0..50 {
            assert!((f1[2 * i] - f2[2 * i]).abs() < 1e-4);
            assert_eq!(labels[i], crate::argmin_label(&f1[2 * i..2 * i + 2]));
        }
        assert_eq!(
            model.eval_batch(&mut s, &xyz, &t[..49], &mut f1),
            Err(Error::BufferLength {
                expected: 50,
                got: 49
            })
        );
        assert_eq!(
            model.eval_batch(&mut s, &xyz, &t, &mut f1[..99]),
            Err(Error::BufferLength {
                expected: 100,
                got: 99
            })
        );
    }

    #[test]
    fn non_finite_queries_give_nan() {
        let bytes = ModelWriter::random_siren(&[16, 16], 2, 3).to_bytes();
        let model = Model::from_bytes(&bytes).unwrap();
        for (x, t) in [
            ([f32::NAN, 0.0, 0.0], 0.0),
            ([0.0; 3], f32::INFINITY),
            ([f32::NEG_INFINITY, 0.0, 0.0], 0.5),
        ] {
            let (mut f, mut g) = ([0.0; 2], [[0.0; 3]; 2]);
            model.eval_grad(x, t, &mut f, &mut g).unwrap();
            assert!(f.iter().all(|v| v.is_nan()), "{x:?} {t}: {f:?}");
            assert!(g.iter().flatten().all(|v| v.is_nan()));
            assert_eq!(model.label(x, t), crate::UNDEFINED_LABEL);
        }
        let mut short = [0.0; 1];
        assert_eq!(
            model.eval([0.0; 3], 0.0, &mut short),
            Err(Error::BufferLength {
                expected: 2,
                got: 1
            })
        );
    }

    /// FNV-1a over the bits of every value, to pin answers exactly.
    fn fnv(values: impl IntoIterator<Item = u32>) -> u64 {
        values.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, v| {
            v.to_le_bytes()
                .iter()
                .fold(h, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
        })
    }

    /// The files and answers of models without motion, pinned bit for bit as the code before
    /// motion models wrote and gave them (the point path everywhere; each batch kernel on a CPU
    /// that has it), for f32 and f16 weights: such a model is still a version-1 file and takes
    /// exactly the old code path.
    #[test]
    fn answers_without_motion_are_pinned() {
        let mut got = Vec::new();
        for (widths, k, half) in [
            (&[64u32, 64, 64][..], 3u32, false),
            (&[40, 37][..], 2, true),
        ] {
            let mut w = ModelWriter::random_siren(widths, k, 23);
            w.domain = crate::Domain {
                center: [10.0, -20.0, 5.0],
                scale: [70.0, 60.0, 50.0],
                time_origin: 0.2,
                time_span: 0.9,
                output_scale: 70.0,
            };
            if half {
                w.weight_type = WeightType::F16;
            }
            let bytes = w.to_bytes();
            got.push(("file", fnv(bytes.iter().map(|&b| b as u32))));
            let model = Model::from_bytes(&bytes).unwrap();
            let k = k as usize;
            let n = 29;
            let (unit, s) = points(n);
            let xyz: Vec<[f32; 3]> = unit
                .iter()
                .map(|u| core::array::from_fn(|i| 10.0 + u[i] * 70.0))
                .collect();
            let t: Vec<f32> = s.iter().map(|s| 0.2 + 0.9 * s).collect();
            let mut bits = Vec::new();
            for (x, &t) in xyz.iter().zip(&t) {
                let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
                model.eval_jacobian(*x, t, &mut f, &mut g, &mut d).unwrap();
                bits.extend(
                    f.iter()
                        .chain(g.iter().flatten())
                        .chain(&d)
                        .map(|v| v.to_bits()),
                );
                bits.push(model.label(*x, t));
            }
            got.push(("point", fnv(bits)));
            for kernels in all_available() {
                let mut scratch = Scratch::boxed();
                let (mut f, mut g, mut d) =
                    (vec![0.0; n * k], vec![[0.0; 3]; n * k], vec![0.0; n * k]);
                for tangents in [Tangents::None, Tangents::Space, Tangents::SpaceTime] {
                    model.blocks(
                        kernels,
                        &mut scratch,
                        &xyz,
                        &t,
                        tangents,
                        |first, points, rows| {
                            let out = Outputs {
                                f: &mut f,
                                grad: (tangents != Tangents::None).then_some(&mut g[..]),
                                dfdt: (tangents == Tangents::SpaceTime).then_some(&mut d[..]),
                            };
                            model.write_outputs(rows, first, points, tangents, out);
                        },
                    );
                    let bits = f.iter().chain(g.iter().flatten()).chain(&d);
                    got.push((kernels.name, fnv(bits.map(|v| v.to_bits()))));
                }
            }
        }
        // Computed by the code before motion models (commit 1566996); avx2 and avx512 happen
        // to agree bit for bit at these widths.
        let pinned: [(&str, u64); 22] = [
            ("file", 0x4213_2ffa_6f70_7694),
            ("point", 0xadd2_492e_b74f_3859),
            ("portable", 0x0abf_7f31_3832_f5b7),
            ("portable", 0xaeb8_d973_5e84_da88),
            ("portable", 0x87cc_346b_d2c0_f0ed),
            ("avx2", 0xf922_6552_729c_5c1d),
            ("avx2", 0x7199_70d6_0c82_725c),
            ("avx2", 0x6c88_bffb_0d33_5a76),
            ("avx512", 0xf922_6552_729c_5c1d),
            ("avx512", 0x7199_70d6_0c82_725c),
            ("avx512", 0x6c88_bffb_0d33_5a76),
            ("file", 0x0e9a_29b8_7267_90b6),
            ("point", 0x68b1_bebc_d7b4_7a3e),
            ("portable", 0xb1f4_d318_7af5_1f33),
            ("portable", 0x32d5_322e_a5ce_b1d2),
            ("portable", 0xcbda_6998_52dd_7ee5),
            ("avx2", 0x045d_ae51_6120_27e5),
            ("avx2", 0xfecc_7844_5851_59c0),
            ("avx2", 0x420b_9830_41b7_1b16),
            ("avx512", 0x045d_ae51_6120_27e5),
            ("avx512", 0xfecc_7844_5851_59c0),
            ("avx512", 0x420b_9830_41b7_1b16),
        ];
        let available: Vec<&str> = all_available().map(|k| k.name).collect();
        let want: Vec<(&str, u64)> = pinned
            .into_iter()
            .filter(|(name, _)| ["file", "point"].contains(name) || available.contains(name))
            .collect();
        assert_eq!(got, want);
    }

    /// Half-precision storage: the error of f against the f32 model, reported in
    /// docs/model-format.md. f16 has an 11-bit significand (relative rounding ≤ 4.9e-4), and a
    /// SIREN's output sums many such products, so |Δf| stays within ~1e-2 of an O(1) output.
    #[test]
    fn f16_round_trip_and_error() {
        let mut w = ModelWriter::random_siren(&[256, 256, 256, 256], 1, 9);
        let exact = w.to_bytes();
        w.weight_type = WeightType::F16;
        let half = w.to_bytes();
        assert!(half.len() < exact.len() * 51 / 100 + 2048);
        let (m32, m16) = (
            Model::from_bytes(&exact).unwrap(),
            Model::from_bytes(&half).unwrap(),
        );
        assert_eq!(
            ModelWriter::from_model(&m16).to_bytes(),
            half,
            "f16 files round-trip bit for bit"
        );
        let (xyz, t) = points(2000);
        let mut s = Scratch::boxed();
        let (mut a, mut b) = (vec![0.0; 2000], vec![0.0; 2000]);
        m32.eval_batch(&mut s, &xyz, &t, &mut a).unwrap();
        m16.eval_batch(&mut s, &xyz, &t, &mut b).unwrap();
        let max = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        let rms = (a.iter().map(|x| x * x).sum::<f32>() / 2000.0).sqrt();
        std::println!("f16 vs f32: max |Δf| = {max:.3e}, rms |f| = {rms:.3e}");
        assert!(max < 2e-2 * rms.max(1.0), "max |Δf| {max}");
    }
}
