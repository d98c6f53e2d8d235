//! Hand-written forward and backward passes of the network over a batch, with forward-mode
//! spatial tangents, so that losses on f and on ∇ₓf have exact parameter gradients.
//!
//! Rows are stacked as S = [H; Ḣ₁; …; Ḣ_T] (the primal, then one group per tangent), so every
//! layer is one matrix product forward and two backward:
//!
//! ```text
//! forward   Z = S Wᵀ (+ b on the primal rows)          H' = sin Z_p,  Ḣ'_d = cos Z_p ⊙ Ż_d
//! backward  Ḡ_Zp = cos Z_p ⊙ Ḡ_H' − sin Z_p ⊙ Σ_d Ż_d ⊙ Ḡ_Ḣ'd,    Ḡ_Żd = cos Z_p ⊙ Ḡ_Ḣ'd
//!           ∂Wᵀ += Sᵀ Ḡ_Z,   ∂b += Σ_rows Ḡ_Zp,   Ḡ_S = Ḡ_Z W
//! ```
//!
//! Cost, with M one layer's product over the N primal rows: (1 + T)M forward and 2(1 + T)M
//! backward, i.e. 3(1 + T)M per point. The trainer picks T per point set ([`Tangents`]):
//! - plane samples need f only: T = 0, **3M**;
//! - contour points need f^k and only ⟨∇ₓf^k, n⟩ (Eq. 6 is a directional derivative along the
//!   in-plane normal): T = 1 along n, **6M** — what reverse over reverse would cost for their
//!   one channel, in one stacked pass — or 4M for those whose orientation hinge is inactive
//!   (see [`Workspace::backward`]);
//! - space-time samples need the whole ∇ₓf^k of every channel (Eq. 8): T = 3 axes, **12M**
//!   whatever K is. Reverse over reverse ([`super::reverse_over_reverse`]) costs (3 + 3K)M
//!   instead, so the trainer uses it for K ≤ 2 and this scheme from K = 3 on
//!   ([`super::objective::SpaceTimeScheme::cheapest`]; step times of both in
//!   docs/performance.md).
//!
//! The first layer's input tangent for direction u is Σ_d u_d e_d, so Ż₀ = Σ_d u_d·(row d of W₀ᵀ)
//! (for the axes, row d of W₀ᵀ itself, i.e. ω_x; for time, the ω_t row), and its weight gradient
//! gets Σ_rows u_d Ḡ_Ż₀ added to row d.

use super::matmul::{matmul, Mat, Op};
use super::network::Network;
use super::simd::multiversion;
use dynaslice_core::sine::sin_cos_with;

/// Inputs of the first layer: normalised x, y, z, t.
pub const INPUT_DIM: usize = 4;

/// The spatial tangents a pass carries.
#[derive(Clone, Copy, Debug)]
pub enum Tangents<'a> {
    /// None: f only.
    None,
    /// ∂/∂x, ∂/∂y, ∂/∂z: the full spatial gradient, in three tangent groups.
    Axes,
    /// One directional derivative per point, along the given vector (one tangent group).
    Along(&'a [[f32; 3]]),
    /// ∂/∂t (one tangent group): a motion's velocity (`crate::warp`).
    Time,
}

impl Tangents<'_> {
    /// Number of tangent groups T.
    pub fn count(&self) -> usize {
        match self {
            Tangents::None => 0,
            Tangents::Axes => 3,
            Tangents::Along(_) | Tangents::Time => 1,
        }
    }

    /// Component `d` (x, y, z, t) of tangent group `group`'s input direction at point `i`.
    fn component(&self, group: usize, i: usize, d: usize) -> f32 {
        match self {
            Tangents::None => 0.0,
            Tangents::Axes => (group == d) as u8 as f32,
            Tangents::Along(u) => u[i].get(d).copied().unwrap_or(0.0),
            Tangents::Time => (d == 3) as u8 as f32,
        }
    }
}

