//! Reverse over reverse: the second exact scheme for a loss on f and the whole ∇ₓf of every
//! channel (the space-time samples of Eq. 8), cheaper than three forward tangents
//! ([`super::passes`]) when K is small.
//!
//! With S_l = sin Z_l, C_l = cos Z_l, Z_l = S_{l−1} W_lᵀ + b_l (row-major, one row per point; the
//! code stores Wᵀ as `wt`) and the output F = S_{L−1} W_Lᵀ + b_L:
//!
//! ```text
//! forward         Z_l, S_l, C_l for l = 0..L−1, F
//! backward (per   P_{L−1}^k = row k of W_L (the same for every point),
//!  channel k)     Q_l^k = C_l ⊙ P_l^k  (= ∂f^k/∂Z_l),   P_{l−1}^k = Q_l^k W_l,
//!                 ∇ₓf^k = Q_0^k W_0[:, xyz]
//! reverse of the  Q̄_0 = Ḡ W_0[:, xyz]ᵀ,  ∂W_0[:, xyz] += Q_0ᵀ Ḡ           (Ḡ = ∂loss/∂∇ₓf)
//!  backward,      P̄_l = C_l ⊙ Q̄_l,   Z̄_l −= Σ_k S_l ⊙ P_l^k ⊙ Q̄_l^k   (d cos z = −sin z)
//!  upwards        Q̄_{l+1} = P̄_l W_{l+1}ᵀ,  ∂W_{l+1} += Q_{l+1}ᵀ P̄_l,  ∂W_L[k] += Σ_rows P̄_{L−1}^k
//! reverse of the  Ḡ_{S_{L−1}} = F̄ W_L,  ∂W_L += F̄ᵀ S_{L−1},  ∂b_L += Σ F̄
//!  forward,       Ḡ_{Z_l} = C_l ⊙ Ḡ_{S_l} + Z̄_l,  ∂W_l += Ḡ_{Z_l}ᵀ S_{l−1},  ∂b_l += Σ Ḡ_{Z_l},
//!  downwards      Ḡ_{S_{l−1}} = Ḡ_{Z_l} W_l
//! ```
//!
//! The K channels' backward rows are stacked as K blocks of N rows, so each line is one matrix
//! product. Cost, M being one layer's product over the N points: forward M; per channel a
//! backward M and its reverse 2M; one reverse of the forward 2M, shared by all channels because
//! it is linear in its seeds (F̄ and the Z̄_l of every channel add up). In all **(3 + 3K)M**,
//! against 12M for three forward tangents: 6M at K = 1, 9M at K = 2, a tie at K = 3, dearer
//! beyond (see [`super::objective::SpaceTimeScheme`]).

use super::matmul::{matmul, Mat, Op};
use super::network::Network;
use super::passes::{
    add_bias, add_row_sums, check_capacity, input_layer, input_layer_weight_grad, per_layer,
    product_backward, INPUT_DIM,
};
use super::simd::multiversion;
use dynaslice_core::sine::sin_cos_with;

/// Buffers of one reverse-over-reverse pass over up to `capacity` points; allocated once and
/// reused every step.
pub struct ReverseWorkspace {
    capacity: usize,
    classes: usize,
    /// Per sine layer: S_l = sin Z_l (`N × w_l`); the pre-activation Z_l is built in place.
    sin: Vec<Vec<f32>>,
    /// Per sine layer: C_l = cos Z_l.
    cos: Vec<Vec<f32>>,
    /// Per sine layer: P_l^k = ∂f^k/∂S_l, K blocks of N rows.
    p: Vec<Vec<f32>>,
    /// Per sine layer: Q_l^k = ∂f^k/∂Z_l, K blocks of N rows.
    q: Vec<Vec<f32>>,
    /// Per sine layer: Z̄_l, the adjoint of Z_l from the gradient chain (`N × w_l`).
    z_bar: Vec<Vec<f32>>,
    /// Outputs [F; ∂F/∂x; ∂F/∂y; ∂F/∂z], each `N × K`: the layout of
    /// [`super::passes::Workspace::outputs`] with three tangents.
    out: Vec<f32>,
    /// Adjoint buffers, `K·N × widest` each.
    g_a: Vec<f32>,
    g_b: Vec<f32>,
}

