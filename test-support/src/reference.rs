//! An independent f64 evaluation of the network, written from the paper's equations rather than
//! from the core's or the trainer's code, in the spirit of llm.c checking its hand-written passes
//! against a reference implementation: the core's derivatives (tests/gradients.rs) and the
//! trainer's hand-written loss gradients (dynaslice-train's gradient check) are checked against
//! central differences of it.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{Domain, Layout};

/// A network in f64, straight from Eq. 1, 2, 4, 9:
/// h⁰ = sin(ω_x x_n + clamp(ω_t, ±ω_t^max) t_n + φ), hⁱ = sin(Wⁱ hⁱ⁻¹ + bⁱ), f = σ(W h + b),
/// with ∇ₓf carried alongside by forward-mode tangents.
#[derive(Debug, Clone)]
pub struct Reference {
    layout: Layout,
    /// Parameters in the core's order (per layer Wᵀ then b).
    params: Vec<f64>,
    domain: Domain,
    /// ω_t^max of Eq. 4; infinite for no clamp.
    omega_t_max: f64,
}

impl Reference {
    /// The model a [`ModelWriter`] describes, its parameters widened to f64.
    pub fn new(writer: &ModelWriter) -> Reference {
        Reference {
            layout: writer.layout().expect("valid layout"),
            params: writer.params.iter().map(|&v| f64::from(v)).collect(),
            domain: writer.domain,
            omega_t_max: f64::from(writer.omega_t_max),
        }
    }

    /// The trainer's network: `params` in `layout`, in normalised units (the identity domain)
    /// and without the Eq. 4 clamp in the forward pass (the trainer projects ω_t after each
    /// step instead), its parameters widened to f64.
    pub fn unclamped(layout: Layout, params: &[f32]) -> Reference {
        Reference {
            layout,
            params: params.iter().map(|&v| f64::from(v)).collect(),
            domain: Domain::IDENTITY,
            omega_t_max: f64::INFINITY,
        }
    }

    /// f and ∇ₓf of every channel at the normalised input (x, y, z, t), in normalised units.
    pub fn normalised(&self, input: [f64; 4]) -> (Vec<f64>, Vec<[f64; 3]>) {
        let mut h = input.to_vec();
        // ∂h/∂x_d, seeded with the unit vectors of the three spatial inputs (t has none).
        let mut hd: Vec<[f64; 3]> = (0..4)
            .map(|i| std::array::from_fn(|d| if d == i { 1.0 } else { 0.0 }))
            .collect();
        for l in 0..self.layout.num_layers() {
            let (fan_in, fan_out) = self.layout.layer_dims(l);
            let off = self.layout.layer_offset(l);
            let w = |i: usize, j: usize| {
                let v = self.params[off + i * fan_out + j];
                // Eq. 4: ω_t, row t of the first layer's Wᵀ, is clamped where it is used.
                if l == 0 && i == 3 {
                    v.clamp(-self.omega_t_max, self.omega_t_max)
                } else {
                    v
                }
            };
            let mut z = Vec::with_capacity(fan_out);
            let mut zd = Vec::with_capacity(fan_out);
            for j in 0..fan_out {
                let mut zj = self.params[off + fan_in * fan_out + j];
                let mut zdj = [0.0; 3];
                for (i, (hi, hdi)) in h.iter().zip(&hd).enumerate() {
                    let wij = w(i, j);
                    zj += wij * hi;
                    for (zdjd, hdid) in zdj.iter_mut().zip(hdi) {
                        *zdjd += wij * hdid;
                    }
                }
                z.push(zj);
                zd.push(zdj);
            }
            if l < self.layout.num_sine_layers() {
                hd = z
                    .iter()
                    .zip(&zd)
                    .map(|(v, g)| g.map(|gd| v.cos() * gd))
                    .collect();
                h = z.iter().map(|v| v.sin()).collect();
            } else {
                (h, hd) = (z, zd);
            }
        }
        (h, hd)
    }

    /// The K world-unit signed distances at world (x, t).
    pub fn eval(&self, x: [f64; 3], t: f64) -> Vec<f64> {
        let d = &self.domain;
        let space = |i: usize| (x[i] - f64::from(d.center[i])) / f64::from(d.scale[i]);
        let time = (t - f64::from(d.time_origin)) / f64::from(d.time_span);
        let (f, _) = self.normalised([space(0), space(1), space(2), time]);
        f.iter().map(|v| v * f64::from(d.output_scale)).collect()
    }

    /// Central differences in f64 of every channel along world input `axis` (0..3 space,
    /// 3 time).
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

    /// Central differences with step `h` of `loss` with respect to every parameter, in the
    /// core's order.
    pub fn parameter_gradient(&self, h: f64, loss: impl Fn(&Reference) -> f64) -> Vec<f64> {
        let mut moved = self.clone();
        (0..self.params.len())
            .map(|i| {
                let v = moved.params[i];
                moved.params[i] = v + h;
                let plus = loss(&moved);
                moved.params[i] -= 2.0 * h;
                let minus = loss(&moved);
                moved.params[i] = v;
                (plus - minus) / (2.0 * h)
            })
            .collect()
    }
}
