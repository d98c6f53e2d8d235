//! The core's exact derivatives (forward-mode tangents) against central differences of an
//! independent f64 reference evaluation, on random networks and points; for motion models
//! (f = g(x_n + u(x_n, t_n), t_n), the chain rule at the output) with f32 and f16 weights, on
//! the single-point and the batch paths, and their displacement u.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{ModelBytes, Scratch};
use dynaslice_test_support::reference::Reference;
use dynaslice_tests::strategies::{any_model, model, motion_model, to_world, unit_point};
use proptest::prelude::*;

/// `w` with the weights as `model` (read from `w`'s file) holds them: f16 weights rounded.
/// Everything else (widths, ω_t^max of both networks, domain) is `w`'s own, so the reference
/// never takes a value from the reader under test.
fn as_stored(w: &ModelWriter, model: &dynaslice_core::Model) -> ModelWriter {
    let read = ModelWriter::from_model(model);
    let mut stored = w.clone();
    stored.params = read.params;
    if let (Some(m), Some(r)) = (&mut stored.motion, read.motion) {
        m.params = r.params;
    }
    stored
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// Tolerances: the reference is f64 with step h = 1e-4 of the normalised unit, so its
    /// truncation error h²·|f'''|/6 is ~1e-8·|f'''| (SIREN derivatives grow by ≲ 30 per order)
    /// and its rounding error ~1e-16/h: both negligible. The core runs in f32 (ε ≈ 6e-8) with a
    /// sine accurate to 1.4e-7; its error is a few ε times the sum of |terms| in each dot
    /// product, which for these SIREN-initialised nets is ≲ 100x the result. Hence
    /// |core − reference| ≤ 2e-4·(|reference| + σ·max(1/s, 1/τ)·30), the last term being the
    /// typical derivative scale of one layer in world units. A wrong formula (a missing cos, a
    /// wrong scale factor, the unclamped ω_t) is off by O(1) of that scale.
    #[test]
    fn gradients_match_central_differences(w in model(), p in unit_point()) {
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let reference = Reference::new(&w);
        let k = model.num_classes();
        let (x, t) = to_world(&w.domain, p);
        let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
        let xd = x.map(|v| v as f64);
        let dom = &w.domain;
        let want_f = reference.eval(xd, t as f64);
        for c in 0..k {
            let tol = 2e-4 * (want_f[c].abs() + dom.output_scale as f64 * 30.0);
            prop_assert!((f[c] as f64 - want_f[c]).abs() <= tol, "f[{c}] {} vs {}", f[c], want_f[c]);
        }
        let units = [dom.scale[0], dom.scale[1], dom.scale[2], dom.time_span].map(f64::from);
        for (axis, unit) in units.into_iter().enumerate() {
            let want = reference.central_difference(xd, t as f64, axis, 1e-4 * unit);
            let got = (0..k).map(|c| if axis < 3 { g[c][axis] } else { d[c] } as f64);
            for (c, (got, want)) in got.zip(want).enumerate() {
                let tol = 2e-4 * (want.abs() + dom.output_scale as f64 / unit * 30.0);
                prop_assert!((got - want).abs() <= tol, "axis {axis} class {c}: {got} vs {want}");
            }
        }
    }

    /// A motion model's f, ∇ₓf and ∂f/∂t, point and batch, against central differences of the
    /// f64 reference composite, with the reference built from the weights the file holds (f16
    /// weights widened), so f32 and f16 files are held to the same tolerance. The tolerance is
    /// the one above, with the derivative scale grown by the warp: ∇ₓf = (I + J_u)ᵀ ∇_y g and
    /// ∂f/∂t adds ∇_y g · ∂u/∂t, so the terms summed are up to (1 + Σ|∂u/∂·|) times g's (the
    /// reference's own |∂u/∂x_n| and |∂u/∂t_n| bound them). The batch path (SIMD kernels) sums
    /// in another order and is held to the same tolerance.
    #[test]
    fn motion_gradients_match_central_differences(w in motion_model(), p in unit_point()) {
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let stored = as_stored(&w, &model);
        let reference = Reference::new(&stored);
        let motion = Reference::new(&ModelWriter {
            classes: vec![(String::new(), 0); 3],
            widths: stored.motion.as_ref().unwrap().widths.clone(),
            params: stored.motion.as_ref().unwrap().params.clone(),
            omega_t_max: stored.motion.as_ref().unwrap().omega_t_max,
            motion: None,
            ..stored.clone()
        });
        let k = model.num_classes();
        let (x, t) = to_world(&w.domain, p);
        let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
        let mut scratch = Scratch::boxed();
        let (mut bf, mut bg, mut bd) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model.eval_jacobian_batch(&mut scratch, &[x], &[t], &mut bf, &mut bg, &mut bd).unwrap();
        let xd = x.map(|v| v as f64);
        let dom = &w.domain;
        // Growth of the derivative scale through the warp: the motion network's own derivatives
        // in normalised units (its outputs are normalised displacements; central differences of
        // the reference u, whose domain is the model's, give them per world unit).
        let units = [dom.scale[0], dom.scale[1], dom.scale[2], dom.time_span].map(f64::from);
        let growth = 1.0 + (0..4)
            .map(|axis| {
                let du = motion.central_difference(xd, t as f64, axis, 1e-4 * units[axis]);
                // motion's output scale σ applies to u: undo it, then per normalised unit.
                du.iter().map(|v| v.abs() * units[axis] / dom.output_scale as f64).sum::<f64>()
            })
            .fold(0.0, f64::max);
        let want_f = reference.eval(xd, t as f64);
        for c in 0..k {
            let tol = 2e-4 * (want_f[c].abs() + dom.output_scale as f64 * 30.0 * growth);
            for got in [f[c], bf[c]] {
                prop_assert!((got as f64 - want_f[c]).abs() <= tol, "f[{c}] {got} vs {}", want_f[c]);
            }
        }
        for (axis, unit) in units.into_iter().enumerate() {
            let want = reference.central_difference(xd, t as f64, axis, 1e-4 * unit);
            for (c, want) in want.into_iter().enumerate() {
                let tol = 2e-4 * (want.abs() + dom.output_scale as f64 / unit * 30.0 * growth);
                let got = if axis < 3 { [g[c][axis], bg[c][axis]] } else { [d[c], bd[c]] };
                for got in got.map(f64::from) {
                    prop_assert!(
                        (got - want).abs() <= tol,
                        "axis {axis} class {c}: {got} vs {want} (tolerance {tol:e})"
                    );
                }
            }
        }
    }

    /// The displacement is u in world units and carries x to where the shape network is read:
    /// the core's `displacement` (point and batch) against the reference's, and the reference
    /// composite f(x, t) equal to the shape network alone at x + u, in world units.
    #[test]
    fn displacement_carries_points_to_the_shape(w in motion_model(), p in unit_point()) {
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let stored = as_stored(&w, &model);
        let reference = Reference::new(&stored);
        let shape = Reference::new(&ModelWriter { motion: None, ..stored.clone() });
        let (x, t) = to_world(&w.domain, p);
        let got = model.displacement(x, t).unwrap();
        let mut batch = [[0.0f32; 3]];
        model.displacement_batch(&mut Scratch::boxed(), &[x], &[t], &mut batch).unwrap();
        let xd = x.map(f64::from);
        let want = reference.displacement(xd, t as f64);
        for axis in 0..3 {
            let tol = 1e-4 * f64::from(w.domain.scale[axis]);
            for got in [got[axis], batch[0][axis]].map(f64::from) {
                prop_assert!((got - want[axis]).abs() <= tol, "axis {axis}: {got} vs {}", want[axis]);
            }
        }
        let moved: [f64; 3] = std::array::from_fn(|i| xd[i] + want[i]);
        let (a, b) = (reference.eval(xd, t as f64), shape.eval(moved, t as f64));
        for (a, b) in a.iter().zip(&b) {
            prop_assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
        }
    }

    /// The gradient-only and value-only entry points agree with the full jacobian.
    #[test]
    fn entry_points_agree(w in any_model(), p in unit_point()) {
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let k = model.num_classes();
        let (x, t) = to_world(&w.domain, p);
        let (mut f1, mut f2, mut f3) = (vec![0.0; k], vec![0.0; k], vec![0.0; k]);
        let (mut g2, mut g3, mut d3) = (vec![[0.0; 3]; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model.eval(x, t, &mut f1).unwrap();
        model.eval_grad(x, t, &mut f2, &mut g2).unwrap();
        model.eval_jacobian(x, t, &mut f3, &mut g3, &mut d3).unwrap();
        prop_assert_eq!(&f1, &f2);
        prop_assert_eq!(&f1, &f3);
        prop_assert_eq!(g2, g3);
    }
}
