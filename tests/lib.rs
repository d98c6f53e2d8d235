//! Shared helpers of DynaSlice's cross-crate tests: proptest strategies for random models and
//! points (the f64 reference network is `dynaslice_test_support::reference`).

#![warn(missing_docs)]

/// Proptest strategies shared by the tests.
pub mod strategies {
    use dynaslice_core::format::{ModelWriter, WeightType};
    use dynaslice_core::Domain;
    use proptest::prelude::*;

    /// A random SIREN-initialised model: 1–4 sine layers of width 4–48, 1–4 classes, and a
    /// random world domain (so the world ↔ normalised scaling is exercised too).
    pub fn model() -> impl Strategy<Value = ModelWriter> {
        (
            proptest::collection::vec(4u32..48, 1..=4),
            1u32..=4,
            any::<u64>(),
            proptest::array::uniform3(-50.0f32..50.0),
            proptest::array::uniform3(5.0f32..80.0),
            (-2.0f32..2.0, 0.5f32..5.0, 1.0f32..20.0),
        )
            .prop_map(|(widths, k, seed, center, scale, (t0, span, sigma))| {
                let mut w = ModelWriter::random_siren(&widths, k, seed);
                w.domain = Domain {
                    center,
                    scale,
                    time_origin: t0,
                    time_span: span,
                    output_scale: sigma,
                };
                w
            })
    }

    /// A random motion model: a [`model`] with a SIREN-initialised motion network of 1–3 sine
    /// layers of width 4–32 ([`ModelWriter::random_motion`]: its own ω_t^max, half its ω_t
    /// clamped, displacements of a few tenths of the normalised cube), f32 or f16 weights.
    pub fn motion_model() -> impl Strategy<Value = ModelWriter> {
        (
            model(),
            proptest::collection::vec(4u32..32, 1..=3),
            any::<u64>(),
            any::<bool>(),
        )
            .prop_map(|(mut w, motion_widths, seed, half)| {
                w.motion = ModelWriter::random_motion(&[4], 1, &motion_widths, seed).motion;
                if half {
                    w.weight_type = WeightType::F16;
                }
                w
            })
    }

    /// A [`model`] or a [`motion_model`], even odds.
    pub fn any_model() -> impl Strategy<Value = ModelWriter> {
        prop_oneof![model(), motion_model()]
    }

    /// A point inside the model's world domain and time range, as fractions of it.
    pub fn unit_point() -> impl Strategy<Value = ([f32; 3], f32)> {
        (proptest::array::uniform3(-0.95f32..0.95), 0.0f32..1.0)
    }

    /// Maps a unit point into the model's world domain.
    pub fn to_world(d: &Domain, (u, s): ([f32; 3], f32)) -> ([f32; 3], f32) {
        let x = std::array::from_fn(|i| d.center[i] + u[i] * d.scale[i]);
        (x, d.time_origin + s * d.time_span)
    }
}