impl ReverseWorkspace {
    /// Buffers for `capacity` points.
    pub fn new(net: &Network, capacity: usize) -> ReverseWorkspace {
        let layout = &net.layout;
        let k = layout.num_classes();
        let stacked = capacity * k;
        ReverseWorkspace {
            capacity,
            classes: k,
            sin: per_layer(net, capacity),
            cos: per_layer(net, capacity),
            p: per_layer(net, stacked),
            q: per_layer(net, stacked),
            z_bar: per_layer(net, capacity),
            out: vec![0.0; 4 * capacity * k],
            g_a: vec![0.0; stacked * layout.max_width()],
            g_b: vec![0.0; stacked * layout.max_width()],
        }
    }

    /// f and ∇ₓf (normalised units) of the last [`ReverseWorkspace::forward`] over `points`
    /// points: rows `0..points` are f, rows `points·(1+d)..points·(2+d)` are ∂f/∂x_d.
    pub fn outputs(&self, points: usize) -> &[f32] {
        &self.out[..4 * points * self.classes]
    }

    /// Forward pass and the per-channel backward that gives ∇ₓf, over `inputs` (normalised
    /// (x, y, z, t) per point).
    pub fn forward(&mut self, net: &Network, inputs: &[[f32; INPUT_DIM]]) {
        let n = inputs.len();
        check_capacity(n, self.capacity);
        let layout = &net.layout;
        let k = layout.num_classes();
        let sines = layout.num_sine_layers();
        let p = &net.params;

        // Forward: S_l, C_l, then F.
        let (_, w0) = layout.layer_dims(0);
        input_layer(net, inputs, &mut self.sin[0][..n * w0]);
        activate(&mut self.sin[0][..n * w0], &mut self.cos[0][..n * w0]);
        for l in 1..=sines {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let off = layout.layer_offset(l);
            let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
            let bias = &p[off + fan_in * fan_out..off + (fan_in + 1) * fan_out];
            let (done, rest) = self.sin.split_at_mut(l);
            let input = Mat::new(&done[l - 1][..n * fan_in], n, fan_in);
            let z = if l == sines {
                &mut self.out[..n * fan_out]
            } else {
                &mut rest[0][..n * fan_out]
            };
            matmul(z, false, input, Op::N, wt, Op::N);
            add_bias(z, bias);
            if l < sines {
                activate(z, &mut self.cos[l][..n * fan_out]);
            }
        }

        // Backward per channel: P_{L−1}^k is row k of W_L, i.e. column k of the stored W_Lᵀ.
        let last = sines - 1;
        let (w_last, _) = layout.layer_dims(sines);
        let off = layout.layer_offset(sines);
        let wt_out = &p[off..off + w_last * k];
        for (c, block) in self.p[last][..k * n * w_last]
            .chunks_exact_mut(n * w_last)
            .enumerate()
        {
            let (first, others) = block.split_at_mut(w_last);
            first
                .iter_mut()
                .zip(wt_out.chunks_exact(k))
                .for_each(|(v, row)| *v = row[c]);
            others
                .chunks_exact_mut(w_last)
                .for_each(|r| r.copy_from_slice(first));
        }
        for l in (0..sines).rev() {
            let w = layout.widths()[l];
            scale_blocks(
                &mut self.q[l][..k * n * w],
                &self.p[l][..k * n * w],
                &self.cos[l][..n * w],
            );
            if l > 0 {
                let (fan_in, fan_out) = layout.layer_dims(l);
                let off = layout.layer_offset(l);
                let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
                let q = Mat::new(&self.q[l][..k * n * fan_out], k * n, fan_out);
                matmul(
                    &mut self.p[l - 1][..k * n * fan_in],
                    false,
                    q,
                    Op::N,
                    wt,
                    Op::T,
                );
            }
        }
        // ∇ₓf^k = Q_0^k W_0[:, xyz]: row d of the stored W₀ᵀ is ω_x's column d.
        let wt0 = &p[..INPUT_DIM * w0];
        for (r, qrow) in self.q[0][..k * n * w0].chunks_exact(w0).enumerate() {
            let (c, i) = (r / n, r % n);
            for d in 0..3 {
                let dot = qrow
                    .iter()
                    .zip(&wt0[d * w0..(d + 1) * w0])
                    .map(|(a, b)| a * b)
                    .sum::<f32>();
                self.out[((1 + d) * n + i) * k + c] = dot;
            }
        }
    }

