//! The DynaSlice loss (Eq. 5–8, 10) on the network's outputs and its gradient with respect to
//! them (f and ∇ₓf), which the backward pass turns into parameter gradients.
//!
//! Per class k, on its own data (Eq. 10):
//! - contour points: |f^k| + λ_n·ReLU(⟨−∇ₓf^k, n⟩) (Eq. 5, 6);
//! - plane samples: λ_d·(f^k − SDF2D^k)² (Eq. 7), or, on a plane annotated for k that holds no
//!   contour of k, λ_d·ReLU(b − f^k)² with b the lower bound the sampler provides (f^k must be
//!   positive there: the plane misses structure k);
//! - space-time samples, every channel: λ_r·[(‖∇ₓf^k‖ − 1)² + exp(−α|f^k|)] (Eq. 8);
//! - where the data says class k is outside by at least b (beyond its contours' box,
//!   [`crate::extent_bound`], on plane, cap and space-time samples; inside a class nested in it):
//!   ReLU(b − f^k), weighted 1 as the surface term is. Not in the paper, whose planes are the
//!   only data: these are facts of the same data off the planes, a structure ending where its
//!   contours end, not a soft target (λ_d's squared hinge let a lung run on 25 mm past its last
//!   plane; lab/notes/2026-12-07-clinical-extent.md).
//! - between two neighbouring parallel planes that both outline class k, with b their in-plane
//!   distances blended by the point's place between them: ReLU(sign(b)·(b/2 − f^k)), weighted
//!   1 (f on b's side, at least half as far; not in the paper: without it a wall thinner than
//!   the planes' spacing swung ±4–5 mm between them under the regulariser, and a squared λ_d
//!   target there was too weak to hold it; lab/notes/2026-12-07-between-slices.md).
//!
//! Every term is a weighted sum over samples; the samplers set the weights (1/N per set and
//! class, times optional class weights), so the sums are the paper's expectations.

/// Loss weights (recorded in the model's metadata).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LossWeights {
    /// λ_n, orientation (Eq. 6); 0 is the ablation `--no-orientation`.
    pub orientation: f32,
    /// λ_d, plane 2D SDF (Eq. 7).
    pub plane: f32,
    /// λ_r, space-time regulariser (Eq. 8).
    pub regulariser: f32,
    /// α of exp(−α|f|), in normalised units.
    pub alpha: f32,
}

/// The loss split by term, for logs and the loss curve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LossTerms {
    /// Σ w |f| on contours.
    pub surface: f64,
    /// Σ w ReLU(−∇f·n) on contours (before λ_n).
    pub orientation: f64,
    /// Σ w (f − SDF2D)² and the absent-class hinge on planes (before λ_d).
    pub plane: f64,
    /// Σ w (‖∇f‖ − 1)² on space-time samples (before λ_r).
    pub eikonal: f64,
    /// Σ w exp(−α|f|) on space-time samples (before λ_r).
    pub spurious: f64,
    /// Σ w ReLU(b − f) where a class is known outside by at least b.
    pub outside: f64,
    /// A motion model's regulariser of its motion u (`crate::warp::regulariser`): Σ w
    /// [λ_s ‖J_u‖²_F + ReLU(δ − det(I + J_u))] on space-time samples, weights included; 0
    /// without motion.
    pub motion: f64,
    /// Σ w ReLU(sign(b)·(b/2 − f)) between neighbouring planes, b their blended in-plane
    /// distance.
    pub between: f64,
}

impl LossTerms {
    /// The terms by name, in the loss log's column order (after its total): the one list the
    /// log, the progress line and Python's figures are made from.
    pub fn named(&self) -> [(&'static str, f64); 8] {
        [
            ("surface", self.surface),
            ("orientation", self.orientation),
            ("plane", self.plane),
            ("eikonal", self.eikonal),
            ("spurious", self.spurious),
            ("outside", self.outside),
            ("motion", self.motion),
            ("between", self.between),
        ]
    }

    /// The weighted total (Eq. 5, 10).
    pub fn total(&self, w: &LossWeights) -> f64 {
        self.surface
            + w.orientation as f64 * self.orientation
            + w.plane as f64 * self.plane
            + w.regulariser as f64 * (self.eikonal + self.spurious)
            + self.outside
            + self.motion
            + self.between
    }

    /// Adds another partial sum (chunks are summed in a fixed order for determinism).
    pub fn add(&mut self, o: &LossTerms) {
        self.surface += o.surface;
        self.orientation += o.orientation;
        self.plane += o.plane;
        self.eikonal += o.eikonal;
        self.spurious += o.spurious;
        self.outside += o.outside;
        self.motion += o.motion;
        self.between += o.between;
    }
}

/// A contour sample: on the zero set of its class (its normal travels separately, as the
/// direction of the pass's tangent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContourSample {
    /// Class index (0-based channel).
    pub class: u32,
    /// Weight of this sample in the sums.
    pub weight: f32,
}

/// What a [`PlaneSample`]'s target says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneKind {
    /// The in-plane 2D SDF (Eq. 7): λ_d·(f − target)².
    Sdf,
    /// The class is annotated on this plane but has no contour there: f ≥ target,
    /// λ_d·ReLU(target − f)².
    Absent,
    /// The class is known outside by at least `target` (beyond its extent, or inside a class
    /// nested in it; the point need not lie on a plane): ReLU(target − f).
    Outside,
    /// Between two neighbouring planes, `target` is their in-plane distances blended by the
    /// point's place between them (`sampling::SamplingIndex::sample_between`): f is asked to
    /// be on the target's side, at least half as far, ReLU(sign(target)·(target/2 − f)).
    Between,
}

