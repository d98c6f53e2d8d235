//! Dynamic shapes with exact analytic signed distance, the ground truth of the synthetic
//! benchmark. Domain: the cube [−1, 1]³, time t ∈ [0, 1]; every motion is periodic in t.
//!
//! Each SDF is exact (a true Euclidean distance, not a bound), so metrics computed from it
//! (IoU, Chamfer distance, paper Sec. 4) measure the reconstruction and nothing else: capsules,
//! circular-arc tubes, tori and spheres under rigid motions all have closed-form distances.

use std::f64::consts::{PI, TAU};
use std::str::FromStr;

/// A synthetic dynamic scene. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A capsule that pulsates (radius 0.30 ± 0.08) and translates across the domain.
    Blob,
    /// A thin tube (radius 0.08, 4 % of the domain's width) along a circular arc of fixed length
    /// whose bend angle goes from 0.5 to 2 rad and back.
    Tube,
    /// A torus (genus 1) whose radii breathe while it tilts and drifts.
    Torus,
    /// Three spheres ("chambers") with pulsating radii out of phase, kept pairwise touching
    /// (never overlapping) while the group rotates: a multi-class scene like heart chambers.
    Chambers,
}

impl Shape {
    /// Every shape, in benchmark order.
    pub const ALL: [Shape; 4] = [Shape::Blob, Shape::Tube, Shape::Torus, Shape::Chambers];

    /// The shape's name (`blob`, `tube`, `torus`, `chambers`).
    pub fn name(self) -> &'static str {
        match self {
            Shape::Blob => "blob",
            Shape::Tube => "tube",
            Shape::Torus => "torus",
            Shape::Chambers => "chambers",
        }
    }

    /// Class names; class k has source label k + 1.
    pub fn class_names(self) -> &'static [&'static str] {
        match self {
            Shape::Blob => &["blob"],
            Shape::Tube => &["tube"],
            Shape::Torus => &["torus"],
            Shape::Chambers => &["chamber a", "chamber b", "chamber c"],
        }
    }

    /// Whether the paper's thin-structure slicing (35 + 35 planes instead of 15 + 15) applies.
    pub fn is_thin(self) -> bool {
        self == Shape::Tube
    }

    /// Exact signed distance of class `class` at world point `x` and time `t` (negative inside).
    /// A class index out of range has no interior: +∞.
    pub fn sdf(self, class: usize, x: [f64; 3], t: f64) -> f64 {
        match (self, class) {
            (Shape::Blob, 0) => blob(x, t),
            (Shape::Tube, 0) => tube(x, t),
            (Shape::Torus, 0) => torus(x, t),
            (Shape::Chambers, k) if k < 3 => {
                let (centres, radii) = chambers(t);
                dist(x, centres[k]) - radii[k]
            }
            _ => f64::INFINITY,
        }
    }
}

