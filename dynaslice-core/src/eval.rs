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
//! A motion model (f = g(y, t_n) with y = x_n + u(x_n, t_n), [`Model::motion`]) runs the same
//! forward pass twice: u with the tangents the query needs (none, space, or space and time:
//! U, J_u = ∂u/∂x_n, ∂u/∂t_n), then g at (y, t_n) with unit tangents as for a model without
//! motion (∇_y g, ∂g/∂t_n), and combines them at the output by the chain rule:
//!
//! ```text
//! ∇_{x_n} f = (I + J_u)ᵀ ∇_y g,      ∂f/∂t_n = ∇_y g · ∂u/∂t_n + ∂g/∂t_n
//! ```
//!
//! y is clamped to ±[`crate::domain::NORMALISED_LIMIT`] like x_n. A model without motion takes
//! the one-network path unchanged. The cost of a motion model is the sum of both networks'.
//!
//! NaN or infinite inputs propagate: every channel of such a point is NaN (and its label
//! [`crate::UNDEFINED_LABEL`]). Every finite point and time gives finite f, ∇ₓf and ∂f/∂t and a
//! defined label: points far outside the training domain are evaluated like any other (the
//! network extrapolates), up to [`crate::domain::NORMALISED_LIMIT`] half-extents, beyond which
//! the coordinate is clamped ([`crate::Domain::normalise`]); the sine stays bounded for any
//! finite pre-activation ([`crate::sine`]).

use crate::domain::NORMALISED_LIMIT;
use crate::format::{MAX_WIDTH, MOTION_OUTPUTS};
use crate::kernel::{self, widen_into, FirstLayer, Kernels, Product};
use crate::label::argmin_label;
use crate::layout::INPUT_DIM;
use crate::model::{Model, Siren, Weights};
use crate::Error;