/// The share of a [`PlaneKind::Between`] target f must reach: the sign, with a margin that
/// grows with the depth the neighbouring planes agree on, not their distances themselves.
pub const BETWEEN_SHARE: f32 = 0.5;

/// A plane sample of one class.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneSample {
    /// Class index (0-based channel).
    pub class: u32,
    /// Target: see `kind`.
    pub target: f32,
    /// What the target says.
    pub kind: PlaneKind,
    /// Weight of this sample in the sums.
    pub weight: f32,
}

/// Exponents beyond this give exp(−x) < 1e-35: treated as 0 so no denormal is ever produced
/// (denormal arithmetic is ~100x slower on x86).
const EXP_CUTOFF: f32 = 80.0;

/// Contour terms. `out` holds the stacked [F; D_n F] of `samples.len()` points, D_n F being
/// the derivative along each point's outward normal n (so ⟨∇ₓf, n⟩ of Eq. 6); the gradient is
/// written to `g` in the same layout (zero elsewhere).
pub fn contour(
    out: &[f32],
    k: usize,
    samples: &[ContourSample],
    w: &LossWeights,
    g: &mut [f32],
) -> LossTerms {
    let n = samples.len();
    g[..2 * n * k].fill(0.0);
    let mut terms = LossTerms::default();
    for (i, s) in samples.iter().enumerate() {
        let c = s.class as usize;
        let f = out[i * k + c];
        terms.surface += (s.weight * f.abs()) as f64;
        g[i * k + c] = s.weight * sign(f);
        let dot = out[(n + i) * k + c];
        if -dot > 0.0 {
            terms.orientation += (s.weight * -dot) as f64;
            g[(n + i) * k + c] = -w.orientation * s.weight;
        }
    }
    terms
}

/// Plane terms on the plain outputs F (`samples.len() × k`).
pub fn plane(
    out: &[f32],
    k: usize,
    samples: &[PlaneSample],
    w: &LossWeights,
    g: &mut [f32],
) -> LossTerms {
    let n = samples.len();
    g[..n * k].fill(0.0);
    let mut terms = LossTerms::default();
    for (i, s) in samples.iter().enumerate() {
        let c = s.class as usize;
        let r = out[i * k + c] - s.target;
        match s.kind {
            PlaneKind::Sdf => {
                terms.plane += (s.weight * r * r) as f64;
                g[i * k + c] = w.plane * s.weight * 2.0 * r;
            }
            // Only f < bound is penalised.
            PlaneKind::Absent => {
                let r = r.min(0.0);
                terms.plane += (s.weight * r * r) as f64;
                g[i * k + c] = w.plane * s.weight * 2.0 * r;
            }
            PlaneKind::Outside => {
                if r < 0.0 {
                    terms.outside -= (s.weight * r) as f64;
                    g[i * k + c] = -s.weight;
                }
            }
            PlaneKind::Between => {
                let side = sign(s.target);
                let r = side * (BETWEEN_SHARE * s.target - out[i * k + c]);
                if r > 0.0 {
                    terms.between += (s.weight * r) as f64;
                    g[i * k + c] = -side * s.weight;
                }
            }
        }
    }
    terms
}

/// Space-time terms on every channel of the stacked [F; ∂F/∂x; ∂F/∂y; ∂F/∂z] of `n` points;
/// `weight` is the per-sample weight (1/N). `floor` holds each point's lower bound of every
/// channel (`[i·k + c]`, −∞ for none; empty: no bounds).
pub fn space_time(
    out: &[f32],
    k: usize,
    floor: &[f32],
    weight: f32,
    w: &LossWeights,
    g: &mut [f32],
) -> LossTerms {
    let n = out.len() / (4 * k);
    let mut terms = LossTerms::default();
    let lr = w.regulariser;
    for i in 0..n {
        for c in 0..k {
            let f = out[i * k + c];
            let grad: [f32; 3] = std::array::from_fn(|d| out[((1 + d) * n + i) * k + c]);
            let norm = (grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2]).sqrt();
            let e = norm - 1.0;
            terms.eikonal += (weight * e * e) as f64;
            // d/dg (‖g‖ − 1)² = 2(‖g‖ − 1) g/‖g‖ (0 at g = 0, a measure-zero point).
            let scale = if norm > 0.0 {
                lr * weight * 2.0 * e / norm
            } else {
                0.0
            };
            for d in 0..3 {
                g[((1 + d) * n + i) * k + c] = scale * grad[d];
            }
            let x = w.alpha * f.abs();
            let ex = if x < EXP_CUTOFF { (-x).exp() } else { 0.0 };
            terms.spurious += (weight * ex) as f64;
            g[i * k + c] = -lr * weight * w.alpha * sign(f) * ex;
            // Beyond the class's extent: f ≥ b.
            if let Some(&b) = floor.get(i * k + c) {
                if f < b {
                    terms.outside += (weight * (b - f)) as f64;
                    g[i * k + c] -= weight;
                }
            }
        }
    }
    terms
}

/// sign with sign(0) = 0 (the subgradient of |·| at 0 used by PyTorch).
fn sign(v: f32) -> f32 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}
