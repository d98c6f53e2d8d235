//! The motion model's warp: f(x, t) = g(y, t) with y = x + u(x, t), g the shape network and u
//! the motion network ([`Network::motion`]), both SIRENs in the normalised frame. Forward and
//! backward through u beside their math, so every data term of Eq. 5–7 reaches both networks
//! with its exact gradient.
//!
//! ```text
//! value terms      ∂L/∂θ_u = (∂u/∂θ_u)ᵀ ∂L/∂y,        ∂L/∂y = ∇_y of g's pass (Workspace::input_adjoints)
//! along n (Eq. 6)  ⟨∇ₓf, n⟩ = ⟨∇_y g, m⟩,  m = n + J_u n  (∇ₓf = (I + J_u)ᵀ ∇_y g)
//!                  so g's pass carries its tangent along m, and u's pass its tangent along n:
//!                  ∂L/∂(J_u n) = ∂L/∂m, the direction's adjoint in g's first layer
//! ```
//!
//! The space-time terms of Eq. 8 regularise the shape g in its own (canonical) frame, on the
//! space-time samples taken as canonical points: the eikonal term asks ‖∇_y g‖ = 1, so g is a
//! signed distance and the motion, not a stretched field, carries the surface. u gets its own
//! regulariser on the same samples ([`regulariser`], [`velocity`]).

use crate::loss::LossTerms;
use crate::network::Network;
use crate::passes::{Tangents, Workspace, INPUT_DIM};
use crate::temporal_bound::temporal_bound;
use dynaslice_core::Domain;
use dynaslice_sequence::Sequence;

/// The motion network's dimensions and bands (recorded in the model's metadata).
#[derive(Clone, Debug, PartialEq)]
pub struct MotionOptions {
    /// Widths of its sine layers.
    pub widths: Vec<u32>,
    /// Its ω₀: the motion's spatial frequency scale, below the shape's, so u is smooth where g
    /// is sharp (DynoSurf, CanFields: the motion at lower frequencies than the shape).
    pub omega_0: f32,
    /// Its ω_t^max (Eq. 4 on u's time input), in normalised time.
    pub omega_t_max: f32,
}

/// Widths of the motion network: small beside the shape network's 4 × 256, so a step and a
/// query cost little more than the shape network's.
pub const MOTION_WIDTHS: [u32; 2] = [64, 64];

/// ω₀ of the motion network.
pub const MOTION_OMEGA_0: f32 = 5.0;

/// c of the motion's ω_t^max = c·π/Δt (Eq. 4): a motion sampled every Δt is known up to the
/// Nyquist frequency π/Δt. 0.2, the shape network's own default: at 0.5 the 4D CT's tumour ran
/// off its path right after the first phases (worst frame IoU 0.77), at 0.1 the swaying tube's
/// motion lagged after the first annotated time (lab/notes/2026-12-07-motion-model.md).
pub const MOTION_TEMPORAL_FACTOR: f32 = 0.2;

/// c of the shape network's own ω_t^max when a motion network carries it (where
/// `--temporal-factor` is not given): half the default 0.2, so that g's time input holds only
/// the residual of shapes that really change and the motion goes to u. At 0.2 the motion
/// network carried 8 % of the swaying tube's travel and the shape's time input the rest; at
/// 0.1, 29 %, and the 4D CT's tumour IoU rose from 0.92 to 0.96 (the lab note above). Not 0:
/// a shape without time cannot start, before u has learnt to move (the same note).
pub const SHAPE_TEMPORAL_FACTOR: f32 = 0.1;

/// The motion network a run trains: one where `on` (`--motion`) and the input has more than one
/// annotated time (a moving input); `None` otherwise, and always for a static input, whose model
/// stays the shape network alone. Not the default yet: on the 4D CT case it measures below the
/// shape network alone (docs/training.md, "Moving inputs"). `control` is Eq. 4's temporal
/// control (`--no-temporal-control` lifts the motion's bound too).
pub fn motion_options(
    seq: &Sequence,
    domain: &Domain,
    on: bool,
    control: bool,
) -> Option<MotionOptions> {
    (on && seq.frames().len() > 1).then(|| MotionOptions {
        widths: MOTION_WIDTHS.to_vec(),
        omega_0: MOTION_OMEGA_0,
        omega_t_max: temporal_bound(seq, domain, MOTION_TEMPORAL_FACTOR, control),
    })
}