/// Buffers of one forward/backward pass over up to `capacity` points; allocated once and
/// reused every step (no allocation per step).
pub struct Workspace {
    capacity: usize,
    tangents: usize,
    /// Per sine layer: stacked pre-activations Z (primal rows, then tangent rows Ż).
    z: Vec<Vec<f32>>,
    /// Per sine layer: stacked activations S = [sin Z_p; cos Z_p ⊙ Ż].
    s: Vec<Vec<f32>>,
    /// Per sine layer: cos Z_p.
    cos: Vec<Vec<f32>>,
    /// Stacked outputs [F; Ḟ₁; Ḟ₂; Ḟ₃], each `points × K`.
    out: Vec<f32>,
    /// Gradient buffers for the backward pass (the widest stacked layer).
    g_a: Vec<f32>,
    g_b: Vec<f32>,
    /// Points whose tangent rows the backward pass keeps (see [`Workspace::backward`]).
    kept: Vec<usize>,
}

impl Workspace {
    /// Buffers for `capacity` points carrying `tangents` tangent groups (see [`Tangents::count`]).
    pub fn new(net: &Network, capacity: usize, tangents: usize) -> Workspace {
        assert!(tangents <= 3, "at most 3 tangent groups");
        let rows = capacity * (1 + tangents);
        let layout = &net.layout;
        let widest = layout.max_width();
        Workspace {
            capacity,
            tangents,
            z: per_layer(net, rows),
            s: per_layer(net, rows),
            cos: per_layer(net, capacity),
            out: vec![0.0; rows * layout.num_classes()],
            g_a: vec![0.0; rows * widest],
            g_b: vec![0.0; rows * widest],
            kept: Vec::with_capacity(capacity),
        }
    }

    /// Stacked outputs of the last forward pass over `points` points: rows `0..points` are f,
    /// rows `points·(1+d)..points·(2+d)` are ∂f/∂x_d (normalised units), each K wide.
    pub fn outputs(&self, points: usize) -> &[f32] {
        &self.out[..points * (1 + self.tangents) * self.out_width()]
    }

    fn out_width(&self) -> usize {
        self.out.len() / (self.capacity * (1 + self.tangents)).max(1)
    }