    /// Parameter gradient of the last forward over `inputs`: `g_out` holds ∂loss/∂outputs in
    /// the layout of [`ReverseWorkspace::outputs`]; the gradient is added to `grad`.
    pub fn backward(
        &mut self,
        net: &Network,
        inputs: &[[f32; INPUT_DIM]],
        g_out: &[f32],
        grad: &mut [f32],
    ) {
        let n = inputs.len();
        let layout = &net.layout;
        let k = layout.num_classes();
        let sines = layout.num_sine_layers();
        let p = &net.params;
        assert!(g_out.len() >= 4 * n * k && grad.len() == p.len());
        let mut g_cur = std::mem::take(&mut self.g_a);
        let mut g_next = std::mem::take(&mut self.g_b);

        // Q̄_0 = Ḡ W_0[:, xyz]ᵀ and ∂W_0[:, xyz] += Ḡᵀ Q_0, row by row (3 axpys each way).
        let (_, w0) = layout.layer_dims(0);
        let (gw0, _) = grad[..INPUT_DIM * w0].split_at_mut(3 * w0);
        let wt0 = &p[..3 * w0];
        for (r, (qbar, qrow)) in g_cur[..k * n * w0]
            .chunks_exact_mut(w0)
            .zip(self.q[0].chunks_exact(w0))
            .enumerate()
        {
            let (c, i) = (r / n, r % n);
            qbar.fill(0.0);
            for d in 0..3 {
                let g = g_out[((1 + d) * n + i) * k + c];
                let w = &wt0[d * w0..(d + 1) * w0];
                qbar.iter_mut().zip(w).for_each(|(a, b)| *a += g * b);
                gw0[d * w0..(d + 1) * w0]
                    .iter_mut()
                    .zip(qrow)
                    .for_each(|(a, b)| *a += g * b);
            }
        }

        // Up the gradient chain: Q̄_l → P̄_l (and Z̄_l) → Q̄_{l+1}.
        for l in 0..sines {
            let w = layout.widths()[l];
            chain_adjoint(
                &mut g_cur[..k * n * w],
                &mut self.z_bar[l][..n * w],
                &self.sin[l][..n * w],
                &self.cos[l][..n * w],
                &self.p[l][..k * n * w],
            );
            let (fan_in, fan_out) = layout.layer_dims(l + 1);
            let off = layout.layer_offset(l + 1);
            let p_bar = Mat::new(&g_cur[..k * n * fan_in], k * n, fan_in);
            let gw = &mut grad[off..off + fan_in * fan_out];
            if l + 1 < sines {
                let q = Mat::new(&self.q[l + 1][..k * n * fan_out], k * n, fan_out);
                matmul(gw, true, p_bar, Op::T, q, Op::N);
                let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
                matmul(
                    &mut g_next[..k * n * fan_out],
                    false,
                    p_bar,
                    Op::N,
                    wt,
                    Op::N,
                );
                std::mem::swap(&mut g_cur, &mut g_next);
            } else {
                // P_{L−1}^k was row k of W_L for every point: its adjoint sums over the block.
                for (c, block) in g_cur[..k * n * fan_in].chunks_exact(n * fan_in).enumerate() {
                    for row in block.chunks_exact(fan_in) {
                        gw.chunks_exact_mut(k).zip(row).for_each(|(g, v)| g[c] += v);
                    }
                }
            }
        }

        // Down the forward pass, seeded with F̄ and every Z̄_l.
        let (w_last, _) = layout.layer_dims(sines);
        let off = layout.layer_offset(sines);
        let f_bar = Mat::new(&g_out[..n * k], n, k);
        let (gw, gb) = grad[off..off + (w_last + 1) * k].split_at_mut(w_last * k);
        let s_last = Mat::new(&self.sin[sines - 1][..n * w_last], n, w_last);
        let wt = Mat::new(&p[off..off + w_last * k], w_last, k);
        product_backward(s_last, f_bar, wt, gw, &mut g_cur[..n * w_last]);
        add_row_sums(gb, &g_out[..n * k]);
        for l in (0..sines).rev() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let off = layout.layer_offset(l);
            sine_adjoint(
                &mut g_cur[..n * fan_out],
                &self.cos[l][..n * fan_out],
                &self.z_bar[l][..n * fan_out],
            );
            let (gw, gb) = grad[off..off + (fan_in + 1) * fan_out].split_at_mut(fan_in * fan_out);
            add_row_sums(gb, &g_cur[..n * fan_out]);
            if l == 0 {
                input_layer_weight_grad(inputs, &g_cur[..n * fan_out], gw);
            } else {
                let g_z = Mat::new(&g_cur[..n * fan_out], n, fan_out);
                let input = Mat::new(&self.sin[l - 1][..n * fan_in], n, fan_in);
                let wt = Mat::new(&p[off..off + fan_in * fan_out], fan_in, fan_out);
                product_backward(input, g_z, wt, gw, &mut g_next[..n * fan_in]);
                std::mem::swap(&mut g_cur, &mut g_next);
            }
        }
        self.g_a = g_cur;
        self.g_b = g_next;
    }
}

