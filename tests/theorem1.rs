//! Theorem 1 and the temporal band limit (Eq. 2–4), checked on random networks.
//!
//! Theorem 1: every hidden unit is a sum of α sin(⟨k, ω_x⟩·x + ⟨k, ω_t⟩·t + λ) with integer k,
//! so if every ω_t entry is an integer multiple of a base ω, all temporal frequencies are, and
//! f is periodic in t with period 2π/ω. Clamping ω_t (Eq. 4) therefore bounds the temporal
//! content of the whole network.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{Domain, ModelBytes};
use dynaslice_tests::strategies::{model, to_world, unit_point};
use proptest::prelude::*;

/// Offset of ω_t (row 3 of the first layer's Wᵀ) in the parameters.
fn omega_t_range(w: &ModelWriter) -> std::ops::Range<usize> {
    let width = w.widths[0] as usize;
    3 * width..4 * width
}

fn eval(w: &ModelWriter, x: [f32; 3], t: f32) -> Vec<f32> {
    let bytes = ModelBytes::copy_from(&w.to_bytes());
    let model = bytes.model().unwrap();
    let mut f = vec![0.0; model.num_classes()];
    model.eval(x, t, &mut f).unwrap();
    f
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// ω_t ∈ ω·Z ⇒ f(x, t + 2π/ω) = f(x, t). In normalised time the phase ⟨k, ω_t⟩t reaches
    /// |t|·Σ|ω_t| ≲ 10², where one f32 ulp is ~8e-6 rad; through a few layers of weights of
    /// norm ~√6 the output moves by ≲ 1e-3 of its scale, far below the O(1) change a
    /// non-integer frequency causes over a whole period.
    #[test]
    fn integer_temporal_frequencies_make_f_periodic(
        mut w in model(),
        multiples in proptest::collection::vec(-3i32..=3, 48),
        base_cycles in 1u32..=3,
        p in unit_point(),
    ) {
        let base = 2.0 * std::f32::consts::PI * base_cycles as f32; // ω, normalised time
        let range = omega_t_range(&w);
        for (v, m) in w.params[range].iter_mut().zip(multiples.iter().cycle()) {
            *v = base * *m as f32;
        }
        w.omega_t_max = base * 3.0;
        let period = w.domain.time_span / base_cycles as f32; // 2π/ω in world time
        let (x, t) = to_world(&w.domain, p);
        let a = eval(&w, x, t);
        let b = eval(&w, x, t + period);
        let scale = w.domain.output_scale;
        for (fa, fb) in a.iter().zip(&b) {
            prop_assert!((fa - fb).abs() <= 2e-3 * scale, "f(t) = {fa}, f(t + T) = {fb}");
        }
    }

    /// ω_t = 0 ⇒ ∂f/∂t = 0 exactly: the t tangent starts at zero and every layer multiplies it.
    #[test]
    fn zero_temporal_frequencies_give_zero_time_derivative(mut w in model(), p in unit_point()) {
        let range = omega_t_range(&w);
        w.params[range].fill(0.0);
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let k = model.num_classes();
        let (x, t) = to_world(&w.domain, p);
        let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![1.0; k]);
        model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
        prop_assert!(d.iter().all(|&v| v == 0.0), "∂f/∂t = {d:?}");
    }

    /// |∂f^k/∂t| ≤ (σ/τ)·‖W_out‖₂·Π‖Wⁱ‖₂·‖clamp(ω_t)‖₂.
    ///
    /// Derivation: ∂h⁰/∂t_n = cos(z⁰) ⊙ ω̃_t with ω̃_t the clamped ω_t, and
    /// ∂hⁱ/∂t_n = cos(zⁱ) ⊙ Wⁱ ∂hⁱ⁻¹/∂t_n. Since |cos| ≤ 1 the diagonal factors have norm ≤ 1,
    /// so ‖∂hⁱ/∂t_n‖₂ ≤ ‖Wⁱ‖₂ ‖∂hⁱ⁻¹/∂t_n‖₂ and ‖∂f_n/∂t_n‖₂ ≤ ‖W_out‖₂ Πᵢ‖Wⁱ‖₂ ‖ω̃_t‖₂; world
    /// units multiply by σ/τ. Each ‖W‖₂ is taken from above by [`spectral_norm_bound`] (at most
    /// 3.3% over it for these widths), so the product is the spectral bound, never smaller.
    #[test]
    fn time_derivative_obeys_the_lipschitz_bound(w in model(), p in unit_point()) {
        let layout = w.layout().unwrap();
        let clamped = w.params[omega_t_range(&w)].iter().map(|v| v.clamp(-w.omega_t_max, w.omega_t_max) as f64);
        let mut bound = clamped.map(|v| v * v).sum::<f64>().sqrt();
        for l in 1..layout.num_layers() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let off = layout.layer_offset(l);
            let wt: Vec<f64> = w.params[off..off + fan_in * fan_out].iter().map(|&v| v as f64).collect();
            bound *= spectral_norm_bound(&wt, fan_in, fan_out);
        }
        bound *= (w.domain.output_scale / w.domain.time_span) as f64;
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        let model = bytes.model().unwrap();
        let k = model.num_classes();
        let (x, t) = to_world(&w.domain, p);
        let (mut f, mut g, mut d) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model.eval_jacobian(x, t, &mut f, &mut g, &mut d).unwrap();
        for v in d {
            prop_assert!((v.abs() as f64) <= bound * (1.0 + 1e-4), "|∂f/∂t| = {v} > bound {bound}");
        }
    }

    /// A stored ω_t beyond ω_t^max is clamped at evaluation: the model answers exactly like the
    /// same model with the clamped values stored.
    #[test]
    fn stored_temporal_frequencies_are_clamped(mut w in model(), p in unit_point(), factor in 1.5f32..20.0) {
        w.omega_t_max = 2.0;
        let range = omega_t_range(&w);
        for (i, v) in w.params[range.clone()].iter_mut().enumerate() {
            *v = if i % 2 == 0 { factor * 2.0 } else { -factor * 2.0 * (i as f32 + 1.0) };
        }
        let mut clamped = w.clone();
        clamped.params[range].iter_mut().for_each(|v| *v = v.clamp(-2.0, 2.0));
        let (x, t) = to_world(&w.domain, p);
        prop_assert_eq!(eval(&w, x, t), eval(&clamped, x, t));
    }
}

