//! A hand-built model with two closed surfaces, and the reference volume of its classes, for the
//! VTK adapter check in scripts/ci-ffi.sh (the VTK mesh's enclosed volume must match).
//!
//! ```text
//! cargo run --release -p dynaslice-ffi --example sphere_fixture -- write MODEL.dsm
//! cargo run --release -p dynaslice-ffi --example sphere_fixture -- volume MODEL.dsm CLASS T N
//! ```
//!
//! The network has one sine layer: with u = x − c in normalised units, a unit
//! sin(ε u + π/2 − ε c) = cos(ε u) gives q(u) = (2/ε²)(1 − cos ε u) ≈ u², monotone in |u| up
//! to π/ε, so f^k = (Σ_axes q(u) − r_k²(t)) / (2 r_k) ≈ |x − c_k| − r_k near the surface and its
//! zero set is a closed, slightly squarish sphere. Class 1 breathes: r₁² = r² + β sin(2π t).
//! `volume` counts the cells of an N³ grid over the model's bounds where f^k < 0 (through the
//! core's batch path), so it measures the model itself, not the sphere it approximates; the
//! counting error is below 0.3% at N = 256 for these radii (the surface crosses ~4·10⁵ cells
//! whose errors largely cancel).
//!
//! Why not `dynaslice_test_support::spheres`: those are spheres exact to O(ε²) with ε = 0.1, so
//! their output weights are ~25 times larger than these and f carries that much more f32
//! rounding, which the VTK check's central differences (steps of ~0.01 mm) turn into a gradient
//! gap of ~0.2 (measured in this domain), beyond the check's 0.05. This fixture trades
//! exactness (its volume is counted, not known) for a well-conditioned f, and breathes
//! periodically in t.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{Domain, Model, ModelBytes, Scratch};
use std::f32::consts::{FRAC_PI_2, PI};
use std::path::Path;

/// Frequency of the quadratic-approximating units (ε above).
const EPS: f32 = 0.5;
/// (centre, radius, breathing amplitude β of r²) per class, normalised units.
const SPHERES: [([f32; 3], f32, f32); 2] =
    [([0.0, 0.0, 0.0], 0.5, 0.05), ([0.5, 0.3, 0.2], 0.3, 0.0)];

fn write_model() -> Vec<u8> {
    let k = SPHERES.len();
    let width = 3 * k + 1; // three axis units per class, one time unit
    let mut first_w = vec![0.0f32; 4 * width]; // Wᵀ: rows x, y, z, t
    let mut first_b = vec![0.0f32; width];
    let mut out_w = vec![0.0f32; width * k]; // Wᵀ: one row per hidden unit
    let mut out_b = vec![0.0f32; k];
    let q = 2.0 / (EPS * EPS);
    for (c, &(centre, r, beta)) in SPHERES.iter().enumerate() {
        for axis in 0..3 {
            let j = 3 * c + axis;
            first_w[axis * width + j] = EPS;
            first_b[j] = FRAC_PI_2 - EPS * centre[axis];
            out_w[j * k + c] = -q / (2.0 * r);
        }
        out_b[c] = (3.0 * q - r * r) / (2.0 * r);
        out_w[(width - 1) * k + c] = -beta / (2.0 * r);
    }
    first_w[3 * width + width - 1] = 2.0 * PI; // sin(2π t): one breath over the time range
    let mut w = ModelWriter::random_siren(&[width as u32], k as u32, 0);
    w.params = [first_w, first_b, out_w, out_b].concat();
    w.domain = Domain {
        center: [10.0, -5.0, 3.0],
        scale: [50.0; 3],
        time_origin: 0.0,
        time_span: 1.0,
        output_scale: 50.0,
    };
    w.classes = vec![("breathing sphere".into(), 1), ("small sphere".into(), 2)];
    w.metadata = "sphere fixture of dynaslice-ffi/examples/sphere_fixture.rs".into();
    w.to_bytes()
}

/// Volume of {f^class < 0} at time `t`: cells of an n³ grid over the bounds, by their centres.
fn volume(model: &Model, class: usize, t: f32, n: usize) -> f64 {
    let k = model.num_classes();
    let (lo, hi) = model.domain().bounds();
    let h: [f32; 3] = std::array::from_fn(|d| (hi[d] - lo[d]) / n as f32);
    let mut scratch = Scratch::boxed();
    let (mut xyz, times) = (vec![[0.0f32; 3]; n * n], vec![t; n * n]);
    let mut f = vec![0.0f32; n * n * k];
    let mut inside = 0u64;
    for iz in 0..n {
        for iy in 0..n {
            for ix in 0..n {
                let i = [ix, iy, iz];
                xyz[iy * n + ix] = std::array::from_fn(|d| lo[d] + (i[d] as f32 + 0.5) * h[d]);
            }
        }
        model
            .eval_batch(&mut scratch, &xyz, &times, &mut f)
            .expect("batch sizes match");
        inside += f.chunks_exact(k).filter(|row| row[class - 1] < 0.0).count() as u64;
    }
    inside as f64 * h.iter().map(|&v| v as f64).product::<f64>()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: sphere_fixture write MODEL.dsm | volume MODEL.dsm CLASS T N";
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["write", path] => std::fs::write(path, write_model()).expect("write the model"),
        ["volume", path, class, t, n] => {
            let bytes = ModelBytes::read(Path::new(path)).expect("read the model");
            let model = bytes.model().expect("valid model");
            let class: usize = class.parse().expect("CLASS is 1..=K");
            assert!((1..=model.num_classes()).contains(&class), "CLASS is 1..=K");
            let v = volume(&model, class, t.parse().expect("T"), n.parse().expect("N"));
            println!("{v:.3}");
        }
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    }
}