/// Rows of one batch block: 64 points for f, 16 points with ∇ₓf (4 rows each), 12 points with
/// ∇ₓf and ∂f/∂t (5 rows each).
pub(crate) const BLOCK_ROWS: usize = 64;
/// Widest packed column panel of the SIMD kernels.
const PANEL_COLS: usize = 32;
/// Outputs of the motion network per row (the displacement's x, y, z).
const MOTION: usize = MOTION_OUTPUTS as usize;
/// Most rows a single point carries: the primal and the tangents along x, y, z and t.
const POINT_ROWS: usize = 5;

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
    /// A motion model's block of motion-network output rows [U; J_u rows (; ∂u/∂t)], kept
    /// while the shape network runs.
    motion: [f32; BLOCK_ROWS * MOTION],
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
            motion: [0.0; BLOCK_ROWS * MOTION],
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

    /// One point through the portable kernels with `ROWS = 1 + tangents` stack rows (the motion
    /// network, if any, runs first in the same rows). Never inlined: inlined into `point`, all
    /// three instances would share the largest frame.
    #[inline(never)]
    fn point_rows<const ROWS: usize>(&self, x: [f32; 3], t: f32, tangents: Tangents, out: Outputs) {
        let mut a = [[0.0f32; MAX_WIDTH]; ROWS];
        let mut b = [[0.0f32; MAX_WIDTH]; ROWS];
        let mut bias = [0.0f32; MAX_WIDTH];
        let mut row = [0.0f32; MAX_WIDTH];
        let mut motion = [0.0f32; POINT_ROWS * MOTION];
        let mut input = [self.domain.normalise(x, t)];
        let warped = self.motion.map(|u| {
            let buffers = Buffers {
                a: a.as_flattened_mut(),
                b: b.as_flattened_mut(),
                panel: &mut [],
                bias: &mut bias,
                row: &mut row,
            };
            let rows = forward(&u, kernel::PORTABLE, &input, tangents, buffers);
            let kept = &mut motion[..rows.len()];
            kept.copy_from_slice(rows);
            warp(&mut input, kept);
            &*kept
        });
        let buffers = Buffers {
            a: a.as_flattened_mut(),
            b: b.as_flattened_mut(),
            panel: &mut [],
            bias: &mut bias,
            row: &mut row,
        };
        let result = forward(&self.shape(), kernel::PORTABLE, &input, tangents, buffers);
        if let Some(motion) = warped {
            chain_rule(result, motion, 1, self.num_classes(), tangents);
        }
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

    /// Runs the model over blocks of points and hands each block's output rows to `sink`
    /// as (index of the block's first point, points in the block, rows). For a motion model
    /// each block runs the motion network, warps its points, runs the shape network and
    /// applies the chain rule.
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
        let shape = self.shape();
        let mut inputs = [[0.0f32; INPUT_DIM]; BLOCK_ROWS];
        let Scratch {
            a,
            b,
            panel,
            bias,
            row,
            motion,
        } = scratch;
        for (block, (xs, ts)) in xyz.chunks(per_block).zip(t.chunks(per_block)).enumerate() {
            let inputs = &mut inputs[..xs.len()];
            for ((input, x), &t) in inputs.iter_mut().zip(xs).zip(ts) {
                *input = self.domain.normalise(*x, t);
            }
            let warped = match &self.motion {
                Some(u) => {
                    let buffers = Buffers {
                        a,
                        b,
                        panel,
                        bias,
                        row,
                    };
                    let rows = forward(u, kernels, inputs, tangents, buffers);
                    let kept = &mut motion[..rows.len()];
                    kept.copy_from_slice(rows);
                    warp(inputs, kept);
                    Some(&*kept)
                }
                None => None,
            };
            let buffers = Buffers {
                a,
                b,
                panel,
                bias,
                row,
            };
            let rows = forward(&shape, kernels, inputs, tangents, buffers);
            if let Some(motion) = warped {
                chain_rule(rows, motion, xs.len(), self.num_classes(), tangents);
            }
            sink(block * per_block, xs.len(), rows);
        }
    }

    /// The displacement u at world point `x` and world time `t`, in world units: the offset
    /// that carries `x` at time `t` to its canonical (reference-shape) position, so that
    /// f(x, t) = g(x + u, t) with g the shape network read in world coordinates. The motion
    /// network gives u_n in normalised coordinates; in world units each axis is u_n times the
    /// domain's scale along it (x_n = (x − c)/s, so a normalised offset u_n is s·u_n in the
    /// world; the clamp of y to ±[`crate::domain::NORMALISED_LIMIT`] is not applied).
    ///
    /// [0, 0, 0] at every finite query of a model without motion; NaN components for a NaN or
    /// infinite point or time, as every other query gives. Evaluated by the portable kernels,
    /// like [`Model::eval`]; it never fails today (the `Result` keeps room for checks).
    pub fn displacement(&self, x: [f32; 3], t: f32) -> Result<[f32; 3], Error> {
        let input = [self.domain.normalise(x, t)];
        let Some(u) = &self.motion else {
            return Ok(no_displacement(&input[0]));
        };
        let mut a = [[0.0f32; MAX_WIDTH]; 1];
        let mut b = [[0.0f32; MAX_WIDTH]; 1];
        let mut bias = [0.0f32; MAX_WIDTH];
        let mut row = [0.0f32; MAX_WIDTH];
        let buffers = Buffers {
            a: a.as_flattened_mut(),
            b: b.as_flattened_mut(),
            panel: &mut [],
            bias: &mut bias,
            row: &mut row,
        };
        let rows = forward(u, kernel::PORTABLE, &input, Tangents::None, buffers);
        let mut out = [[0.0f32; 3]];
        self.world_displacement(rows, &mut out);
        Ok(out[0])
    }

    /// [`Model::displacement`] at many points: `xyz[i]`, `t[i]` → `out[i]`, world units (SIMD
    /// kernels chosen at run time with the `std` feature, as [`Model::eval_batch`]).
    /// `t.len()` and `out.len()` must equal `xyz.len()`.
    pub fn displacement_batch(
        &self,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        out: &mut [[f32; 3]],
    ) -> Result<(), Error> {
        check_len(t.len(), xyz.len())?;
        check_len(out.len(), xyz.len())?;
        self.displacement_blocks(kernel::best(), scratch, xyz, t, out);
        Ok(())
    }

    /// [`Model::displacement_batch`] with the given kernels, blocks of [`BLOCK_ROWS`] points.
    fn displacement_blocks(
        &self,
        kernels: Kernels,
        scratch: &mut Scratch,
        xyz: &[[f32; 3]],
        t: &[f32],
        out: &mut [[f32; 3]],
    ) {
        let mut inputs = [[0.0f32; INPUT_DIM]; BLOCK_ROWS];
        let blocks = xyz.chunks(BLOCK_ROWS).zip(t.chunks(BLOCK_ROWS));
        for ((xs, ts), out) in blocks.zip(out.chunks_mut(BLOCK_ROWS)) {
            let inputs = &mut inputs[..xs.len()];
            for ((input, x), &t) in inputs.iter_mut().zip(xs).zip(ts) {
                *input = self.domain.normalise(*x, t);
            }
            let Some(u) = &self.motion else {
                for (o, input) in out.iter_mut().zip(inputs.iter()) {
                    *o = no_displacement(input);
                }
                continue;
            };
            let buffers = Buffers {
                a: &mut scratch.a,
                b: &mut scratch.b,
                panel: &mut scratch.panel,
                bias: &mut scratch.bias,
                row: &mut scratch.row,
            };
            let rows = forward(u, kernels, inputs, Tangents::None, buffers);
            self.world_displacement(rows, out);
        }
    }

    /// Normalised displacement rows (3 per point) to world units, into `out`.
    fn world_displacement(&self, rows: &[f32], out: &mut [[f32; 3]]) {
        let s = self.domain.scale;
        for (o, u) in out.iter_mut().zip(rows.chunks_exact(MOTION)) {
            *o = core::array::from_fn(|d| s[d] * u[d]);
        }
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

/// One forward pass of the network `net` over `inputs` (normalised) with their tangents;
/// returns the output rows [F; Ḟ_x; Ḟ_y; Ḟ_z (; Ḟ_t)], each `points × outputs`, in normalised
/// units.
///
/// Relies on: `inputs.len() * (1 + tangents) <= rows the buffers hold`, and the network's
/// validated layout (weights hold `param_count` scalars, widths ≤ MAX_WIDTH).
fn forward<'s>(
    net: &Siren,
    kernels: Kernels,
    inputs: &[[f32; INPUT_DIM]],
    tangents: Tangents,
    buf: Buffers<'s>,
) -> &'s mut [f32] {
    let layout = &net.layout;
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
    let w0 = net
        .weights
        .sub(layout.layer_offset(0), (INPUT_DIM + 1) * width);
    let first = FirstLayer {
        w: w0,
        omega_t_max: net.omega_t_max,
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
            net.weights.sub(offset + fan_in * fan_out, fan_out),
            0,
            fan_out,
            bias,
        );
        let product = Product {
            a: &cur[..rows * fan_in],
            rows,
            kdim: fan_in,
            b: net.weights.sub(offset, fan_in * fan_out),
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
    &mut cur[..rows * layout.num_classes()]
}