/// Repeated squarings in [`spectral_norm_bound`]: p = 2⁶ = 64.
const SQUARINGS: u32 = 6;

/// An upper bound on the spectral norm ‖M‖₂ of the `rows`×`cols` row-major matrix `m`, within a
/// factor cols^(1/2p) of it (1.033 for 64 columns): ‖M‖₂² = λ_max(MᵀM) ≤ tr((MᵀM)^p)^(1/p),
/// since MᵀM is positive semi-definite and the trace sums its p-th eigenvalue powers. (MᵀM)^p
/// comes from repeated squaring, rescaled by its largest entry each time (the scale kept as a
/// logarithm) so it stays finite. Rounding can put it below ‖M‖₂ by a relative ~1e-16.
fn spectral_norm_bound(m: &[f64], rows: usize, cols: usize) -> f64 {
    let n = cols;
    let mut a: Vec<f64> = (0..n * n)
        .map(|ij| {
            (0..rows)
                .map(|r| m[r * cols + ij / n] * m[r * cols + ij % n])
                .sum()
        })
        .collect();
    let mut log_scale = 0.0f64;
    for _ in 0..SQUARINGS {
        let c = a.iter().fold(0.0f64, |x, v| x.max(v.abs()));
        if c == 0.0 {
            return 0.0;
        }
        a.iter_mut().for_each(|v| *v /= c);
        log_scale = 2.0 * (log_scale + c.ln());
        a = (0..n * n)
            .map(|ij| {
                (0..n)
                    .map(|l| a[(ij / n) * n + l] * a[l * n + ij % n])
                    .sum()
            })
            .collect();
    }
    let trace: f64 = (0..n).map(|i| a[i * n + i]).sum();
    let p = f64::from(1u32 << SQUARINGS);
    // λ_max ≤ (trace · e^scale)^(1/p); ‖M‖₂ = √λ_max.
    ((trace.ln() + log_scale) / p / 2.0).exp()
}

#[test]
fn spectral_norm_bound_is_tight_and_above() {
    // diag(3, 1, 0.5) rotated: ‖M‖₂ = 3 exactly.
    let (c, s) = (0.6f64, 0.8f64);
    let m = [3.0 * c, -3.0 * s, 0.0, 1.0 * s, 1.0 * c, 0.0, 0.0, 0.0, 0.5];
    let b = spectral_norm_bound(&m, 3, 3);
    // Above up to f64 rounding (relative 1e-16), far inside the 1e-4 slack of the bound's use.
    assert!(
        (3.0 * (1.0 - 1e-12)..3.0 * 3f64.powf(1.0 / 128.0)).contains(&b),
        "{b}"
    );
    // A rank-one 4×64 matrix u vᵀ: ‖M‖₂ = ‖u‖‖v‖.
    let u = [1.0, -2.0, 0.5, 3.0];
    let v: Vec<f64> = (0..64)
        .map(|j| ((j * 37 % 11) as f64 - 5.0) * 0.1)
        .collect();
    let m: Vec<f64> = (0..4 * 64).map(|ij| u[ij / 64] * v[ij % 64]).collect();
    let exact =
        u.iter().map(|x| x * x).sum::<f64>().sqrt() * v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let b = spectral_norm_bound(&m, 4, 64);
    assert!(
        b >= exact * (1.0 - 1e-12) && b <= exact * 1.04,
        "{b} vs {exact}"
    );
}

/// The world time of the identity domain is normalised time: a sanity anchor for the tests
/// above, which rely on `Domain::time_span` to convert periods.
#[test]
fn identity_domain_period_is_two_pi_over_omega() {
    let mut w = ModelWriter::random_siren(&[16, 16], 1, 1);
    w.domain = Domain::IDENTITY;
    let range = omega_t_range(&w);
    w.params[range]
        .iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v = std::f32::consts::PI * (i % 3) as f32);
    w.omega_t_max = 10.0;
    let a = eval(&w, [0.2, 0.1, -0.3], 0.25);
    let b = eval(&w, [0.2, 0.1, -0.3], 2.25); // period 2π/π = 2
    let c = eval(&w, [0.2, 0.1, -0.3], 1.25); // half a period: differs
    assert!((a[0] - b[0]).abs() < 1e-4, "{a:?} vs {b:?}");
    assert!((a[0] - c[0]).abs() > 1e-3, "{a:?} vs {c:?}");
}
