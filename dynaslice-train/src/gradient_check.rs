//! The trainer's hand-written gradients against central differences of an independent f64
//! implementation of the same loss (Eq. 5–8 on the f64 reference network of
//! `dynaslice_test_support::reference`, whose ∇ₓf is carried by forward-mode tangents), and the
//! trainer's f and ∇ₓf against the core's evaluation of the exported model.

use super::loss::{ContourSample, LossWeights, PlaneKind, PlaneSample, BETWEEN_SHARE};
use super::network::Network;
use super::objective::{Batch, Objective, SpaceTimeScheme};
use super::passes::{Tangents, Workspace};
use super::reverse_over_reverse::ReverseWorkspace;
use super::warp::{self, WarpWorkspace};
use dynaslice_core::{Domain, Layout, ModelBytes};
use dynaslice_test_support::reference::Reference;
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use std::cell::Cell;

/// The trainer's loss (Eq. 5–8) of `b` under the `reference` network, in f64, and the
/// arguments of its kinks: for every term where |·|, a hinge or ‖·‖ switches branch (and λ of
/// the term is not 0), the quantity whose sign picks the branch, in this order: per contour point
/// f and ⟨∇ₓf, n⟩; per absent-class or outside plane sample f − b; per space-time sample and
/// channel f and ‖∇ₓf‖, and f − b where the channel has a lower bound b there; with a motion
/// network, per space-time sample det(I + J_u) − δ.
///
/// With `motion` (a motion model, `crate::warp`), the data terms see f(x) = g(x + u(x), t) with
/// ∇ₓf = (I + J_u)ᵀ ∇_y g, written here directly from u's value and Jacobian; the space-time
/// terms see g at the sample itself (a canonical point) and add u's regulariser there.
fn reference_loss(
    reference: &Reference,
    motion: Option<&Reference>,
    b: &Batch,
    w: &LossWeights,
) -> (f64, Vec<f64>) {
    let wide = |x: [f32; 4]| x.map(|v| v as f64);
    // f and ∇ₓf of every channel at a data point, through the warp where there is one.
    let field = |x: [f32; 4]| -> (Vec<f64>, Vec<[f64; 3]>) {
        let x = wide(x);
        let Some(motion) = motion else {
            return reference.normalised(x);
        };
        let (u, j) = motion.normalised(x);
        let (f, gy) = reference.normalised([x[0] + u[0], x[1] + u[1], x[2] + u[2], x[3]]);
        let gx = gy
            .iter()
            .map(|g| std::array::from_fn(|d| g[d] + (0..3).map(|a| j[a][d] * g[a]).sum::<f64>()))
            .collect();
        (f, gx)
    };
    let mut loss = 0.0;
    let mut kinks = Vec::new();
    for ((x, s), normal) in b.contour_x.iter().zip(&b.contour).zip(&b.contour_normal) {
        let (f, g) = field(*x);
        let c = s.class as usize;
        let dot: f64 = (0..3).map(|d| g[c][d] * normal[d] as f64).sum();
        loss += s.weight as f64 * (f[c].abs() + w.orientation as f64 * (-dot).max(0.0));
        kinks.push(f[c]);
        if w.orientation != 0.0 {
            kinks.push(dot);
        }
    }
    for (x, s) in b.plane_x.iter().zip(&b.plane) {
        let (f, _) = field(*x);
        let r = f[s.class as usize] - s.target as f64;
        match s.kind {
            PlaneKind::Sdf => loss += s.weight as f64 * w.plane as f64 * r * r,
            PlaneKind::Absent => {
                if w.plane != 0.0 {
                    kinks.push(r);
                }
                loss += s.weight as f64 * w.plane as f64 * r.min(0.0).powi(2);
            }
            PlaneKind::Outside => {
                kinks.push(r);
                loss += s.weight as f64 * (-r).max(0.0);
            }
            PlaneKind::Between => {
                let side = (s.target as f64).signum() * f64::from(u8::from(s.target != 0.0));
                let r = side * (BETWEEN_SHARE as f64 * s.target as f64 - f[s.class as usize]);
                kinks.push(r);
                loss += s.weight as f64 * r.max(0.0);
            }
        }
    }
    let n = b.space_x.len() as f64;
    for (i, x) in b.space_x.iter().enumerate() {
        let (f, g) = reference.normalised(wide(*x));
        for (c, (fc, gc)) in f.iter().zip(&g).enumerate() {
            let norm = (gc[0] * gc[0] + gc[1] * gc[1] + gc[2] * gc[2]).sqrt();
            loss += w.regulariser as f64 / n
                * ((norm - 1.0).powi(2) + (-(w.alpha as f64) * fc.abs()).exp());
            if w.regulariser != 0.0 {
                kinks.extend([*fc, norm]);
            }
            let floor = b
                .space_floor
                .get(i * f.len() + c)
                .map_or(f64::NEG_INFINITY, |&v| v as f64);
            if floor.is_finite() {
                loss += (floor - fc).max(0.0) / n;
                kinks.push(fc - floor);
            }
        }
        if let Some(motion) = motion {
            let (_, j) = motion.normalised(wide(*x));
            let m: [[f64; 3]; 3] =
                std::array::from_fn(|a| std::array::from_fn(|d| j[a][d] + f64::from(a == d)));
            let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
            let strain: f64 = j.iter().flatten().map(|v| v * v).sum();
            let margin = f64::from(warp::FOLD_MARGIN);
            loss += (f64::from(warp::STRAIN_WEIGHT) * strain + (margin - det).max(0.0)) / n;
            // ∂u/∂t by a central difference (step 1e-4 in f64: O(1e-8) truncation).
            let h = 1e-4;
            let at = |dt: f64| {
                motion
                    .normalised([x[0] as f64, x[1] as f64, x[2] as f64, x[3] as f64 + dt])
                    .0
            };
            let (ahead, behind) = (at(h), at(-h));
            let speed: f64 = (0..3)
                .map(|a| ((ahead[a] - behind[a]) / (2.0 * h)).powi(2))
                .sum();
            loss += f64::from(warp::VELOCITY_WEIGHT) * speed / n;
            kinks.push(det - margin);
        }
    }
    (loss, kinks)
}

