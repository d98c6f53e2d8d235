//! Growing spheres as a hand-built model file: a ground truth in closed form for testing label
//! volumes and metrics through real model files (like `ModelWriter::random_siren`, a fixture).
//!
//! One sine layer of 7 units feeds every class: cos(εx_a) (a phase of π/2 on sin) and
//! sin(ε'x_a) for each axis a, and sin(ε't). Since 2(1 − cos εx)/ε² = x² − ε²x⁴/12 + … and
//! sin(ε'x)/ε' = x − ε'²x³/6 + …, the output layer combines them into, per class,
//! f = (|x − c|² − R² − 2RVt) / (2R) in normalised units: negative exactly inside the sphere
//! of radius r(t) = √(R² + 2RVt) (up to the O(ε²) terms, < 1e-3 of the radius), and equal to
//! the signed distance to first order at the surface. ε = 0.1 keeps the x² term above f32
//! rounding of cos(εx) ≈ 1; ε' = 0.01 since sin(ε'x) is small and rounds relative to itself.

use dynaslice_core::format::{ModelWriter, MotionWriter, WeightType};
use dynaslice_core::Domain;
use std::f64::consts::{FRAC_PI_2, PI};

const EPS: f64 = 0.1;
const EPS_LINEAR: f64 = 0.01;

/// The world domain of [`model`]: centre (10, −5, 2) mm, half-extent 20 mm, times 0..2 s, so
/// that tests exercise the world ↔ normalised maps.
pub const SPHERES_DOMAIN: Domain = Domain {
    center: [10.0, -5.0, 2.0],
    scale: [20.0; 3],
    time_origin: 0.0,
    time_span: 2.0,
    output_scale: 20.0,
};

/// One class: a sphere in normalised coordinates whose squared radius grows linearly in
/// normalised time, r(t)² = R² + 2RVt (growth rate V at t = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre, normalised.
    pub centre: [f64; 3],
    /// Radius R at normalised time 0.
    pub radius: f64,
    /// V.
    pub rate: f64,
}

impl Sphere {
    /// The sphere of normalised centre `centre`, radius `radius` at time 0, growth rate `rate`.
    pub fn new(centre: [f64; 3], radius: f64, rate: f64) -> Sphere {
        Sphere {
            centre,
            radius,
            rate,
        }
    }

    fn normalise(x: [f64; 3], t: f64) -> ([f64; 3], f64) {
        let d = SPHERES_DOMAIN;
        (
            std::array::from_fn(|a| (x[a] - f64::from(d.center[a])) / f64::from(d.scale[a])),
            (t - f64::from(d.time_origin)) / f64::from(d.time_span),
        )
    }

    /// World radius at world time `t`.
    pub fn world_radius(&self, t: f64) -> f64 {
        let tn = Self::normalise([0.0; 3], t).1;
        let r2 = self.radius * self.radius + 2.0 * self.radius * self.rate * tn;
        f64::from(SPHERES_DOMAIN.scale[0]) * r2.sqrt()
    }

    /// World centre.
    pub fn world_centre(&self) -> [f64; 3] {
        let d = SPHERES_DOMAIN;
        std::array::from_fn(|a| f64::from(d.center[a]) + f64::from(d.scale[a]) * self.centre[a])
    }

    /// Exact signed distance to the sphere at world point `x` and time `t`.
    pub fn world_distance(&self, x: [f64; 3], t: f64) -> f64 {
        let c = self.world_centre();
        let d = (0..3).map(|a| (x[a] - c[a]).powi(2)).sum::<f64>().sqrt();
        d - self.world_radius(t)
    }

    /// What the network computes (world units, without its O(ε²) terms): the quadratic
    /// f = σ(|x − c|² − r²)/(2R), whose argmin over classes is the model's Eq. 11 label.
    pub fn world_field(&self, x: [f64; 3], t: f64) -> f64 {
        let (xn, tn) = Self::normalise(x, t);
        let d2: f64 = (0..3).map(|a| (xn[a] - self.centre[a]).powi(2)).sum();
        let r2 = self.radius * self.radius + 2.0 * self.radius * self.rate * tn;
        f64::from(SPHERES_DOMAIN.output_scale) * (d2 - r2) / (2.0 * self.radius)
    }

    /// World volume at world time `t`.
    pub fn world_volume(&self, t: f64) -> f64 {
        4.0 / 3.0 * PI * self.world_radius(t).powi(3)
    }
}

/// The model file of `spheres`, one class each, named and labelled by `classes`, in
/// [`SPHERES_DOMAIN`] (the `world_*` methods of [`Sphere`] assume it).
pub fn model(spheres: &[Sphere], classes: &[(&str, i32)]) -> Vec<u8> {
    model_in(SPHERES_DOMAIN, spheres, classes)
}

/// [`model`] in another world domain (e.g. the identity map, where normalised sphere
/// coordinates are world coordinates).
pub fn model_in(domain: Domain, spheres: &[Sphere], classes: &[(&str, i32)]) -> Vec<u8> {
    writer_in(domain, spheres, classes).to_bytes()
}

