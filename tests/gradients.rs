//! The core's exact derivatives (forward-mode tangents) against central differences of an
//! independent f64 reference evaluation, on random networks and points.

use dynaslice_core::ModelBytes;
use dynaslice_test_support::reference::Reference;
use dynaslice_tests::strategies::{model, to_world, unit_point};
use proptest::prelude::*;

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

    /// The gradient-only and value-only entry points agree with the full jacobian.
    #[test]
    fn entry_points_agree(w in model(), p in unit_point()) {
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
