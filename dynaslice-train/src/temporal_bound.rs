//! Eq. 4, the temporal band limit, in one place: the bound ω_t^max = c·π/Δt from the data's
//! annotated frames ([`temporal_bound`]), the first layer's ω_t initialised inside it
//! ([`initial_limit`], used by [`Network::siren`](crate::network::Network::siren)), and the
//! projection back into it after every optimiser step ([`project`]).
//!
//! Δt is the spacing of the annotated frames in normalised time; with |ω_t| ≤ c·π/Δt every
//! first-layer unit varies by less than a half-period of c between two annotated frames, and by
//! Theorem 1 the whole network's temporal content is bounded by integer combinations of these
//! frequencies.

use dynaslice_core::Domain;
use dynaslice_sequence::Sequence;

/// Δt of Eq. 4: the median spacing of the annotated timesteps in normalised time (1 for a
/// single timestep, where the network's time input is then switched off by ω_t^max = 0).
pub fn annotated_spacing(seq: &Sequence, domain: &Domain) -> Option<f64> {
    let times: Vec<f64> = seq.frames().iter().map(|f| f.time).collect();
    let mut gaps: Vec<f64> = times
        .windows(2)
        .map(|w| (w[1] - w[0]) / domain.time_span as f64)
        .filter(|g| *g > 0.0)
        .collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    Some(gaps[gaps.len() / 2])
}

/// The default c of ω_t^max = c·π/Δt (Eq. 4). Measured on the chambers (lab/notes/training.md, "The
/// temporal factor c"): at SIREN's ω₀ = 30, where ω_t starts in ±7.5, c = 0.2 (ω_t^max ≈ 5.7 with
/// 10 annotated frames) beats both a looser bound (c = 0.3, which no longer binds) and tighter
/// ones (0.1, 0.05 cut the motion). At the trainer's default ω₀ = 20, ω_t starts in ±5, below
/// this bound with 10 annotated frames, so it is a guard there; with 5 (the 4D CT case of
/// lab/cases/rtstruct4d.py, ω_t^max ≈ 2.5) it binds.
pub const DEFAULT_TEMPORAL_FACTOR: f32 = 0.2;

/// ω_t^max of Eq. 4 for `seq` in `domain`: c·π/Δt with `factor` c; `f32::INFINITY` when
/// temporal control is off (the "4D SIREN" ablation); 0 for a single timestep, where there is
/// nothing to interpolate in time and the time input is switched off.
pub fn temporal_bound(seq: &Sequence, domain: &Domain, factor: f32, control: bool) -> f32 {
    match (control, annotated_spacing(seq, domain)) {
        (false, _) => f32::INFINITY,
        (true, Some(dt)) => factor * (std::f64::consts::PI / dt) as f32,
        (true, None) => 0.0,
    }
}

/// The range ±limit the first layer's ω_t is drawn from: SIREN's range for the layer, `siren`,
/// cut to the bound, so the initial network already satisfies Eq. 4 (without temporal control,
/// ω_t^max = ∞, exactly SIREN's).
pub fn initial_limit(siren: f32, omega_t_max: f32) -> f32 {
    siren.min(omega_t_max)
}

/// Projects every ω_t into [−ω_t^max, ω_t^max] (Eq. 4): the trainer's constraint, applied after
/// each optimiser step.
pub fn project(omega_t: &mut [f32], omega_t_max: f32) {
    omega_t
        .iter_mut()
        .for_each(|v| *v = v.clamp(-omega_t_max, omega_t_max));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data_sampler::domain_for;
    use crate::network::{Network, OMEGA_0};
    use crate::trainer::TrainOptions;
    use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};

    /// The default c on the benchmark's sampling (10 of 37 frames annotated): at the trainer's
    /// default ω₀ the bound leaves the initial network exactly the unbounded one (a guard, so
    /// the default tables of lab/results/results.md do not depend on c), while at SIREN's ω₀ = 30 it
    /// cuts ω_t's initial range, the setting where lab/notes/training.md measures its gain.
    #[test]
    fn default_temporal_bound_binds_at_sirens_omega0_only() {
        // The benchmark's frames (37, every 4th annotated); few, coarse planes suffice for Δt.
        let bench = BenchmarkOptions {
            planes: Some((1, 1)),
            plane_resolution: 16,
            volume_resolution: 8,
            ..BenchmarkOptions::default()
        };
        let seq = slice_sequence(Shape::Blob, &bench).unwrap();
        let bound = temporal_bound(&seq, &domain_for(&seq), DEFAULT_TEMPORAL_FACTOR, true);
        let expected = DEFAULT_TEMPORAL_FACTOR * 9.0 * std::f32::consts::PI;
        assert!(
            (bound - expected).abs() < 1e-4,
            "{bound} against {expected}"
        );
        let layout = dynaslice_core::Layout::new(&[32, 32], 1).unwrap();
        let net =
            |omega_0: f32, omega_t_max: f32| Network::siren(layout, omega_0, 0.2, omega_t_max, 7);
        let default_omega_0 = TrainOptions::default().omega_0;
        assert_eq!(
            net(default_omega_0, bound).params,
            net(default_omega_0, f32::INFINITY).params
        );
        let (bounded, free) = (net(OMEGA_0, bound), net(OMEGA_0, f32::INFINITY));
        assert!(bounded.largest_omega_t() <= bound);
        let free = free.largest_omega_t();
        assert!(free > bound, "{free} ≤ {bound}");
    }

    #[test]
    fn project_clamps_into_the_bound_and_keeps_what_is_inside() {
        let mut w = [-9.0, -1.0, 0.0, 0.5, 3.0, f32::INFINITY];
        project(&mut w, 2.0);
        assert_eq!(w, [-2.0, -1.0, 0.0, 0.5, 2.0, 2.0]);
        let mut free = [-9.0, 7.0];
        project(&mut free, f32::INFINITY);
        assert_eq!(free, [-9.0, 7.0]);
        assert_eq!(initial_limit(7.5, 5.7), 5.7);
        assert_eq!(initial_limit(2.5, 5.7), 2.5);
    }
}