/// The writer of [`model_in`]'s file, for tests that set more (e.g. its metadata).
pub fn writer_in(domain: Domain, spheres: &[Sphere], classes: &[(&str, i32)]) -> ModelWriter {
    assert_eq!(spheres.len(), classes.len(), "one (name, label) per sphere");
    let mut params = Vec::new();
    // First layer Wᵀ: rows x, y, z, t of the 7 units' frequencies, then the 7 phases.
    for input in 0..4 {
        params.extend((0..7).map(|unit| {
            let axis = if unit < 6 { unit % 3 } else { 3 };
            match (axis == input, unit) {
                (false, _) => 0.0,
                (true, 0..=2) => EPS,
                (true, _) => EPS_LINEAR,
            }
        }));
    }
    params.extend([FRAC_PI_2, FRAC_PI_2, FRAC_PI_2, 0.0, 0.0, 0.0, 0.0]);
    // Output layer Wᵀ: 7 rows of K classes, then K biases.
    for unit in 0..7 {
        params.extend(spheres.iter().map(|s| match unit {
            0..=2 => -1.0 / (EPS * EPS * s.radius),
            3..=5 => -s.centre[unit - 3] / (s.radius * EPS_LINEAR),
            _ => -s.rate / EPS_LINEAR,
        }));
    }
    params.extend(spheres.iter().map(|s| {
        let c2: f64 = s.centre.iter().map(|c| c * c).sum();
        3.0 / (EPS * EPS * s.radius) + (c2 - s.radius * s.radius) / (2.0 * s.radius)
    }));
    ModelWriter {
        widths: vec![7],
        classes: classes.iter().map(|(n, l)| (n.to_string(), *l)).collect(),
        domain,
        omega_t_max: 1.0,
        params: params.into_iter().map(|v| v as f32).collect(),
        metadata: String::new(),
        weight_type: WeightType::F32,
        motion: None,
    }
}

/// The frequency of [`translated`]'s one motion unit, sin(ε t_n).
pub const TRANSLATION_EPS: f64 = 0.5;

/// A motion model (file version 2): [`writer_in`]'s spheres in [`SPHERES_DOMAIN`] carried along
/// x by the motion network u(x, t) = (−a·sin(ε t_n)/ε, 0, 0) (normalised; ε =
/// [`TRANSLATION_EPS`]), one sine unit sin(ε t_n) with output weight −a/ε on u_x. Every sphere's
/// centre then moves along x by a·sin(ε t_n)/ε ≈ a·t_n normalised, [`translation_x`] in world
/// units, while it grows at its own rate: a rigid motion with a known displacement, for the
/// meshes carried through a series.
pub fn translated(spheres: &[Sphere], classes: &[(&str, i32)], a: f64) -> ModelWriter {
    let mut w = writer_in(SPHERES_DOMAIN, spheres, classes);
    // First layer Wᵀ (rows x, y, z, t of the one unit), its phase; then the output layer's
    // Wᵀ (one row of u_x, u_y, u_z) and biases.
    let params = [0.0, 0.0, 0.0, TRANSLATION_EPS, 0.0];
    let output = [-a / TRANSLATION_EPS, 0.0, 0.0, 0.0, 0.0, 0.0];
    w.motion = Some(MotionWriter {
        widths: vec![1],
        omega_t_max: 1.0,
        params: params.iter().chain(&output).map(|&v| v as f32).collect(),
    });
    w
}

/// How far (world units, along +x) [`translated`]'s motion has carried every sphere at world
/// time `t` from where it is at time 0.
pub fn translation_x(a: f64, t: f64) -> f64 {
    let d = SPHERES_DOMAIN;
    let tn = (t - f64::from(d.time_origin)) / f64::from(d.time_span);
    f64::from(d.scale[0]) * a * (TRANSLATION_EPS * tn).sin() / TRANSLATION_EPS
}

/// Three static spheres of `scale` times `radii`, in world coordinates (the identity domain):
/// with the synthetic benchmark's `dynaslice_synth::shapes::chambers(t)` at `scale` = 1, a
/// model of the exact shapes at that instant, for testing the benchmark's scores.
pub fn chambers_model((centres, radii): ([[f64; 3]; 3], [f64; 3]), scale: f64) -> Vec<u8> {
    let spheres: Vec<Sphere> = (0..3)
        .map(|c| Sphere::new(centres[c], scale * radii[c], 0.0))
        .collect();
    model_in(Domain::IDENTITY, &spheres, &[("a", 1), ("b", 2), ("c", 3)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_core::Model;

    #[test]
    fn the_network_computes_the_quadratic_field() {
        let s = [
            Sphere::new([0.1, -0.2, 0.05], 0.4, 0.2),
            Sphere::new([-0.3, 0.1, 0.0], 0.25, -0.05),
        ];
        let bytes = model(&s, &[("a", 1), ("b", 2)]);
        let m = Model::from_bytes(&bytes).unwrap();
        let mut f = [0.0f32; 2];
        for i in 0..200 {
            let u = |k: u32| ((i * 7919 + k * 104729) % 1000) as f64 / 1000.0;
            let x = [u(1), u(2), u(3)].map(|v| 20.0 * (1.8 * v - 0.9));
            let x = [x[0] + 10.0, x[1] - 5.0, x[2] + 2.0];
            let t = 2.0 * u(4);
            m.eval(x.map(|v| v as f32), t as f32, &mut f).unwrap();
            for c in 0..2 {
                let want = s[c].world_field(x, t);
                assert!(
                    (f64::from(f[c]) - want).abs() < 0.05,
                    "{c}: {} vs {want}",
                    f[c]
                );
            }
        }
        // On the surface the field is zero; at the centre it is −σr²/(2R).
        let c = s[0].world_centre();
        let on = [c[0] + s[0].world_radius(1.0), c[1], c[2]];
        assert!(s[0].world_field(on, 1.0).abs() < 1e-9);
        assert!(s[0].world_distance(on, 1.0).abs() < 1e-9);
    }
}