/// How far from 0 every kink argument must be for the f32 trainer to be on the reference's
/// branch: its f and ∇ₓf differ from the f64 ones by a few ε₃₂ times sums of O(1–100) terms,
/// i.e. ≲ 1e-5.
const KINK_MARGIN: f64 = 1e-4;

/// Central differences of the reference loss with respect to every parameter.
struct Differences {
    /// The loss at the parameters.
    loss: f64,
    /// Its kinks' arguments there (see [`reference_loss`]).
    kinks: Vec<f64>,
    /// ∂loss/∂θᵢ by central differences.
    gradient: Vec<f64>,
    /// The first (parameter, kink argument) whose ±h step changed the kink argument's sign:
    /// that parameter's difference then mixes two branches (a hinge's jump of slope, averaged
    /// over the step) and says nothing about either branch's derivative.
    crossed: Option<(usize, usize)>,
}

impl Differences {
    /// Central differences with step `h` (O(h²) truncation, O(ε₆₄/h) rounding), over every
    /// trained parameter in [`Network::all_params`]'s order: the shape network's, then the
    /// motion network's.
    fn new(net: &Network, batch: &Batch, weights: &LossWeights, h: f64) -> Differences {
        let shape = Reference::unclamped(net.layout, &net.params);
        let motion = net
            .motion
            .as_deref()
            .map(|m| Reference::unclamped(m.layout, &m.params));
        let (loss, kinks) = reference_loss(&shape, motion.as_ref(), batch, weights);
        // parameter_gradient evaluates θ + heᵢ then θ − heᵢ for i = 0, 1, …
        let calls = Cell::new(0usize);
        let crossed = Cell::new(None);
        let watch = |(loss, moved_kinks): (f64, Vec<f64>)| {
            let flipped = moved_kinks
                .iter()
                .zip(&kinks)
                .position(|(m, k)| m.signum() != k.signum());
            if let (None, Some(kink)) = (crossed.get(), flipped) {
                crossed.set(Some((calls.get() / 2, kink)));
            }
            calls.set(calls.get() + 1);
            loss
        };
        let mut gradient = shape.parameter_gradient(h, |moved| {
            watch(reference_loss(moved, motion.as_ref(), batch, weights))
        });
        if let Some(motion) = &motion {
            gradient.extend(motion.parameter_gradient(h, |moved| {
                watch(reference_loss(&shape, Some(moved), batch, weights))
            }));
        }
        Differences {
            loss,
            kinks,
            gradient,
            crossed: crossed.get(),
        }
    }