/// The warp of a motion model: each point's normalised (x_n, t_n) becomes (y, t_n) with
/// y = x_n + u clamped to ±[`NORMALISED_LIMIT`] (so a finite query stays finite however large
/// u is; NaN stays NaN). `motion` starts with the motion network's primal rows (3 per point).
fn warp(inputs: &mut [[f32; INPUT_DIM]], motion: &[f32]) {
    for (input, u) in inputs.iter_mut().zip(motion.chunks_exact(MOTION)) {
        for (y, u) in input.iter_mut().zip(u) {
            *y = (*y + u).clamp(-NORMALISED_LIMIT, NORMALISED_LIMIT);
        }
    }
}

/// The chain rule of a motion model at the output, in normalised units, in place on the shape
/// network's rows [F; G_x; G_y; G_z (; G_t)] (each `points × k`: ∇_y g and ∂g/∂t_n) given the
/// motion network's rows [U; U_x; U_y; U_z (; U_t)] (each `points × 3`: row d holds
/// ∂u_e/∂x_d for e = x, y, z, i.e. column d of J_u):
///
/// ```text
/// ∂f/∂x_d = ∂g/∂y_d + Σ_e ∂u_e/∂x_d · ∂g/∂y_e     ((I + J_u)ᵀ ∇_y g)
/// ∂f/∂t_n = Σ_e ∂g/∂y_e · ∂u_e/∂t_n + ∂g/∂t_n
/// ```
///
/// F is f already (g at the warped point). Fixed work: 3·4 (or 4·4) multiply-adds per point
/// and class.
fn chain_rule(rows: &mut [f32], motion: &[f32], points: usize, k: usize, tangents: Tangents) {
    if tangents == Tangents::None {
        return;
    }
    let (pk, p3) = (points * k, points * MOTION);
    let grads = &mut rows[pk..];
    for p in 0..points {
        // ∂u_e/∂x_d for d < 3, ∂u_e/∂t_n for d = 3.
        let du = |d: usize, e: usize| motion[(1 + d) * p3 + p * MOTION + e];
        for c in 0..k {
            let i = p * k + c;
            let g = [grads[i], grads[pk + i], grads[2 * pk + i]];
            let along = |d: usize| du(d, 0) * g[0] + du(d, 1) * g[1] + du(d, 2) * g[2];
            for (d, &gd) in g.iter().enumerate() {
                grads[d * pk + i] = gd + along(d);
            }
            if tangents == Tangents::SpaceTime {
                grads[3 * pk + i] += along(3);
            }
        }
    }
}