/// λ_s of the motion's strain term λ_s ‖J_u‖²_F: small, so smoothness comes mostly from u's low
/// ω₀ and band (a strain penalty also resists the true bending of a swaying structure), and
/// never the size of u itself (a penalty on |u| biases the motion's amplitude low).
pub const STRAIN_WEIGHT: f32 = 0.01;

/// λ_v of the motion's velocity term λ_v ‖∂u/∂t‖²: between annotated times the data leave the
/// motion free, and the least-velocity path between two positions is the straight one at even
/// speed, so this term interpolates the motion as a linear interpolation of positions would,
/// where a per-point field would blend the shapes instead. Small against the data terms, which
/// pin the positions at the annotated times.
pub const VELOCITY_WEIGHT: f32 = 1e-3;

/// δ of the fold hinge ReLU(δ − det(I + J_u)): the warp x ↦ x + u(x, t) keeps a positive
/// Jacobian determinant with a margin wherever it is sampled, so it does not fold.
pub const FOLD_MARGIN: f32 = 0.2;

/// Buffers of the warp's passes over one point set of up to `capacity` points.
pub struct WarpWorkspace {
    motion: Workspace,
    /// The warped inputs (y, t) handed to the shape network.
    warped: Vec<[f32; INPUT_DIM]>,
    /// With a direction n per point: m = n + J_u n, the shape network's tangent direction.
    directions: Vec<[f32; 3]>,
    /// ∂L/∂y and ∂L/∂m from the shape network's pass.
    g_y: Vec<[f32; 3]>,
    g_m: Vec<[f32; 3]>,
    /// The adjoint of u's stacked outputs [U; U̇].
    g_u: Vec<f32>,
}

impl WarpWorkspace {
    /// Buffers for `capacity` points, with one tangent (a direction per point) or none.
    pub fn new(motion: &Network, capacity: usize, along: bool) -> WarpWorkspace {
        let groups = usize::from(along);
        WarpWorkspace {
            motion: Workspace::new(motion, capacity, groups),
            warped: vec![[0.0; INPUT_DIM]; capacity],
            directions: vec![[0.0; 3]; capacity],
            g_y: vec![[0.0; 3]; capacity],
            g_m: vec![[0.0; 3]; capacity],
            g_u: vec![0.0; capacity * (1 + groups) * 3],
        }
    }

    /// u's forward pass at `inputs` (along `normals` where given): returns the shape network's
    /// inputs (y, t), y = x + u(x, t), and with normals the directions m = n + J_u n.
    pub fn forward(
        &mut self,
        motion: &Network,
        inputs: &[[f32; INPUT_DIM]],
        normals: Option<&[[f32; 3]]>,
    ) -> (&[[f32; INPUT_DIM]], &[[f32; 3]]) {
        let n = inputs.len();
        let tangents = normals.map_or(Tangents::None, Tangents::Along);
        self.motion.forward(motion, inputs, tangents);
        let out = self.motion.outputs(n);
        for (i, (y, x)) in self.warped[..n].iter_mut().zip(inputs).enumerate() {
            *y = [
                x[0] + out[3 * i],
                x[1] + out[3 * i + 1],
                x[2] + out[3 * i + 2],
                x[3],
            ];
        }
        if let Some(normals) = normals {
            for (i, (m, nv)) in self.directions[..n].iter_mut().zip(normals).enumerate() {
                let du = &out[3 * (n + i)..3 * (n + i) + 3];
                *m = [nv[0] + du[0], nv[1] + du[1], nv[2] + du[2]];
            }
        }
        (&self.warped[..n], &self.directions[..n])
    }

    /// After the shape network's backward over the warped points (`shape_pass`, run by
    /// `shape` with the directions of [`WarpWorkspace::forward`] where given): u's backward,
    /// adding its parameter gradient to `grad` (u's parameters only).
    pub fn backward(
        &mut self,
        motion: &Network,
        shape: &Network,
        shape_pass: &Workspace,
        inputs: &[[f32; INPUT_DIM]],
        normals: Option<&[[f32; 3]]>,
        grad: &mut [f32],
    ) {
        let n = inputs.len();
        let g_m = normals.is_some().then_some(&mut self.g_m[..n]);
        shape_pass.input_adjoints(shape, n, &mut self.g_y[..n], g_m);
        // Stacked like u's outputs: [∂L/∂U; ∂L/∂U̇] with ∂L/∂U = ∂L/∂y, ∂L/∂U̇ = ∂L/∂m.
        for (dst, src) in self.g_u.chunks_exact_mut(3).zip(&self.g_y[..n]) {
            dst.copy_from_slice(src);
        }
        if normals.is_some() {
            for (dst, src) in self.g_u[3 * n..].chunks_exact_mut(3).zip(&self.g_m[..n]) {
                dst.copy_from_slice(src);
            }
        }
        let tangents = normals.map_or(Tangents::None, Tangents::Along);
        self.motion
            .backward(motion, inputs, tangents, &self.g_u, grad);
    }
}