    /// Whether the loss is differentiable on every step and at least [`KINK_MARGIN`] from each
    /// kink at the parameters, so that one branch's derivative is what both sides compute.
    fn smooth(&self) -> bool {
        self.crossed.is_none() && self.kinks.iter().all(|k| k.abs() >= KINK_MARGIN)
    }
}

/// Both schemes' loss and gradient against `numeric` (see the property test for the tolerance).
fn schemes_match(
    net: &Network,
    batch: &Batch,
    weights: &LossWeights,
    numeric: &Differences,
) -> Result<(), TestCaseError> {
    let l64 = numeric.loss;
    let max = numeric.gradient.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for scheme in [
        SpaceTimeScheme::ForwardTangents,
        SpaceTimeScheme::ReverseOverReverse,
    ] {
        let mut objective = Objective::with_scheme(net, 2, 16, scheme);
        let mut grad = vec![0.0; net.all_params_len()];
        let terms = objective.evaluate(net, batch, weights, &mut grad);
        let total = terms.total(weights);
        prop_assert!(
            (total - l64).abs() <= 1e-4 * (1.0 + l64.abs()),
            "{scheme:?}: loss {total} vs {l64}"
        );
        for (i, (g, want)) in grad.iter().zip(&numeric.gradient).enumerate() {
            let tol = 2e-3 * want.abs().max(0.05 * max);
            prop_assert!(
                (*g as f64 - want).abs() <= tol,
                "{scheme:?}, param {i}: {g} vs {want} (max {max})"
            );
        }
    }
    Ok(())
}

fn batch_strategy(k: u32) -> impl Strategy<Value = Batch> {
    let point = || {
        (proptest::array::uniform3(-1.0f32..1.0), 0.0f32..1.0)
            .prop_map(|(x, t)| [x[0], x[1], x[2], t])
    };
    let normal = proptest::array::uniform3(-1.0f32..1.0).prop_map(|n| {
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt().max(1e-3);
        n.map(|v| v / l)
    });
    (
        proptest::collection::vec((point(), 0..k, normal), 1..12),
        proptest::collection::vec((point(), 0..k, -0.5f32..0.5, 0..4u8), 1..12),
        // Each space-time sample's lower bound per channel: beyond the class's extent or not.
        proptest::collection::vec(
            (
                point(),
                proptest::collection::vec(proptest::option::of(-0.5f32..0.5), k as usize),
            ),
            1..12,
        ),
    )
        .prop_map(|(contour, plane, space)| Batch {
            contour_x: contour.iter().map(|c| c.0).collect(),
            contour_normal: contour.iter().map(|c| c.2).collect(),
            contour: contour
                .iter()
                .map(|c| ContourSample {
                    class: c.1,
                    weight: 1.0 / contour.len() as f32,
                })
                .collect(),
            plane_x: plane.iter().map(|p| p.0).collect(),
            plane: plane
                .iter()
                .map(|p| PlaneSample {
                    class: p.1,
                    target: p.2,
                    kind: [
                        PlaneKind::Sdf,
                        PlaneKind::Absent,
                        PlaneKind::Outside,
                        PlaneKind::Between,
                    ][p.3 as usize],
                    weight: 1.0 / plane.len() as f32,
                })
                .collect(),
            space_x: space.iter().map(|s| s.0).collect(),
            space_floor: space
                .iter()
                .flat_map(|s| s.1.iter().map(|b| b.unwrap_or(f32::NEG_INFINITY)))
                .collect(),
        })
}

fn net_strategy() -> impl Strategy<Value = (Network, Batch)> {
    (
        proptest::collection::vec(3u32..14, 1..=3),
        1u32..=3,
        any::<u64>(),
        1.0f32..40.0,
    )
        .prop_flat_map(|(widths, k, seed, omega)| {
            let layout = Layout::new(&widths, k).unwrap();
            // Smaller first-layer frequencies than SIREN's 30 keep the f64 differences well
            // conditioned; the passes do not depend on the weights' scale.
            let mut net = Network::siren(layout, super::network::OMEGA_0, 0.0, omega, seed);
            let w0 = layout.layer_dims(0).1;
            net.params[..4 * w0].iter_mut().for_each(|v| *v *= 0.3);
            (Just(net), batch_strategy(k))
        })
}

