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
///
/// A motion model is the composite f(x, t) = σ g(y, t_n) with y = x_n + u(x_n, t_n) (clamped
/// to ±2²⁰ like x_n) and u a second network of the same form with 3 outputs and its own ω_t^max;
/// its ∇ₓf by the chain rule through y: ∇_{x_n} f = (I + J_u)ᵀ ∇_y g.
#[derive(Debug, Clone)]
pub struct Reference {
    layout: Layout,
    /// Parameters in the core's order (per layer Wᵀ then b).
    params: Vec<f64>,
    domain: Domain,
    /// ω_t^max of Eq. 4; infinite for no clamp.
    omega_t_max: f64,
    /// The motion network u of a motion model (in normalised units, the identity domain).
    motion: Option<Box<Reference>>,
}

/// Largest normalised coordinate, as `dynaslice_core::domain::NORMALISED_LIMIT` (2²⁰).
const LIMIT: f64 = 1_048_576.0;

impl Reference {
    /// The model a [`ModelWriter`] describes, its parameters widened to f64, its motion
    /// network included.
    pub fn new(writer: &ModelWriter) -> Reference {
        let widen = |p: &[f32]| p.iter().map(|&v| f64::from(v)).collect();
        Reference {
            layout: writer.layout().expect("valid layout"),
            params: widen(&writer.params),
            domain: writer.domain,
            omega_t_max: f64::from(writer.omega_t_max),
            motion: writer.motion.as_ref().map(|m| {
                Box::new(Reference {
                    layout: m.layout().expect("valid motion layout"),
                    params: widen(&m.params),
                    domain: Domain::IDENTITY,
                    omega_t_max: f64::from(m.omega_t_max),
                    motion: None,
                })
            }),
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
            motion: None,
        }
    }

    /// f and ∇ₓf of every channel at the normalised input (x, y, z, t), in normalised units;
    /// for a motion model, through the warp y = x_n + u(x_n, t_n).
    pub fn normalised(&self, input: [f64; 4]) -> (Vec<f64>, Vec<[f64; 3]>) {
        let Some(motion) = &self.motion else {
            return self.network(input);
        };
        // u and J_u[e][d] = ∂u_e/∂x_d.
        let (u, ju) = motion.network(input);
        let y = std::array::from_fn(|d| {
            if d < 3 {
                (input[d] + u[d]).clamp(-LIMIT, LIMIT)
            } else {
                input[3]
            }
        });
        let (g, grad_g) = self.network(y);
        // ∂f/∂x_d = Σ_e ∂g/∂y_e (δ_ed + ∂u_e/∂x_d).
        let grad = grad_g
            .iter()
            .map(|gy| {
                std::array::from_fn(|d| {
                    (0..3)
                        .map(|e| gy[e] * (f64::from(u8::from(e == d)) + ju[e][d]))
                        .sum()
                })
            })
            .collect();
        (g, grad)
    }

    /// The displacement u of a motion model at world (x, t), in world units (u_n times the
    /// domain's scale per axis); zero without motion.
    pub fn displacement(&self, x: [f64; 3], t: f64) -> [f64; 3] {
        let Some(motion) = &self.motion else {
            return [0.0; 3];
        };
        let (u, _) = motion.network(self.normalise(x, t));
        std::array::from_fn(|d| u[d] * f64::from(self.domain.scale[d]))
    }

    /// World (x, t) to the normalised input (x_n, t_n).
    fn normalise(&self, x: [f64; 3], t: f64) -> [f64; 4] {
        let d = &self.domain;
        let space = |i: usize| (x[i] - f64::from(d.center[i])) / f64::from(d.scale[i]);
        let time = (t - f64::from(d.time_origin)) / f64::from(d.time_span);
        [space(0), space(1), space(2), time]
    }

    /// One network's outputs and their ∇ₓ at the normalised input.
    fn network(&self, input: [f64; 4]) -> (Vec<f64>, Vec<[f64; 3]>) {
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
        let (f, _) = self.normalised(self.normalise(x, t));
        let sigma = f64::from(self.domain.output_scale);
        f.iter().map(|v| v * sigma).collect()
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