/// The motion's regulariser on `n` points of u's stacked [U; ∂U/∂x; ∂U/∂y; ∂U/∂z] (`out`, each
/// n × 3, J_u\[a\]\[d\] = ∂u_a/∂x_d in group 1 + d), each point weighing `weight`:
/// λ_s ‖J_u‖²_F + ReLU(δ − det(I + J_u)) ([`STRAIN_WEIGHT`], [`FOLD_MARGIN`]). Writes its
/// gradient to `g` in the same layout (zero on U).
pub fn regulariser(out: &[f32], weight: f32, g: &mut [f32]) -> LossTerms {
    let n = out.len() / 12;
    g[..12 * n].fill(0.0);
    let mut terms = LossTerms::default();
    let at = |i: usize, a: usize, d: usize| 3 * ((1 + d) * n + i) + a;
    for i in 0..n {
        let j: [[f32; 3]; 3] = std::array::from_fn(|a| std::array::from_fn(|d| out[at(i, a, d)]));
        let strain: f32 = j.iter().flatten().map(|v| v * v).sum();
        let mut value = STRAIN_WEIGHT * strain;
        for a in 0..3 {
            for d in 0..3 {
                g[at(i, a, d)] = weight * STRAIN_WEIGHT * 2.0 * j[a][d];
            }
        }
        let m: [[f32; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|d| j[a][d] + f32::from(a == d)));
        let cof = cofactors(&m);
        let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
        if det < FOLD_MARGIN {
            value += FOLD_MARGIN - det;
            // ∂det/∂M[a][d] = cofactor[a][d].
            for a in 0..3 {
                for d in 0..3 {
                    g[at(i, a, d)] -= weight * cof[a][d];
                }
            }
        }
        terms.motion += (weight * value) as f64;
    }
    terms
}

/// The motion's velocity term on `n` points of u's stacked [U; ∂U/∂t] (`out`, each n × 3), each
/// point weighing `weight`: λ_v ‖∂u/∂t‖² ([`VELOCITY_WEIGHT`]). Writes its gradient to `g` in
/// the same layout (zero on U).
pub fn velocity(out: &[f32], weight: f32, g: &mut [f32]) -> LossTerms {
    let n = out.len() / 6;
    g[..3 * n].fill(0.0);
    let mut terms = LossTerms::default();
    for (gv, v) in g[3 * n..6 * n].iter_mut().zip(&out[3 * n..6 * n]) {
        terms.motion += (weight * VELOCITY_WEIGHT * v * v) as f64;
        *gv = weight * VELOCITY_WEIGHT * 2.0 * v;
    }
    terms
}

/// The cofactor matrix C of `m` (C[a][d] = ∂det m/∂m[a][d]).
fn cofactors(m: &[[f32; 3]; 3]) -> [[f32; 3]; 3] {
    std::array::from_fn(|a| {
        std::array::from_fn(|d| {
            let (a1, a2) = ((a + 1) % 3, (a + 2) % 3);
            let (d1, d2) = ((d + 1) % 3, (d + 2) % 3);
            m[a1][d1] * m[a2][d2] - m[a1][d2] * m[a2][d1]
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cofactors_give_the_determinant_and_its_derivative() {
        let m = [[1.2, -0.3, 0.5], [0.1, 0.9, -0.4], [0.7, 0.2, 1.1]];
        let c = cofactors(&m);
        let det = |m: &[[f32; 3]; 3]| -> f32 {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let expansion: f32 = (0..3).map(|d| m[0][d] * c[0][d]).sum();
        assert!((expansion - det(&m)).abs() < 1e-6);
        for a in 0..3 {
            for d in 0..3 {
                let (mut p, mut q) = (m, m);
                p[a][d] += 1e-3;
                q[a][d] -= 1e-3;
                let numeric = (det(&p) - det(&q)) / 2e-3;
                assert!(
                    (numeric - c[a][d]).abs() < 1e-3,
                    "{a}{d}: {numeric} vs {}",
                    c[a][d]
                );
            }
        }
    }
}