/// A motion model: [`net_strategy`]'s shape network carried by a random motion network whose
/// output layer is not zero (the trainer starts it at zero, where most of its gradient is
/// trivially zero), scaled so that the displacements are a fraction of the domain.
fn motion_strategy() -> impl Strategy<Value = (Network, Batch)> {
    (
        net_strategy(),
        proptest::collection::vec(3u32..10, 1..=2),
        any::<u64>(),
        1.0f32..10.0,
        // Up to displacements whose Jacobian folds the warp, so the fold hinge is active in some
        // cases (with its gradient zeroed, this test fails).
        0.05f32..4.0,
    )
        .prop_map(|((net, batch), widths, seed, omega, scale)| {
            let layout = Layout::new(&widths, 3).unwrap();
            let mut motion = Network::siren(layout, 5.0, 0.0, omega, seed);
            let last = layout.layer_offset(layout.num_layers() - 1);
            motion.params[last..].iter_mut().for_each(|v| *v *= scale);
            (net.with_motion(Some(motion)), batch)
        })
}

proptest! {
    // proptest's default config: 256 random cases (about 7 ms each), PROPTEST_CASES overrides.
    // Until kinks were rejected, 3 random cases in 20000 failed (in a census, each with an
    // orientation hinge within reach; `orientation_kink_within_the_step` is CI's case);
    // about 2% of cases are now rejected, nearly all for a kink argument within KINK_MARGIN.

    /// Every parameter's gradient (all loss terms at once, with non-trivial λs so each term
    /// matters) against f64 central differences with step 1e-6: truncation O(h²) and rounding
    /// O(ε₆₄/h) ≈ 1e-10 are negligible. The trainer runs in f32, whose accumulated rounding is
    /// a few ε₃₂ ≈ 1e-7 times the sum of |terms|, itself ≲ 100x the largest gradient entry:
    /// hence the 2e-3·max(|g|, 0.05·max|g|) tolerance. A wrong formula (e.g. a dropped
    /// −sin z ⊙ Σ Ż ⊙ Ḡ cross term) is off by O(1) of that scale.
    ///
    /// The loss has kinks (|f|, the hinges of Eq. 6 and the absent-class plane term, ‖∇ₓf‖ at 0):
    /// a case where one lies within a step of some parameter, or so near that the f32 trainer
    /// may take the other branch, is rejected, since neither side's value is then a derivative
    /// to compare (`orientation_kink_within_the_step` is such a case).
    #[test]
    fn parameter_gradients_match_f64_central_differences((net, batch) in net_strategy(), lambdas in (0.0f32..2.0, 0.0f32..2.0, 0.1f32..2.0, 1.0f32..20.0)) {
        let weights = LossWeights { orientation: lambdas.0, plane: lambdas.1, regulariser: lambdas.2, alpha: lambdas.3 };
        let numeric = Differences::new(&net, &batch, &weights, 1e-6);
        prop_assume!(numeric.smooth(), "a kink within reach: {:?}", numeric.crossed);
        schemes_match(&net, &batch, &weights, &numeric)?;
    }

    /// A motion model's gradient, shape and motion parameters alike, through the warp of every
    /// data term and the motion's regulariser (`crate::warp`), as the test above.
    #[test]
    fn motion_gradients_match_f64_central_differences((net, batch) in motion_strategy(), lambdas in (0.0f32..2.0, 0.0f32..2.0, 0.1f32..2.0, 1.0f32..20.0)) {
        let weights = LossWeights { orientation: lambdas.0, plane: lambdas.1, regulariser: lambdas.2, alpha: lambdas.3 };
        let numeric = Differences::new(&net, &batch, &weights, 1e-6);
        prop_assume!(numeric.smooth(), "a kink within reach: {:?}", numeric.crossed);
        schemes_match(&net, &batch, &weights, &numeric)?;
    }

    /// Both schemes' f and ∇ₓf equal the core's evaluation of the exported model.
    #[test]
    fn trainer_outputs_match_the_core((net, batch) in net_strategy()) {
        let k = net.layout.num_classes();
        let bytes = ModelBytes::copy_from(&net.to_writer(Domain::IDENTITY, (0..k).map(|c| (format!("c{c}"), c as i32 + 1)).collect(), String::new()).to_bytes());
        let model = bytes.model().unwrap();
        let x = &batch.space_x;
        let n = x.len();
        let mut tangents = Workspace::new(&net, n, 3);
        tangents.forward(&net, x, Tangents::Axes);
        let mut reverse = ReverseWorkspace::new(&net, n);
        reverse.forward(&net, x);
        for out in [tangents.outputs(n), reverse.outputs(n)] {
            for (i, p) in x.iter().enumerate() {
                let (mut f, mut g) = (vec![0.0; k], vec![[0.0; 3]; k]);
                model.eval_grad([p[0], p[1], p[2]], p[3], &mut f, &mut g).unwrap();
                for c in 0..k {
                    prop_assert!((out[i * k + c] - f[c]).abs() <= 1e-4 * (1.0 + f[c].abs()));
                    for d in 0..3 {
                        let mine = out[((1 + d) * n + i) * k + c];
                        prop_assert!((mine - g[c][d]).abs() <= 1e-4 * (1.0 + g[c][d].abs()), "∇f {mine} vs {}", g[c][d]);
                    }
                }
            }
        }
    }
}