multiversion! {
    /// In place: Z becomes S = sin Z; `cos` gets cos Z.
    fn activate<M: MulAdd>(z: &mut [f32], cos: &mut [f32]) {
        for (zv, cv) in z.iter_mut().zip(cos.iter_mut()) {
            (*zv, *cv) = sin_cos_with::<M>(*zv);
        }
    }
}

multiversion! {
    /// Q^k = C ⊙ P^k for every block k of `p` (each `c.len()` long).
    fn scale_blocks(q: &mut [f32], p: &[f32], c: &[f32]) {
        for (qb, pb) in q.chunks_exact_mut(c.len()).zip(p.chunks_exact(c.len())) {
            for ((qv, pv), cv) in qb.iter_mut().zip(pb).zip(c) {
                *qv = cv * pv;
            }
        }
    }
}

multiversion! {
    /// In place Q̄^k → P̄^k = C ⊙ Q̄^k per block, and Z̄ = −Σ_k S ⊙ P^k ⊙ Q̄^k.
    fn chain_adjoint(g: &mut [f32], z_bar: &mut [f32], s: &[f32], c: &[f32], p: &[f32]) {
        z_bar.fill(0.0);
        for (gb, pb) in g.chunks_exact_mut(c.len()).zip(p.chunks_exact(c.len())) {
            for ((((gv, zv), sv), cv), pv) in gb.iter_mut().zip(z_bar.iter_mut()).zip(s).zip(c).zip(pb) {
                *zv -= sv * pv * *gv;
                *gv *= cv;
            }
        }
    }
}

multiversion! {
    /// In place Ḡ_S → Ḡ_Z = C ⊙ Ḡ_S + Z̄.
    fn sine_adjoint(g: &mut [f32], c: &[f32], z_bar: &[f32]) {
        for ((gv, cv), zv) in g.iter_mut().zip(c).zip(z_bar) {
            *gv = cv * *gv + zv;
        }
    }
}
