//! Evaluation is defined everywhere finite: every finite point and time, however far outside the
//! model's domain (up to ±f32::MAX), gives finite f, ∇ₓf and ∂f/∂t and a defined label, on the
//! single-point and the batch (SIMD) paths alike. Before the sine's reduced argument was
//! clamped, x = 10⁹ mm gave NaN. Motion models too: their warped point is clamped like x_n.

use dynaslice_core::{ModelBytes, Scratch, UNDEFINED_LABEL};
use dynaslice_tests::strategies::any_model;
use proptest::num::f32::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
use proptest::prelude::*;

/// Any finite f32: every binade of both signs, subnormals and zeros.
fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![
        (POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO),
        Just(f32::MAX),
        Just(-f32::MAX),
        Just(1e9f32),
        Just(4_294_967_297.0f32),
        -1e3f32..1e3,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn every_finite_query_gives_finite_answers(
        mut w in any_model(),
        tiny_domain in any::<bool>(),
        points in proptest::collection::vec((proptest::array::uniform3(finite()), finite()), 1..24),
    ) {
        if tiny_domain {
            // Scales below 1 make (x − c)/s overflow near f32::MAX.
            w.domain.scale = [1e-3, 2e-3, 5e-4];
            w.domain.time_span = 1e-3;
        }
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let k = model.num_classes();
        let (xyz, t): (Vec<[f32; 3]>, Vec<f32>) = points.iter().copied().unzip();
        for (x, &t) in xyz.iter().zip(&t) {
            let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
            model.eval_jacobian(*x, t, &mut f, &mut g, &mut d).unwrap();
            prop_assert!(f.iter().all(|v| v.is_finite()), "f at {x:?}, {t}: {f:?}");
            prop_assert!(g.iter().flatten().all(|v| v.is_finite()), "∇f at {x:?}, {t}: {g:?}");
            prop_assert!(d.iter().all(|v| v.is_finite()), "∂f/∂t at {x:?}, {t}: {d:?}");
            let label = model.label(*x, t);
            prop_assert!(label != UNDEFINED_LABEL && label as usize <= k, "label {label}");
        }
        let n = xyz.len();
        let mut scratch = Scratch::boxed();
        let (mut f, mut g, mut d) = (vec![0.0; n * k], vec![[0.0; 3]; n * k], vec![0.0; n * k]);
        model.eval_jacobian_batch(&mut scratch, &xyz, &t, &mut f, &mut g, &mut d).unwrap();
        prop_assert!(f.iter().all(|v| v.is_finite()), "batch f: {f:?}");
        prop_assert!(g.iter().flatten().all(|v| v.is_finite()), "batch ∇f: {g:?}");
        prop_assert!(d.iter().all(|v| v.is_finite()), "batch ∂f/∂t: {d:?}");
        model.eval_batch(&mut scratch, &xyz, &t, &mut f).unwrap();
        prop_assert!(f.iter().all(|v| v.is_finite()), "batch f only: {f:?}");
        let mut labels = vec![0u32; n];
        model.label_batch(&mut scratch, &xyz, &t, &mut labels).unwrap();
        prop_assert!(labels.iter().all(|&l| l != UNDEFINED_LABEL && l as usize <= k), "{labels:?}");
    }
}