proptest! {
    /// A motion model's f and ⟨∇ₓf, n⟩ as the trainer computes them (u's pass along n, then g's
    /// at y = x + u along m = n + J_u n: `warp`) equal the core's evaluation of the exported
    /// model, version 2 of the file: trainer and core agree on what the model is.
    #[test]
    fn motion_outputs_match_the_core((net, batch) in motion_strategy()) {
        let k = net.layout.num_classes();
        let classes = (0..k).map(|c| (format!("c{c}"), c as i32 + 1)).collect();
        let bytes = ModelBytes::copy_from(&net.to_writer(Domain::IDENTITY, classes, String::new()).to_bytes());
        let model = bytes.model().unwrap();
        prop_assert!(model.motion().is_some());
        let (x, normals) = (&batch.contour_x, &batch.contour_normal);
        let n = x.len();
        let motion = net.motion.as_deref().unwrap();
        let mut warp = WarpWorkspace::new(motion, n, true);
        let (y, m) = warp.forward(motion, x, Some(normals));
        let mut shape = Workspace::new(&net, n, 1);
        shape.forward(&net, y, Tangents::Along(m));
        let out = shape.outputs(n);
        for (i, p) in x.iter().enumerate() {
            let (mut f, mut g) = (vec![0.0; k], vec![[0.0; 3]; k]);
            model.eval_grad([p[0], p[1], p[2]], p[3], &mut f, &mut g).unwrap();
            for c in 0..k {
                prop_assert!((out[i * k + c] - f[c]).abs() <= 1e-3 * (1.0 + f[c].abs()), "f {} vs {}", out[i * k + c], f[c]);
                let dot: f32 = (0..3).map(|d| g[c][d] * normals[i][d]).sum();
                let mine = out[(n + i) * k + c];
                prop_assert!((mine - dot).abs() <= 1e-3 * (1.0 + dot.abs()), "⟨∇f, n⟩ {mine} vs {dot}");
            }
        }
    }
}

/// The parameters of the one random case that failed the property test in CI (before kinks
/// were rejected): a 9-7 network, one class, ω_t^max = 27.06 (every |ω_t| ≤ 2.25, so the
/// trainer's clamp, which the unclamped reference lacks, plays no part).
#[rustfmt::skip]
const KINK_CASE_PARAMS: [f32; 123] = [
    -1.99072, -0.24331285, -0.18636304, 1.8111215, -1.4996359, 0.86137795, 0.99984914, -0.5084659,
    -1.1231804, -0.8312944, -0.49622157, -0.5935606, 1.851477, 1.3730797, 0.9402432, 1.7094052,
    -1.8031987, 2.203774, -1.4217956, -2.0235133, -1.9972459, -1.3321781, -0.48509303, -1.693814,
    1.8633468, -1.2256334, 0.40210077, 0.31620142, -1.2001883, -2.2434776, 2.2314043, -0.13077322,
    -1.0171082, 0.033565667, 1.2451662, -0.14039384, -14.298685, 2.327814, 2.4552574, -10.319724,
    3.759077, -10.767245, 14.082266, 6.202608, 6.0344696, 0.8082526, -0.7996958, -0.25369364,
    -0.17888606, 0.7432606, -0.6978313, 0.3661027, 0.4919939, 0.7946533, -0.1277197, 0.5369657,
    -0.52531147, 0.8162515, 0.33371556, 0.637081, -0.2361846, 0.20119631, -0.59032065, 0.40359473,
    -0.10690212, 0.6600139, 0.095419645, -0.50966585, -0.43827838, 0.20297599, -0.32372212, 0.57523096,
    0.75447345, 0.51230323, -0.1376577, -0.40326363, 0.67203665, -0.08742577, 0.6355227, 0.46805108,
    0.69546473, -0.6822092, -0.5710577, -0.7452497, -0.1811325, 0.26096022, 0.7226641, -0.6546253,
    -0.6525062, -0.1635561, 0.15611011, 0.8109709, -0.23904991, 0.36778522, -0.5561942, 0.07952225,
    0.05872041, 0.12843686, 0.10045141, -0.7636357, 0.39054286, 0.47187006, 0.53349435, 0.17169464,
    -0.04384935, 0.539098, -0.71585095, 0.33069265, -6.5109205, 7.6517086, -6.7288637, -5.948124,
    8.515869, -0.35851955, -0.75197697, -0.011539016, -0.01732779, 0.004949879, -0.024507387, -0.01872095,
    0.019049522, 0.01615857, 0.1996882,
];