    /// Forward pass over `inputs` (normalised (x, y, z, t) per point) carrying `tangents`,
    /// which must have this workspace's tangent count (and one direction per point).
    pub fn forward(&mut self, net: &Network, inputs: &[[f32; INPUT_DIM]], tangents: Tangents) {
        let n = inputs.len();
        check_capacity(n, self.capacity);
        check_tangents(tangents, self.tangents, n);
        let layout = &net.layout;
        let t = self.tangents;
        let rows = n * (1 + t);
        let p = &net.params;

        // Layer 0 (Eq. 2): Z_p = X W₀ᵀ + φ; Ż_d = row d of W₀ᵀ.
        let (_, w0) = layout.layer_dims(0);
        let wt0 = &p[..INPUT_DIM * w0];
        let z0 = &mut self.z[0];
        input_layer(net, inputs, &mut z0[..n * w0]);
        for g in 0..t {
            let group = &mut z0[(1 + g) * n * w0..(2 + g) * n * w0];
            for (i, row) in group.chunks_exact_mut(w0).enumerate() {
                row.fill(0.0);
                for d in 0..INPUT_DIM {
                    let u = tangents.component(g, i, d);
                    if u != 0.0 {
                        let w = &wt0[d * w0..(d + 1) * w0];
                        row.iter_mut().zip(w).for_each(|(r, w)| *r += u * w);
                    }
                }
            }
        }
        activate(
            &self.z[0][..rows * w0],
            &mut self.s[0][..rows * w0],
            &mut self.cos[0][..n * w0],
            n,
            t,
            w0,
        );

        for l in 1..layout.num_layers() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let off = layout.layer_offset(l);
            let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
            let bias = &p[off + fan_in * fan_out..off + (fan_in + 1) * fan_out];
            let input = Mat::new(&self.s[l - 1][..rows * fan_in], rows, fan_in);
            let is_output = l == layout.num_sine_layers();
            let z = if is_output {
                &mut self.out[..rows * fan_out]
            } else {
                &mut self.z[l][..rows * fan_out]
            };
            matmul(z, false, input, Op::N, wt, Op::N);
            add_bias(&mut z[..n * fan_out], bias);
            if !is_output {
                activate(
                    &self.z[l][..rows * fan_out],
                    &mut self.s[l][..rows * fan_out],
                    &mut self.cos[l][..n * fan_out],
                    n,
                    t,
                    fan_out,
                );
            }
        }
    }

    /// Backward pass for the last forward over `points` points: `g_out` holds ∂loss/∂(stacked
    /// outputs) in the layout of [`Workspace::outputs`]; parameter gradients are added to
    /// `grad` (same order as the parameters). It consumes the forward's state: call
    /// [`Workspace::forward`] again before another backward.
    ///
    /// A point whose tangent outputs all have a zero adjoint (a contour point whose orientation
    /// hinge, Eq. 6, is inactive) contributes exactly nothing through its tangent rows:
    /// Ḡ_Ż = cos Z ⊙ Ḡ_Ḣ stays zero down the network, and so does −sin Z ⊙ Ż ⊙ Ḡ_Ḣ. Such rows
    /// are dropped from every product, so the backward costs 2(1 + T·m/N)M instead of
    /// 2(1 + T)M for m kept points out of N.
    pub fn backward(
        &mut self,
        net: &Network,
        inputs: &[[f32; INPUT_DIM]],
        tangents: Tangents,
        g_out: &[f32],
        grad: &mut [f32],
    ) {
        let n = inputs.len();
        check_tangents(tangents, self.tangents, n);
        let layout = &net.layout;
        let t = self.tangents;
        let p = &net.params;
        let k = layout.num_classes();
        assert!(g_out.len() >= n * (1 + t) * k && grad.len() == p.len());
        let m = self.keep_tangent_rows(net, n, g_out);
        let rows = n + t * m;

        // Ḡ flows from layer l to l−1 through g_a (current) and g_b (next).
        let mut g_cur = std::mem::take(&mut self.g_a);
        let mut g_next = std::mem::take(&mut self.g_b);
        g_cur[..n * k].copy_from_slice(&g_out[..n * k]);
        for g in 0..t {
            for (j, &i) in self.kept.iter().enumerate() {
                let src = ((1 + g) * n + i) * k;
                let dst = (n + g * m + j) * k;
                g_cur[dst..dst + k].copy_from_slice(&g_out[src..src + k]);
            }
        }
        for l in (0..layout.num_layers()).rev() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let off = layout.layer_offset(l);
            if l < layout.num_sine_layers() {
                // Through the sine: Ḡ_Ḣ' (in g_cur) → Ḡ_Z (in place).
                sine_backward(
                    &mut g_cur[..rows * fan_out],
                    &self.z[l],
                    &self.s[l],
                    &self.cos[l],
                    n,
                    fan_out,
                    &self.kept,
                );
            }
            let g_z = Mat::new(&g_cur[..rows * fan_out], rows, fan_out);
            let (gw, gb) = grad[off..off + (fan_in + 1) * fan_out].split_at_mut(fan_in * fan_out);
            add_row_sums(gb, &g_cur[..n * fan_out]);
            if l == 0 {
                // ∂W₀ᵀ = Xᵀ Ḡ_Zp + Σ_g Σ_rows u_g,d Ḡ_Ż_g on row d (u: the input directions).
                input_layer_weight_grad(inputs, &g_cur[..n * fan_out], gw);
                for g in 0..t {
                    let group = &g_cur[(n + g * m) * fan_out..(n + (g + 1) * m) * fan_out];
                    for (&i, grow) in self.kept.iter().zip(group.chunks_exact(fan_out)) {
                        for d in 0..INPUT_DIM {
                            let u = tangents.component(g, i, d);
                            if u != 0.0 {
                                let row = &mut gw[d * fan_out..(d + 1) * fan_out];
                                row.iter_mut().zip(grow).for_each(|(a, b)| *a += u * b);
                            }
                        }
                    }
                }
            } else {
                let input = Mat::new(&self.s[l - 1][..rows * fan_in], rows, fan_in);
                let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
                product_backward(input, g_z, wt, gw, &mut g_next[..rows * fan_in]);
                std::mem::swap(&mut g_cur, &mut g_next);
            }
        }
        self.g_a = g_cur;
        self.g_b = g_next;
    }

    /// The adjoints of the last backward pass's inputs, for a network whose input is itself
    /// computed (the motion model's warped point, `crate::warp`): with Z₀ = X W₀ᵀ + φ and
    /// Ż₀ = Σ_d u_d (row d of W₀ᵀ), ∂loss/∂x_d = ⟨row d of W₀ᵀ, Ḡ_Zp⟩ and ∂loss/∂u_d =
    /// ⟨row d of W₀ᵀ, Ḡ_Ż⟩, read from the layer-0 adjoints the pass leaves in its buffer.
    /// `g_x[i]` gets the spatial part (x, y, z) of point i's input adjoint; with one tangent
    /// group, `g_dir[i]` gets the adjoint of its direction (zero where the pass dropped the
    /// point's tangent rows, whose adjoint was zero).
    pub fn input_adjoints(
        &self,
        net: &Network,
        n: usize,
        g_x: &mut [[f32; 3]],
        g_dir: Option<&mut [[f32; 3]]>,
    ) {
        let (_, w0) = net.layout.layer_dims(0);
        let wt0 = &net.params[..INPUT_DIM * w0];
        let dot = |d: usize, row: &[f32]| -> f32 {
            wt0[d * w0..(d + 1) * w0]
                .iter()
                .zip(row)
                .map(|(a, b)| a * b)
                .sum()
        };
        for (gx, row) in g_x[..n].iter_mut().zip(self.g_a.chunks_exact(w0)) {
            *gx = std::array::from_fn(|d| dot(d, row));
        }
        if let Some(g_dir) = g_dir {
            assert_eq!(
                self.tangents, 1,
                "a direction's adjoint needs one tangent group"
            );
            g_dir[..n].fill([0.0; 3]);
            let group = &self.g_a[n * w0..(n + self.kept.len()) * w0];
            for (&i, row) in self.kept.iter().zip(group.chunks_exact(w0)) {
                g_dir[i] = std::array::from_fn(|d| dot(d, row));
            }
        }
    }

    /// Points whose tangent rows the last backward pass kept (all of them with no tangents).
    pub fn kept_points(&self) -> usize {
        self.kept.len()
    }

    /// Fills `kept` with the points whose tangent outputs have a nonzero adjoint in `g_out`
    /// and, when some are dropped, moves their tangent rows of every layer's Z and S to the
    /// front of each tangent group (group g's kept row j at n + g·m + j). Returns m.
    fn keep_tangent_rows(&mut self, net: &Network, n: usize, g_out: &[f32]) -> usize {
        let t = self.tangents;
        let k = net.layout.num_classes();
        self.kept.clear();
        let carries = |i: usize| {
            (0..t).any(|g| {
                let start = ((1 + g) * n + i) * k;
                g_out[start..start + k].iter().any(|&v| v != 0.0)
            })
        };
        self.kept.extend((0..n).filter(|&i| carries(i)));
        let m = self.kept.len();
        if m < n {
            // Destination rows never pass their source (j ≤ kept[j], m ≤ n), and groups move in
            // order, so copying forward in place reads every source row before it is overwritten.
            for (l, &w) in net.layout.widths().iter().enumerate() {
                for buf in [&mut self.z[l], &mut self.s[l]] {
                    for g in 0..t {
                        for (j, &i) in self.kept.iter().enumerate() {
                            let (src, dst) = ((n + g * n + i) * w, (n + g * m + j) * w);
                            buf.copy_within(src..src + w, dst);
                        }
                    }
                }
            }
        }
        m
    }
}