/// A model without motion: u = 0 at a finite normalised query, NaN at a NaN one.
fn no_displacement(input: &[f32; INPUT_DIM]) -> [f32; 3] {
    let zero = if input.iter().all(|v| v.is_finite()) {
        0.0
    } else {
        f32::NAN
    };
    [zero; 3]
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
        // Widths chosen to exercise full tiles, remainder columns and remainder rows; motion
        // models too (their motion networks' 3 outputs are a narrow last panel).
        let none: Option<&[u32]> = None;
        for (widths, k, motion) in [
            (&[64u32, 64, 64][..], 3u32, none),
            (&[40, 37][..], 1, None),
            (&[32][..], 40, None),
            (&[64, 64, 64][..], 3, Some(&[32u32, 32][..])),
            (&[40, 37][..], 2, Some(&[19][..])),
            (&[32][..], 40, Some(&[64, 33, 17][..])),
        ] {
            let bytes = match motion {
                Some(m) => ModelWriter::random_motion(widths, k, m, 11).to_bytes(),
                None => ModelWriter::random_siren(widths, k, 11).to_bytes(),
            };
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
                let (f, g, d) = block_outputs(&model, kernels, &xyz, &t, tangents);
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

    /// The displacement: every batch kernel against the single point, f32 and f16, in world
    /// units (u_n times the domain's scale), and zero for a model without motion.
    #[test]
    fn displacement_batches_match_single_points() {
        let domain = crate::Domain {
            center: [10.0, -20.0, 5.0],
            scale: [70.0, 60.0, 50.0],
            time_origin: 0.2,
            time_span: 0.9,
            output_scale: 70.0,
        };
        for half in [false, true] {
            let mut w = ModelWriter::random_motion(&[16], 2, &[48, 40], 3);
            w.domain = domain;
            if half {
                w.weight_type = WeightType::F16;
            }
            let bytes = w.to_bytes();
            let model = Model::from_bytes(&bytes).unwrap();
            let n = 150; // more than two blocks of 64
            let (unit, s) = points(n);
            let xyz: Vec<[f32; 3]> = unit
                .iter()
                .map(|u| core::array::from_fn(|i| 10.0 + u[i] * 60.0))
                .collect();
            let t: Vec<f32> = s.iter().map(|s| 0.2 + 0.9 * s).collect();
            let want: Vec<[f32; 3]> = xyz
                .iter()
                .zip(&t)
                .map(|(x, &t)| model.displacement(*x, t).unwrap())
                .collect();
            // World units: a few tenths of the normalised cube times the scale.
            let largest = want.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
            assert!(largest > 1.0 && largest < 200.0, "{largest}");
            for kernels in all_available() {
                let mut scratch = Scratch::boxed();
                let mut got = vec![[f32::NAN; 3]; n];
                model.displacement_blocks(kernels, &mut scratch, &xyz, &t, &mut got);
                for (i, (a, b)) in got.iter().flatten().zip(want.iter().flatten()).enumerate() {
                    assert!(
                        (a - b).abs() <= 2e-4 * b.abs().max(60.0),
                        "{} {i}: {a} vs {b}",
                        kernels.name
                    );
                }
            }
            let mut s = Scratch::boxed();
            let mut out = vec![[0.0; 3]; n];
            assert_eq!(
                model.displacement_batch(&mut s, &xyz, &t[..n - 1], &mut out),
                Err(Error::BufferLength {
                    expected: n,
                    got: n - 1
                })
            );
            assert_eq!(
                model.displacement_batch(&mut s, &xyz, &t, &mut out[..n - 1]),
                Err(Error::BufferLength {
                    expected: n,
                    got: n - 1
                })
            );
            // Without motion: zero where the query is finite, NaN where it is not.
            w.motion = None;
            let bytes = w.to_bytes();
            let still = Model::from_bytes(&bytes).unwrap();
            still
                .displacement_batch(&mut s, &xyz, &t, &mut out)
                .unwrap();
            assert!(out.iter().flatten().all(|&v| v == 0.0));
            assert_eq!(still.displacement(xyz[0], t[0]), Ok([0.0; 3]));
            let nan = still.displacement([f32::NAN, 0.0, 0.0], 0.5).unwrap();
            assert!(nan.iter().all(|v| v.is_nan()));
            let nan = model.displacement([0.0; 3], f32::INFINITY).unwrap();
            assert!(nan.iter().all(|v| v.is_nan()));
        }
    }

    /// A motion network whose weights are all zero moves nothing: the motion model answers
    /// exactly as its shape network alone, point and batch, f, ∇ₓf, ∂f/∂t and labels.
    #[test]
    fn zero_motion_is_the_shape_network() {
        let mut w = ModelWriter::random_motion(&[32, 32], 3, &[16, 16], 8);
        if let Some(m) = &mut w.motion {
            m.params.iter_mut().for_each(|v| *v = 0.0);
        }
        let moving = w.to_bytes();
        w.motion = None;
        let still = w.to_bytes();
        let (a, b) = (
            Model::from_bytes(&moving).unwrap(),
            Model::from_bytes(&still).unwrap(),
        );
        assert!(a.motion().is_some() && b.motion().is_none());
        let (xyz, t) = points(40);
        let jacobian = |m: &Model, x: [f32; 3], t: f32| {
            let (mut f, mut g, mut d) = ([0.0; 3], [[0.0; 3]; 3], [0.0; 3]);
            m.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
            (f, g, d, m.label(x, t))
        };
        for (x, &t) in xyz.iter().zip(&t) {
            assert_eq!(jacobian(&a, *x, t), jacobian(&b, *x, t));
        }
        let batch = |m: &Model| {
            let mut s = Scratch::boxed();
            let (mut f, mut g, mut d) = (vec![0.0; 120], vec![[0.0; 3]; 120], vec![0.0; 120]);
            let mut labels = vec![0; 40];
            m.eval_jacobian_batch(&mut s, &xyz, &t, &mut f, &mut g, &mut d)
                .unwrap();
            m.label_batch(&mut s, &xyz, &t, &mut labels).unwrap();
            (f, g, d, labels)
        };
        assert_eq!(batch(&a), batch(&b));
    }

    /// A motion model keeps the promises of a model without motion: NaN in, NaN out (and the
    /// undefined label); every finite query, however far, finite.
    #[test]
    fn motion_queries_are_finite_or_nan() {
        let bytes = ModelWriter::random_motion(&[16, 16], 2, &[8], 3).to_bytes();
        let model = Model::from_bytes(&bytes).unwrap();
        let (mut f, mut g, mut d) = ([0.0; 2], [[0.0; 3]; 2], [0.0; 2]);
        for (x, t) in [
            ([f32::NAN, 0.0, 0.0], 0.0),
            ([0.0; 3], f32::INFINITY),
            ([f32::NEG_INFINITY, 0.0, 0.0], 0.5),
        ] {
            model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
            assert!(f
                .iter()
                .chain(g.iter().flatten())
                .chain(&d)
                .all(|v| v.is_nan()));
            assert_eq!(model.label(x, t), crate::UNDEFINED_LABEL);
        }
        for (x, t) in [
            ([f32::MAX, -f32::MAX, 1e30], -f32::MAX),
            ([1e6, 0.0, -1e6], 1e6),
        ] {
            model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
            assert!(f
                .iter()
                .chain(g.iter().flatten())
                .chain(&d)
                .all(|v| v.is_finite()));
            assert!(model.label(x, t) <= 2);
            assert!(model
                .displacement(x, t)
                .unwrap()
                .iter()
                .all(|v| v.is_finite()));
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
    /// f, ∇ₓf and ∂f/∂t of `model` at every point through `kernels`' block path carrying
    /// `tangents` (the derivatives it does not carry stay zero).
    fn block_outputs(
        model: &Model,
        kernels: Kernels,
        xyz: &[[f32; 3]],
        t: &[f32],
        tangents: Tangents,
    ) -> (Vec<f32>, Vec<[f32; 3]>, Vec<f32>) {
        let n = xyz.len() * model.num_classes();
        let mut scratch = Scratch::boxed();
        let (mut f, mut g, mut d) = (vec![0.0; n], vec![[0.0; 3]; n], vec![0.0; n]);
        model.blocks(
            kernels,
            &mut scratch,
            xyz,
            t,
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
        (f, g, d)
    }

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
                for tangents in [Tangents::None, Tangents::Space, Tangents::SpaceTime] {
                    let (f, g, d) = block_outputs(&model, kernels, &xyz, &t, tangents);
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