/// The CI failure ("ForwardTangents, param 115: 0.33856523 vs 0.5868273935671908"), explained:
/// its contour point has ⟨∇ₓf, n⟩ = 6.2e-7 > 0 (orientation hinge of Eq. 6 inactive) and
/// ∂⟨∇ₓf, n⟩/∂θ₁₁₅ ≈ −1.45, so θ₁₁₅ + 1e-6 crosses the hinge and the central difference averages
/// the inactive branch's slope (the trainer's 0.3386) with the active one's (0.3386 + λ_n·1.45).
/// The trainer is right: below the kink's distance, or with λ_n = 0, the differences agree.
#[test]
fn orientation_kink_within_the_step() {
    let net = Network {
        layout: Layout::new(&[9, 7], 1).unwrap(),
        params: KINK_CASE_PARAMS.to_vec(),
        omega_t_max: 27.061483,
        plane_band: None,
        motion: None,
    };
    let batch = Batch {
        contour_x: vec![[-0.52670485, 0.3072418, -0.45405558, 0.07004865]],
        contour_normal: vec![[0.5531984, -0.82123977, 0.13977376]],
        contour: vec![ContourSample {
            class: 0,
            weight: 1.0,
        }],
        plane_x: vec![[0.0; 4]],
        plane: vec![PlaneSample {
            class: 0,
            target: 0.0,
            kind: PlaneKind::Sdf,
            weight: 1.0,
        }],
        space_x: vec![[0.0; 4]],
        space_floor: Vec::new(),
    };
    let weights = LossWeights {
        orientation: 0.5921467,
        plane: 0.9517934,
        regulariser: 1.3561041,
        alpha: 11.604693,
    };
    assert!(net.largest_omega_t() < net.omega_t_max);

    let numeric = Differences::new(&net, &batch, &weights, 1e-6);
    // Kink 1 is the contour point's ⟨∇ₓf, n⟩ (kink 0 its f = 0.18, far from |·|'s kink).
    let dot = numeric.kinks[1];
    assert!(dot > 0.0 && dot < 1e-6, "⟨∇f, n⟩ = {dot}");
    let (param, kink) = numeric.crossed.expect("a step crosses the hinge");
    assert_eq!(kink, 1);
    assert!(!numeric.smooth());
    // The check as CI ran it fails on exactly this parameter.
    let failure = schemes_match(&net, &batch, &weights, &numeric).unwrap_err();
    assert!(
        failure.to_string().contains(&format!("param {param}:")),
        "{failure}"
    );
    assert_eq!(param, 115);

    // With steps below the kink's distance (6.2e-7/1.45 ≈ 4e-7 along θ₁₁₅; rounding
    // ε₆₄·loss/h ≈ 4e-8 is still negligible) no step crosses it, and both schemes agree with the
    // differences everywhere, loss included.
    let fine = Differences::new(&net, &batch, &weights, 1e-8);
    assert_eq!(fine.crossed, None);
    schemes_match(&net, &batch, &weights, &fine).unwrap();

    // Without the orientation term there is no kink in reach at the usual step.
    let no_orientation = LossWeights {
        orientation: 0.0,
        ..weights
    };
    let smooth = Differences::new(&net, &batch, &no_orientation, 1e-6);
    assert!(smooth.smooth());
    schemes_match(&net, &batch, &no_orientation, &smooth).unwrap();
}