/// Z₀ = X W₀ᵀ + φ over the primal rows (Eq. 2): `z` is `inputs.len() × w₀`. The stored ω_t are
/// already inside their bound (the trainer clamps them after every step, Eq. 4).
pub(super) fn input_layer(net: &Network, inputs: &[[f32; INPUT_DIM]], z: &mut [f32]) {
    let (_, w0) = net.layout.layer_dims(0);
    let wt0 = &net.params[..INPUT_DIM * w0];
    let b0 = &net.params[INPUT_DIM * w0..(INPUT_DIM + 1) * w0];
    for (zrow, x) in z.chunks_exact_mut(w0).zip(inputs) {
        zrow.copy_from_slice(b0);
        for (d, &xd) in x.iter().enumerate() {
            for (zv, wv) in zrow.iter_mut().zip(&wt0[d * w0..(d + 1) * w0]) {
                *zv += xd * wv;
            }
        }
    }
}

/// ∂W₀ᵀ += Xᵀ Ḡ_Z: row d of the first layer's Wᵀ gathers Σᵢ xᵢ,d Ḡ_Z[i] (`g` is `inputs.len() × w₀`).
pub(super) fn input_layer_weight_grad(inputs: &[[f32; INPUT_DIM]], g: &[f32], gw: &mut [f32]) {
    let w0 = gw.len() / INPUT_DIM;
    for (x, grow) in inputs.iter().zip(g.chunks_exact(w0)) {
        for (d, &xd) in x.iter().enumerate() {
            gw[d * w0..(d + 1) * w0]
                .iter_mut()
                .zip(grow)
                .for_each(|(a, b)| *a += xd * b);
        }
    }
}