impl FromStr for Shape {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Shape::ALL
            .into_iter()
            .find(|shape| shape.name() == s)
            .ok_or_else(|| format!("unknown shape `{s}` (blob, tube, torus, chambers)"))
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

fn blob(x: [f64; 3], t: f64) -> f64 {
    let c = [-0.3 + 0.6 * t, 0.15 * (TAU * t).sin(), 0.0];
    let r = 0.30 + 0.08 * (TAU * t).sin();
    // Axis tilted 60° from x towards z, half-length 0.25.
    let d = [0.125, 0.0, 0.25 * (PI / 3.0).sin()];
    let a = [c[0] - d[0], c[1] - d[1], c[2] - d[2]];
    let w = [x[0] - a[0], x[1] - a[1], x[2] - a[2]];
    let len2 = 4.0 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    let s = ((w[0] * 2.0 * d[0] + w[1] * 2.0 * d[1] + w[2] * 2.0 * d[2]) / len2).clamp(0.0, 1.0);
    let p = [
        a[0] + 2.0 * s * d[0],
        a[1] + 2.0 * s * d[1],
        a[2] + 2.0 * s * d[2],
    ];
    dist(x, p) - r
}

/// Tube radius (4 % of the domain's width of 2).
pub const TUBE_RADIUS: f64 = 0.08;

fn tube(x: [f64; 3], t: f64) -> f64 {
    // Arc of length 1.4 in the xz-plane, its midpoint fixed at (0.2, 0, 0), bending about y.
    let length = 1.4;
    let bend = 0.5 + 1.5 * (0.5 - 0.5 * (TAU * t).cos());
    let radius = length / bend;
    let centre = [0.2 - radius, 0.0, 0.0];
    let (a, b, w) = (x[0] - centre[0], x[2] - centre[2], x[1] - centre[1]);
    let angle = b.atan2(a);
    let d = if angle.abs() <= 0.5 * bend {
        ((a.hypot(b) - radius).powi(2) + w * w).sqrt()
    } else {
        // Outside the arc's angular span the nearest arc point is an endpoint.
        let e = 0.5 * bend * angle.signum();
        let end = [
            centre[0] + radius * e.cos(),
            0.0,
            centre[2] + radius * e.sin(),
        ];
        dist(x, end)
    };
    d - TUBE_RADIUS
}

fn torus(x: [f64; 3], t: f64) -> f64 {
    let major = 0.5 + 0.1 * (TAU * t).sin();
    let minor = 0.18 + 0.05 * (TAU * t).cos();
    let tilt = 0.6 * (PI * t).sin();
    let c = [0.1 * (TAU * t).sin(), 0.0, 0.0];
    let p = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
    // Rotate by −tilt about x into the torus frame (rigid, so distances are preserved).
    let (s, co) = tilt.sin_cos();
    let q = [p[0], co * p[1] + s * p[2], -s * p[1] + co * p[2]];
    (q[0].hypot(q[1]) - major).hypot(q[2]) - minor
}

/// Centres and radii of the three chambers at time `t`: sphere a at the origin of the group, b
/// along its x axis at distance r_a + r_b, c placed so both its distances are sums of radii
/// (pairwise tangent), then the group is centred, rotated about z and tilted about x.
pub fn chambers(t: f64) -> ([[f64; 3]; 3], [f64; 3]) {
    let base = [0.34, 0.29, 0.24];
    let radii: [f64; 3] =
        std::array::from_fn(|k| base[k] * (1.0 + 0.15 * (TAU * t + k as f64 * TAU / 3.0).sin()));
    let (ab, ac, bc) = (
        radii[0] + radii[1],
        radii[0] + radii[2],
        radii[1] + radii[2],
    );
    let cx = (ac * ac - bc * bc + ab * ab) / (2.0 * ab);
    let cy = (ac * ac - cx * cx).max(0.0).sqrt();
    let local = [[0.0, 0.0], [ab, 0.0], [cx, cy]];
    let mean = [(ab + cx) / 3.0, cy / 3.0];
    let spin = 0.5 * TAU * t;
    let tilt: f64 = 0.3;
    let centres = local.map(|p| {
        let (x, y) = (p[0] - mean[0], p[1] - mean[1]);
        let (x, y) = (
            x * spin.cos() - y * spin.sin(),
            x * spin.sin() + y * spin.cos(),
        );
        [x, y * tilt.cos(), y * tilt.sin()]
    });
    (centres, radii)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Exact distances have unit gradient almost everywhere (finite differences), and every
        /// class has an interior inside the domain.
        #[test]
        fn unit_gradient(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0, t in 0.0f64..1.0) {
            for shape in Shape::ALL {
                for k in 0..shape.class_names().len() {
                    let h = 1e-6;
                    let f = |d: [f64; 3]| shape.sdf(k, [x + d[0], y + d[1], z + d[2]], t);
                    let g = [
                        (f([h, 0.0, 0.0]) - f([-h, 0.0, 0.0])) / (2.0 * h),
                        (f([0.0, h, 0.0]) - f([0.0, -h, 0.0])) / (2.0 * h),
                        (f([0.0, 0.0, h]) - f([0.0, 0.0, -h])) / (2.0 * h),
                    ];
                    let norm = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                    // Kinks (medial axes) have measure zero: a random point lands within h of
                    // one with negligible probability.
                    prop_assert!((norm - 1.0).abs() < 1e-4,
                        "{} class {}: |∇f| = {}", shape.name(), k, norm);
                }
            }
        }

        #[test]
        fn chambers_touch_without_overlapping(t in 0.0f64..1.0) {
            let (c, r) = chambers(t);
            for (i, j) in [(0, 1), (0, 2), (1, 2)] {
                prop_assert!((dist(c[i], c[j]) - r[i] - r[j]).abs() < 1e-12);
            }
            for k in 0..3 {
                for coordinate in c[k] {
                    prop_assert!(coordinate.abs() + r[k] < 1.0, "inside the domain");
                }
            }
        }
    }

    #[test]
    fn tube_passes_through_its_midpoint_at_every_time() {
        for i in 0..=10 {
            let t = i as f64 / 10.0;
            assert!((tube([0.2, 0.0, 0.0], t) + TUBE_RADIUS).abs() < 1e-12);
            assert!((tube([0.2, TUBE_RADIUS, 0.0], t)).abs() < 1e-12);
        }
        assert!(blob([-0.3, 0.0, 0.0], 0.0) < 0.0);
        assert!(
            torus([0.5, 0.0, 0.0], 0.0) < 0.0 && torus([0.0; 3], 0.0) > 0.0,
            "genus 1"
        );
        assert_eq!("torus".parse::<Shape>(), Ok(Shape::Torus));
        assert!("cube".parse::<Shape>().is_err());
        assert_eq!(Shape::Blob.sdf(1, [0.0; 3], 0.0), f64::INFINITY);
    }
}
