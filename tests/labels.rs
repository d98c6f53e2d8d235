//! Eq. 11 labels: the argmin over (0, f¹, …, f^K), from every entry point, for models with and
//! without motion.

use dynaslice_core::{argmin_label, ModelBytes, Scratch};
use dynaslice_tests::strategies::{any_model, to_world, unit_point};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn labels_are_the_argmin_with_background_zero(
        mut w in any_model(),
        shift in -1.0f32..1.0,
        points in proptest::collection::vec(unit_point(), 1..40),
    ) {
        // Shift the output biases so that every class wins somewhere.
        let layout = w.layout().unwrap();
        let out = layout.num_layers() - 1;
        let (fan_in, fan_out) = layout.layer_dims(out);
        let bias = layout.layer_offset(out) + fan_in * fan_out;
        for (c, b) in w.params[bias..bias + fan_out].iter_mut().enumerate() {
            *b += shift * (c as f32 - 1.0);
        }
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let k = model.num_classes();
        let (xyz, t): (Vec<_>, Vec<_>) = points.iter().map(|&p| to_world(&w.domain, p)).unzip();
        let mut batch = vec![0u32; xyz.len()];
        let mut scratch = Scratch::boxed();
        model.label_batch(&mut scratch, &xyz, &t, &mut batch).unwrap();
        for (i, (x, t)) in xyz.iter().zip(&t).enumerate() {
            let mut f = vec![0.0; k];
            model.eval(*x, *t, &mut f).unwrap();
            let mut want = 0;
            let mut best = 0.0f32;
            for (c, &v) in f.iter().enumerate() {
                if v < best {
                    best = v;
                    want = c as u32 + 1;
                }
            }
            prop_assert_eq!(model.label(*x, *t), want);
            prop_assert_eq!(argmin_label(&f), want);
            // The batch path sums in another order: accept a different label only on a near-tie.
            if batch[i] != want {
                let value = |l: u32| if l == 0 { 0.0 } else { f[l as usize - 1] };
                prop_assert!((value(batch[i]) - value(want)).abs() < 1e-4, "batch {} vs {}", batch[i], want);
            }
        }
    }
}
