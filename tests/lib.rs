//! Shared helpers of DynaSlice's cross-crate tests: an independent f64 reference evaluation of
//! the network, written from the paper's equations rather than from the core's code, in the
//! spirit of llm.c checking its hand-written passes against a reference implementation.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::Layout;

/// f64 evaluation of a model held by a [`ModelWriter`], straight from Eq. 1, 2, 4, 9:
/// h⁰ = sin(ω_x x_n + clamp(ω_t, ±ω_t^max) t_n + φ), hⁱ = sin(Wⁱ hⁱ⁻¹ + bⁱ), f = σ(W h + b).
pub struct Reference {
    layout: Layout,
    params: Vec<f64>,
    writer: ModelWriter,
}

impl Reference {
    /// Wraps a model description (its parameters widened to f64).
    pub fn new(writer: &ModelWriter) -> Reference {
        Reference {
            layout: writer.layout().expect("valid layout"),
            params: writer.params.iter().map(|&v| v as f64).collect(),
            writer: writer.clone(),
        }
    }

    /// The K world-unit signed distances at world (x, t).
    pub fn eval(&self, x: [f64; 3], t: f64) -> Vec<f64> {
        let d = &self.writer.domain;
        let mut input = vec![0.0; 4];
        for i in 0..3 {
            input[i] = (x[i] - d.center[i] as f64) / d.scale[i] as f64;
        }
        input[3] = (t - d.time_origin as f64) / d.time_span as f64;
        let mut h = input;
        let omega_max = self.writer.omega_t_max as f64;
        for l in 0..self.layout.num_layers() {
            let (fan_in, fan_out) = self.layout.layer_dims(l);
            let off = self.layout.layer_offset(l);
            let w = |i: usize, j: usize| {
                let v = self.params[off + i * fan_out + j];
                if l == 0 && i == 3 {
                    v.clamp(-omega_max, omega_max)
                } else {
                    v
                }
            };
            let mut z: Vec<f64> = (0..fan_out)
                .map(|j| self.params[off + fan_in * fan_out + j])
                .collect();
            for (j, zj) in z.iter_mut().enumerate() {
                for (i, hi) in h.iter().enumerate() {
                    *zj += w(i, j) * hi;
                }
            }
            let is_sine = l < self.layout.num_sine_layers();
            h = if is_sine {
                z.iter().map(|v| v.sin()).collect()
            } else {
                z
            };
        }
        h.iter().map(|v| v * d.output_scale as f64).collect()
    }

    /// Central differences in f64 of every channel along input `axis` (0..3 space, 3 time).
    pub fn central_difference(&self, x: [f64; 3], t: f64, axis: usize, step: f64) -> Vec<f64> {
        let shifted = |s: f64| {
            let (mut x, mut t) = (x, t);
            if axis < 3 {
                x[axis] += s
            } else {
                t += s
            }
            self.eval(x, t)
        };
        let (plus, minus) = (shifted(step), shifted(-step));
        plus.iter()
            .zip(&minus)
            .map(|(p, m)| (p - m) / (2.0 * step))
            .collect()
    }
}

/// Proptest strategies shared by the tests.
pub mod strategies {
    use dynaslice_core::format::ModelWriter;
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