/// Adds `bias` to every row of `z`.
pub(super) fn add_bias(z: &mut [f32], bias: &[f32]) {
    for zrow in z.chunks_exact_mut(bias.len()) {
        zrow.iter_mut().zip(bias).for_each(|(v, b)| *v += b);
    }
}

/// ∂b += the column sums of `g` (rows of `gb.len()`).
pub(super) fn add_row_sums(gb: &mut [f32], g: &[f32]) {
    for grow in g.chunks_exact(gb.len()) {
        gb.iter_mut().zip(grow).for_each(|(a, b)| *a += b);
    }
}

/// Backward through a layer's product Z = S Wᵀ (+ b), `wt` being Wᵀ: adds ∂Wᵀ = Sᵀ Ḡ_Z to `gw`
/// and writes Ḡ_S = Ḡ_Z W to `g_s`.
#[inline]
pub(super) fn product_backward(s: Mat, g_z: Mat, wt: Mat, gw: &mut [f32], g_s: &mut [f32]) {
    matmul(gw, true, s, Op::T, g_z, Op::N);
    matmul(g_s, false, g_z, Op::N, wt, Op::T);
}

/// One zeroed buffer of `rows` rows per sine layer (a workspace's per-layer storage).
pub(super) fn per_layer(net: &Network, rows: usize) -> Vec<Vec<f32>> {
    let widths = net.layout.widths();
    widths.iter().map(|w| vec![0.0; rows * w]).collect()
}

/// Panics unless a workspace for `capacity` points holds `n` (a caller's bug, not bad data).
#[track_caller]
pub(super) fn check_capacity(n: usize, capacity: usize) {
    assert!(n <= capacity, "{n} points > workspace capacity {capacity}");
}

fn check_tangents(tangents: Tangents, groups: usize, n: usize) {
    assert_eq!(
        tangents.count(),
        groups,
        "tangents do not match the workspace"
    );
    if let Tangents::Along(u) = tangents {
        assert_eq!(u.len(), n, "one direction per point");
    }
}

multiversion! {
    /// S_p = sin Z_p, cos = cos Z_p, S_d = cos Z_p ⊙ Ż_d.
    fn activate<M: MulAdd>(z: &[f32], s: &mut [f32], cos: &mut [f32], n: usize, t: usize, w: usize) {
        let (zp, zt) = z.split_at(n * w);
        let (sp, st) = s.split_at_mut(n * w);
        for ((sv, cv), zv) in sp.iter_mut().zip(cos.iter_mut()).zip(zp) {
            (*sv, *cv) = sin_cos_with::<M>(*zv);
        }
        for d in 0..t {
            let range = d * n * w..(d + 1) * n * w;
            for ((sv, zv), cv) in st[range.clone()].iter_mut().zip(&zt[range]).zip(cos.iter()) {
                *sv = cv * zv;
            }
        }
    }
}

multiversion! {
    /// In place: g (Ḡ_H' stacked) becomes Ḡ_Z:
    /// Ḡ_Zp = cos ⊙ Ḡ_Hp − sin ⊙ Σ_d Ż_d ⊙ Ḡ_Ḣd;  Ḡ_Żd = cos ⊙ Ḡ_Ḣd.
    /// Tangent rows are the `kept` points' (see [`Workspace::backward`]), each group
    /// `kept.len()` rows; one row sweep at a time, contiguous and vectorisable.
    fn sine_backward(g: &mut [f32], z: &[f32], s: &[f32], cos: &[f32], n: usize, w: usize, kept: &[usize]) {
        let (gp, gt) = g.split_at_mut(n * w);
        gp.iter_mut().zip(&cos[..n * w]).for_each(|(g, c)| *g *= c);
        let zt = &z[n * w..n * w + gt.len()];
        for (j, (gtrow, zrow)) in gt.chunks_exact_mut(w).zip(zt.chunks_exact(w)).enumerate() {
            let i = kept[j % kept.len()];
            let row = i * w..(i + 1) * w;
            for ((((gpv, gtv), zv), sv), cv) in gp[row.clone()].iter_mut().zip(gtrow).zip(zrow).zip(&s[row.clone()]).zip(&cos[row]) {
                *gpv -= sv * zv * *gtv;
                *gtv *= cv;
            }
        }
    }
}
