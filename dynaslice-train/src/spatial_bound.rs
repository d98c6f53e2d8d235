//! Eq. 4's band limit applied across parallel planes: where every annotated plane of the data
//! is parallel (a short-axis cine stack, axial RT contours, slices drawn along one axis), the
//! data samples space along the planes' normal n only every Δs, as it samples time every Δt.
//! The first layer's frequency along n, ⟨ω_x, n⟩, is then bounded by c·π/Δs with Eq. 4's c,
//! and by Theorem 1 (which holds for any input direction, not only t) so is the whole
//! network's content along n.
//!
//! Why: without it the network fits each plane with frequencies the planes cannot observe, and
//! between two planes a thin structure (a myocardial ring 8 mm thick between planes 20 mm
//! apart) can bulge out of its channel (lab/notes/2026-12-06-vanishing-ring.md). The bound
//! binds only where planes are sparse for the domain: 3 mm axial contours in a 300 mm domain
//! allow ⟨ω_x, n⟩ up to 31, beyond SIREN's initial ±ω₀/4. Planes in several orientations
//! (resliced label maps, long-axis views beside a short-axis stack) observe every direction,
//! and nothing is bounded.

use dynaslice_core::Domain;
use dynaslice_sequence::sequence::dot;
use dynaslice_sequence::Sequence;

/// Planes whose unit normals' |cosine| is at least this are parallel (within 0.008°).
const PARALLEL: f64 = 1.0 - 1e-8;

/// Two parallel planes closer than this along their normal (normalised units) are one position.
const SAME_POSITION: f64 = 1e-6;

/// The bound on the first layer's spatial frequency along the normal of the data's parallel
/// planes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneBand {
    /// The planes' unit normal (world and normalised frames agree: the domain's scale is
    /// isotropic).
    pub normal: [f32; 3],
    /// The largest |⟨ω_x, n⟩|: c·π/Δs in normalised units.
    pub max: f32,
}

/// The normal of `seq`'s planes and the median spacing of their distinct positions along it, in
/// `domain`'s normalised units; `None` unless every plane is parallel to the first and they lie
/// at two positions or more.
pub fn parallel_spacing(seq: &Sequence, domain: &Domain) -> Option<([f64; 3], f64)> {
    let planes = || seq.frames().iter().flat_map(|f| f.planes.iter());
    let normal = planes().next()?.normal();
    let mut positions = Vec::new();
    for plane in planes() {
        let n = plane.normal();
        let cos = dot(n, normal);
        if cos.abs() < PARALLEL {
            return None;
        }
        positions.push(dot(plane.origin, normal) / domain.scale[0] as f64);
    }
    positions.sort_by(f64::total_cmp);
    positions.dedup_by(|a, b| (*a - *b).abs() < SAME_POSITION);
    let mut gaps: Vec<f64> = positions.windows(2).map(|w| w[1] - w[0]).collect();
    if gaps.is_empty() {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    Some((normal, gaps[gaps.len() / 2]))
}

/// The band of `seq`'s parallel planes in `domain` with Eq. 4's `factor` c; `None` where the
/// planes are not all parallel, or where `control` is off (`--no-plane-band`).
pub fn plane_band(
    seq: &Sequence,
    domain: &Domain,
    factor: f32,
    control: bool,
) -> Option<PlaneBand> {
    if !control {
        return None;
    }
    let (normal, spacing) = parallel_spacing(seq, domain)?;
    Some(PlaneBand {
        normal: normal.map(|v| v as f32),
        max: factor * (std::f64::consts::PI / spacing) as f32,
    })
}

/// Projects every first-layer unit's ω_x (three rows of the layer's Wᵀ: `x`, `y`, `z`, one
/// entry per unit) so that |⟨ω_x, n⟩| ≤ `band.max`, leaving the in-plane part unchanged: the
/// trainer's constraint, applied after each optimiser step.
pub fn project(rows: [&mut [f32]; 3], band: &PlaneBand) {
    let [x, y, z] = rows;
    let n = band.normal;
    for ((wx, wy), wz) in x.iter_mut().zip(y.iter_mut()).zip(z.iter_mut()) {
        let along = *wx * n[0] + *wy * n[1] + *wz * n[2];
        let excess = along - along.clamp(-band.max, band.max);
        if excess != 0.0 {
            *wx -= excess * n[0];
            *wy -= excess * n[1];
            *wz -= excess * n[2];
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::data_sampler::domain_for;
    use crate::temporal_bound::DEFAULT_TEMPORAL_FACTOR;
    use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};

    /// The blob benchmark sliced by `planes` (rotated, parallel) planes per timestep.
    pub(crate) fn benchmark(planes: (usize, usize)) -> Sequence {
        let bench = BenchmarkOptions {
            planes: Some(planes),
            plane_resolution: 16,
            volume_resolution: 8,
            ..BenchmarkOptions::default()
        };
        slice_sequence(Shape::Blob, &bench).unwrap()
    }

    /// Parallel planes give their normal and spacing; one rotated plane among them, none.
    #[test]
    fn only_parallel_planes_are_bounded() {
        let seq = benchmark((0, 4));
        let domain = domain_for(&seq);
        let (normal, spacing) = parallel_spacing(&seq, &domain).unwrap();
        let first = &seq.frames()[0].planes;
        let along: Vec<f64> = first.iter().map(|p| dot(p.origin, normal)).collect();
        let gap = (along[1] - along[0]).abs() / domain.scale[0] as f64;
        assert!((spacing - gap).abs() < 1e-9, "{spacing} against {gap}");
        let band = plane_band(&seq, &domain, DEFAULT_TEMPORAL_FACTOR, true).unwrap();
        let expected = DEFAULT_TEMPORAL_FACTOR * (std::f64::consts::PI / spacing) as f32;
        assert!((band.max - expected).abs() < 1e-4 * expected);
        assert_eq!(
            plane_band(&seq, &domain, DEFAULT_TEMPORAL_FACTOR, false),
            None
        );
        let mixed = benchmark((1, 4));
        assert_eq!(parallel_spacing(&mixed, &domain_for(&mixed)), None);
    }

    /// The projection bounds the component along n and keeps the rest.
    #[test]
    fn project_bounds_the_frequency_along_the_normal_only() {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let band = PlaneBand {
            normal: [0.0, s, s],
            max: 1.0,
        };
        let (mut x, mut y, mut z) = (
            vec![3.0, -2.0, 0.5],
            vec![4.0, 0.0, 0.2],
            vec![0.0, -5.0, 0.1],
        );
        let before: Vec<[f32; 3]> = (0..3).map(|i| [x[i], y[i], z[i]]).collect();
        project([&mut x, &mut y, &mut z], &band);
        for i in 0..3 {
            let w = [x[i], y[i], z[i]];
            let along = w[1] * s + w[2] * s;
            let was = before[i][1] * s + before[i][2] * s;
            assert!(
                (along - was.clamp(-1.0, 1.0)).abs() < 1e-6,
                "{i}: {along} from {was}"
            );
            // In the plane: x and y − z unchanged.
            assert_eq!(w[0], before[i][0]);
            assert!(((w[1] - w[2]) - (before[i][1] - before[i][2])).abs() < 1e-6);
        }
        assert_eq!([x[2], y[2], z[2]], before[2], "inside the band: untouched");
    }
}
