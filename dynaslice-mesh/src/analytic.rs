//! Exact signed distance fields for tests: geometry is checked against closed-form volumes and
//! areas, which a trained network cannot give.

use super::field::PointField;

/// One analytic channel.
#[derive(Debug, Clone, Copy)]
pub enum Shape {
    /// Ball of radius `radius + rate · t` around `centre`.
    Sphere {
        centre: [f32; 3],
        radius: f32,
        rate: f32,
    },
    /// Torus around the z axis through `centre`: tube radius `minor` at distance `major`.
    Torus {
        centre: [f32; 3],
        major: f32,
        minor: f32,
    },
    /// Axis-aligned box `lo..hi`.
    Cuboid { lo: [f32; 3], hi: [f32; 3] },
}

impl Shape {
    /// A sphere whose radius grows at `rate` per unit time.
    pub fn sphere(centre: [f32; 3], radius: f32, rate: f32) -> Shape {
        Shape::Sphere {
            centre,
            radius,
            rate,
        }
    }

    /// Distance, gradient and time derivative at `p`, time `t`.
    fn eval(&self, p: [f32; 3], t: f32) -> (f32, [f32; 3], f32) {
        let sub = |c: [f32; 3]| -> [f32; 3] { std::array::from_fn(|a| p[a] - c[a]) };
        let norm = |v: [f32; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        match *self {
            Shape::Sphere {
                centre,
                radius,
                rate,
            } => {
                let d = sub(centre);
                let n = norm(d).max(1e-12);
                (n - radius - rate * t, d.map(|v| v / n), -rate)
            }
            Shape::Torus {
                centre,
                major,
                minor,
            } => {
                let d = sub(centre);
                let rho = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-12);
                let q = [rho - major, d[2]];
                let n = (q[0] * q[0] + q[1] * q[1]).sqrt().max(1e-12);
                let g = [q[0] / n * d[0] / rho, q[0] / n * d[1] / rho, q[1] / n];
                (n - minor, g, 0.0)
            }
            Shape::Cuboid { lo, hi } => {
                let c: [f32; 3] = std::array::from_fn(|a| (lo[a] + hi[a]) / 2.0);
                let half: [f32; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) / 2.0);
                let d = sub(c);
                let q: [f32; 3] = std::array::from_fn(|a| d[a].abs() - half[a]);
                let out: [f32; 3] = std::array::from_fn(|a| q[a].max(0.0) * d[a].signum());
                let n = norm(out);
                if n > 0.0 {
                    return (n, out.map(|v| v / n), 0.0);
                }
                let a = (0..3).max_by(|&i, &j| q[i].total_cmp(&q[j])).unwrap_or(0);
                let mut g = [0.0; 3];
                g[a] = d[a].signum();
                (q[a], g, 0.0)
            }
        }
    }
}

/// A K-channel analytic field, one [`Shape`] per channel.
pub struct Analytic {
    shapes: Vec<Shape>,
}

impl Analytic {
    /// The field with channel k = `shapes[k]`.
    pub fn new(shapes: Vec<Shape>) -> Analytic {
        Analytic { shapes }
    }
}

impl PointField for Analytic {
    fn num_classes(&self) -> usize {
        self.shapes.len()
    }

    fn value(&self, class: usize, p: [f32; 3], t: f32) -> f32 {
        self.shapes[class].eval(p, t).0
    }

    fn jet(&self, class: usize, p: [f32; 3], t: f32) -> (f32, [f32; 3], f32) {
        self.shapes[class].eval(p, t)
    }
}
