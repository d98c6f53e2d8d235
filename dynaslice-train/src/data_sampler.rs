//! Training samples from a cross-section [`Sequence`]: the data-side samplers (world units)
//! mapped into the network's normalised frame, with the per-class weights of Eq. 10.

use super::loss::{ContourSample, PlaneKind, PlaneSample};
use super::objective::Batch;
use crate::extent_bound::ClassExtents;
use crate::sampling::{
    sample_space_time, ContourBatch, PlaneBatch, PlaneSampling, PlaneTarget, SampleRng, Sampler,
    SamplingIndex, SpaceTimeBatch,
};
use crate::spatial_bound::parallel_spacing;
use dynaslice_core::Domain;
use dynaslice_model::SampleRecord;
use dynaslice_sequence::{Aabb, Sequence};

/// Relative margin around the data's bounding box inside the normalised cube, so surfaces near
/// the outermost planes are not clipped by the domain.
const DOMAIN_MARGIN: f64 = 0.1;

/// The isotropic world ↔ normalised map of a sequence: its region of interest's bounding box
/// (plus a margin) inside [−1, 1]³ with one scale for all axes, so distances and gradient
/// norms mean the same in both frames (σ = s), and its time range onto [0, 1].
pub fn domain_for(seq: &Sequence) -> Domain {
    let b = seq.roi_bounding_box();
    let center: [f64; 3] = std::array::from_fn(|i| 0.5 * (b.min[i] + b.max[i]));
    let half = (0..3)
        .map(|i| 0.5 * (b.max[i] - b.min[i]))
        .fold(0.0f64, f64::max);
    let scale = (half * (1.0 + DOMAIN_MARGIN)).max(1e-6);
    let (t0, t1) = seq.time_range();
    let span = if t1 > t0 { t1 - t0 } else { 1.0 };
    Domain {
        center: center.map(|c| c as f32),
        scale: [scale as f32; 3],
        time_origin: t0 as f32,
        time_span: span as f32,
        output_scale: scale as f32,
    }
}

/// How many samples each step draws.
///
/// Up to [`SampleCounts::budget_classes`] classes, every class gets `contour_per_class` contour
/// and `plane_per_class` plane samples. Beyond that the classes share the budget of
/// `budget_classes` classes, so that a step's cost grows slowly with K (a shared network's
/// hidden layers dominate it): each class gets at least `min_per_class`, and the rest is split
/// in proportion to the classes' contour lengths, so a long boundary gets the samples it needs
/// and a small structure keeps enough for its mean (Eq. 10 weighs every class's mean equally).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleCounts {
    /// Contour points per class, up to `budget_classes` classes.
    pub contour_per_class: usize,
    /// Plane samples per class, up to `budget_classes` classes.
    pub plane_per_class: usize,
    /// Space-time samples (shared by all channels).
    pub space: usize,
    /// Number of classes whose full per-class counts make the per-step budget.
    pub budget_classes: usize,
    /// The fewest contour and plane samples a class gets when classes share the budget (capped
    /// at the per-class counts).
    pub min_per_class: usize,
}

impl Default for SampleCounts {
    /// 1024 contour and 1024 plane samples per class, 1024 space-time: in the measured sweep of
    /// lab/notes/training.md, four times the steps of the 4096-sample batch beat its larger batches
    /// at equal wall time (chambers IoU 0.975 against 0.866 in 1.5 min). Past 3 classes the
    /// classes share the budget of 3, at least 64 samples each.
    fn default() -> Self {
        // From the table of options, as `dynaslice train --help` shows them.
        use crate::flags::*;
        let count = |f: &Flag| f.default.whole() as usize;
        SampleCounts {
            contour_per_class: count(&CONTOUR_SAMPLES),
            plane_per_class: count(&PLANE_SAMPLES),
            space: count(&SPACE_SAMPLES),
            budget_classes: count(&BUDGET_CLASSES),
            min_per_class: count(&MIN_CLASS_SAMPLES),
        }
    }
}

impl SampleCounts {
    /// Contour samples of each class per step, for classes of the given contour lengths.
    pub fn contour_split(&self, lengths: &[f64]) -> Vec<usize> {
        self.split(self.contour_per_class, lengths)
    }

    /// Plane samples of each class per step, for classes of the given contour lengths.
    pub fn plane_split(&self, lengths: &[f64]) -> Vec<usize> {
        self.split(self.plane_per_class, lengths)
    }

    /// A per-step total for `k` classes at `per_class` each, shared past `budget_classes`.
    pub fn total(&self, per_class: usize, k: usize) -> usize {
        if k <= self.budget_classes {
            per_class * k
        } else {
            let floor = self.min_per_class.min(per_class);
            (per_class * self.budget_classes).max(floor * k)
        }
    }

    /// The total for `lengths.len()` classes split among them: `per_class` each while the
    /// budget allows, otherwise the floor each plus the rest by contour length (largest
    /// remainders, ties to the lower index). Classes of zero length share only the floor; if
    /// every length is 0 the rest goes evenly.
    fn split(&self, per_class: usize, lengths: &[f64]) -> Vec<usize> {
        let k = lengths.len();
        if k <= self.budget_classes {
            return vec![per_class; k];
        }
        let floor = self.min_per_class.min(per_class);
        let rest = self.total(per_class, k) - floor * k;
        let sum: f64 = lengths.iter().sum();
        let share: Vec<f64> = lengths
            .iter()
            .map(|&l| {
                let w = if sum > 0.0 { l / sum } else { 1.0 / k as f64 };
                w * rest as f64
            })
            .collect();
        let mut n: Vec<usize> = share.iter().map(|s| s.floor() as usize).collect();
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| {
            let frac = |i: usize| share[i] - share[i].floor();
            frac(b).total_cmp(&frac(a)).then(a.cmp(&b))
        });
        let left = rest - n.iter().sum::<usize>();
        for &i in order.iter().take(left) {
            n[i] += 1;
        }
        n.iter_mut().for_each(|c| *c += floor);
        n
    }

    /// The counts as a model's run record holds them.
    pub fn record(&self) -> SampleRecord {
        SampleRecord {
            contour_per_class: self.contour_per_class,
            plane_per_class: self.plane_per_class,
            budget_classes: self.budget_classes,
            min_per_class: self.min_per_class,
            space_time: self.space,
        }
    }

    /// The counts in one line, as a model's metadata records them ([`SampleRecord::describe`]).
    pub fn describe(&self) -> String {
        self.record().describe()
    }
}

/// A [`Sampler`] over a sequence.
pub struct DataSampler {
    index: SamplingIndex,
    domain: Domain,
    counts: SampleCounts,
    plane: PlaneSampling,
    cube: Aabb,
    times: (f64, f64),
    num_classes: usize,
    fingerprint: u64,
    contour: ContourBatch,
    planes: PlaneBatch,
    between: PlaneBatch,
    space: SpaceTimeBatch,
    per_class: Vec<usize>,
    /// Contour and plane samples of each class per step ([`SampleCounts::contour_split`]).
    contour_split: Vec<usize>,
    plane_split: Vec<usize>,
    /// Samples between neighbouring planes of each class per step: half its plane samples
    /// where it has neighbouring planes that both outline it, else none
    /// ([`SamplingIndex::sample_between`]).
    between_split: Vec<usize>,
    /// Optional per-class weights of the contour and plane terms (1 by default).
    class_weight: Vec<f32>,
    /// Each class's extent (parallel planes only), whose signed distance bounds the class from
    /// below on the cap and space-time samples and caps its in-plane targets' depth.
    extents: Option<ClassExtents>,
    /// Each class's direct outer class, where it is drawn nested in one.
    outer: Vec<Option<usize>>,
}

impl DataSampler {
    /// Indexes `seq` for sampling in `domain`.
    pub fn new(seq: &Sequence, domain: Domain, counts: SampleCounts) -> DataSampler {
        Self::with_progress(seq, domain, counts, &mut |_, _| {})
    }

    /// [`DataSampler::new`], telling `progress(done, total)` how far the index of exact
    /// in-plane distances is built ([`SamplingIndex::with_progress`]).
    pub fn with_progress(
        seq: &Sequence,
        domain: Domain,
        counts: SampleCounts,
        progress: &mut dyn FnMut(usize, usize),
    ) -> DataSampler {
        let (lo, hi) = domain.bounds();
        let s = domain.scale[0] as f64;
        let (t0, t1) = domain.time_range();
        // The fingerprint tells runs apart: the data's digest and the batch sizes (a resume with
        // other counts would draw other samples).
        let fingerprint = [
            counts.contour_per_class,
            counts.plane_per_class,
            counts.space,
            counts.budget_classes,
            counts.min_per_class,
        ]
        .iter()
        .fold(dynaslice_sequence::native::digest(seq), |h, &c| {
            (h ^ c as u64).wrapping_mul(0x100_0000_01b3)
        });
        let index = SamplingIndex::with_progress(seq, progress);
        // Between neighbouring planes only where every plane is parallel.
        let index = match parallel_spacing(seq, &domain) {
            Some((normal, _)) => index.with_neighbour_pairs(normal),
            None => index,
        };
        let lengths = index.contour_lengths();
        // The extents change the objective: a checkpoint of a run without them (a run of an
        // earlier version on parallel planes) does not continue with them.
        let extents = ClassExtents::of(seq, &domain);
        let fingerprint = extents.as_ref().map_or(fingerprint, |e| {
            (fingerprint ^ e.margin().to_bits()).wrapping_mul(0x100_0000_01b3)
        });
        // So do the samples between neighbouring planes.
        let pairs = index.neighbour_pairs();
        let fingerprint = pairs.iter().fold(fingerprint, |h, &n| {
            (h ^ n as u64).wrapping_mul(0x100_0000_01b3)
        });
        let plane_split = counts.plane_split(&lengths);
        let between_split = plane_split
            .iter()
            .zip(&pairs)
            .map(|(&n, &pairs)| if pairs > 0 { n / 2 } else { 0 })
            .collect();
        DataSampler {
            contour_split: counts.contour_split(&lengths),
            plane_split,
            between_split,
            index,
            domain,
            counts,
            plane: PlaneSampling::for_scene(2.0 * 3f64.sqrt() * s / (1.0 + DOMAIN_MARGIN)),
            cube: Aabb {
                min: lo.map(f64::from),
                max: hi.map(f64::from),
            },
            times: (t0 as f64, t1 as f64),
            num_classes: seq.classes().len(),
            fingerprint,
            contour: ContourBatch::default(),
            planes: PlaneBatch::default(),
            between: PlaneBatch::default(),
            space: SpaceTimeBatch::default(),
            per_class: vec![0; seq.classes().len()],
            class_weight: vec![1.0; seq.classes().len()],
            extents,
            outer: {
                let mut outer = vec![None; seq.classes().len()];
                for n in seq.nesting() {
                    outer[n.inner] = Some(n.outer);
                }
                outer
            },
        }
    }

    /// The classes' extents the space-time samples respect (`None`: the planes are not all
    /// parallel, nothing is imposed off them).
    pub fn extents(&self) -> Option<&ClassExtents> {
        self.extents.as_ref()
    }

    /// Each class's number of neighbouring plane pairs that both outline it, between which
    /// samples take the blend of their in-plane distances as target (none where the planes are
    /// not all parallel).
    pub fn neighbour_pairs(&self) -> Vec<usize> {
        self.index.neighbour_pairs()
    }

    /// Weights each class's contour and plane terms by `weights[k]` (one finite, positive weight
    /// per class), e.g. to favour a small structure. Space-time terms stay shared. The weights
    /// enter the fingerprint, so a resume with other weights is refused.
    pub fn with_class_weights(mut self, weights: &[f32]) -> Result<DataSampler, String> {
        if weights.len() != self.num_classes {
            return Err(format!(
                "{} class weights for {} classes",
                weights.len(),
                self.num_classes
            ));
        }
        if let Some((k, w)) = weights
            .iter()
            .enumerate()
            .find(|(_, w)| !(w.is_finite() && **w > 0.0))
        {
            return Err(format!(
                "class {} has weight {w}: weights are finite and positive",
                k + 1
            ));
        }
        self.class_weight = weights.to_vec();
        self.fingerprint = weights.iter().fold(self.fingerprint, |h, w| {
            (h ^ u64::from(w.to_bits())).wrapping_mul(0x100_0000_01b3)
        });
        Ok(self)
    }

    /// Replaces `out` with the normalised (x, y, z, t) of the samples at `xyz`, `t`.
    fn normalise_into(&self, xyz: &[[f32; 3]], t: &[f32], out: &mut Vec<[f32; 4]>) {
        out.clear();
        out.extend(
            xyz.iter()
                .zip(t)
                .map(|(x, &t)| self.domain.normalise(*x, t)),
        );
    }

    /// Each sample's class and weight in a set whose classes are `classes`: the class's weight
    /// over N_k, the set's count of that class (Eq. 10: a mean per class, summed). `per_class`
    /// is scratch for the counts.
    fn weighted_classes<'s>(
        per_class: &'s mut [usize],
        class_weight: &'s [f32],
        classes: &'s [u32],
    ) -> impl Iterator<Item = (u32, f32)> + 's {
        per_class.fill(0);
        for &c in classes {
            per_class[c as usize] += 1;
        }
        let per_class = &*per_class;
        classes
            .iter()
            .map(move |&c| (c, class_weight[c as usize] / per_class[c as usize] as f32))
    }
}

impl DataSampler {
    /// Appends to the plane set, for every plane sample inside a class drawn nested in another
    /// (trained as disjoint regions: the outer is its region minus the inner's), a lower bound
    /// of the outer there: the point's depth in the inner. The outer's own samples fall on the
    /// hole an inner structure makes in it in proportion to its contour length, so a 12 mm node
    /// in a BODY got none, the BODY's channel stayed inside over it, and Eq. 11 gave the node's
    /// points to the BODY. A per-class mean per outer class.
    fn hole_samples(&mut self, b: &mut Batch) {
        if self.outer.iter().all(Option::is_none) {
            return;
        }
        let first = b.plane.len();
        self.per_class.fill(0);
        for i in 0..first {
            let s = b.plane[i];
            let Some(outer) = self.outer[s.class as usize] else {
                continue;
            };
            if s.kind != PlaneKind::Sdf || s.target >= 0.0 {
                continue;
            }
            b.plane_x.push(b.plane_x[i]);
            b.plane.push(PlaneSample {
                class: outer as u32,
                target: -s.target,
                kind: PlaneKind::Outside,
                weight: 0.0,
            });
            self.per_class[outer] += 1;
        }
        for s in &mut b.plane[first..] {
            let c = s.class as usize;
            s.weight = self.class_weight[c] / self.per_class[c] as f32;
        }
    }

    /// Appends to the plane set each class's cap samples ([`ClassExtents::cap_sample`]): a
    /// quarter of its plane samples (at least [`MIN_CAP_SAMPLES`]) around the faces of its
    /// contours' box, each with the box's signed distance as a lower bound, a per-class mean.
    /// Only where the planes are parallel.
    fn cap_samples(&mut self, rng: &mut SampleRng, b: &mut Batch) {
        let Some(extents) = &self.extents else {
            return;
        };
        let (t0, t1) = self.times;
        for (class, &n) in self.plane_split.iter().enumerate() {
            let first = b.plane.len();
            for _ in 0..(n / 4).max(MIN_CAP_SAMPLES) {
                let Some((x, bound)) = extents.cap_sample(rng, class) else {
                    break;
                };
                let t = self.domain.normalise([0.0; 3], rng.range(t0, t1) as f32)[3];
                if x.iter().any(|v| v.abs() > 1.0) {
                    continue; // beyond the domain: nothing is asked there
                }
                b.plane_x.push([x[0], x[1], x[2], t]);
                b.plane.push(PlaneSample {
                    class: class as u32,
                    target: bound,
                    kind: PlaneKind::Outside,
                    weight: 0.0,
                });
            }
            let drawn = b.plane.len() - first;
            for s in &mut b.plane[first..] {
                s.weight = self.class_weight[class] / drawn as f32;
            }
        }
    }
}

impl DataSampler {
    /// Appends the samples between neighbouring planes drawn this step to the plane set: the
    /// blended in-plane distance as a [`PlaneKind::Between`] target (no deeper than the class's
    /// extent allows), a per-class mean with the class's weight.
    fn between_samples(&mut self, b: &mut Batch) {
        if self.between.is_empty() {
            return;
        }
        let first = b.plane.len();
        let sigma = self.domain.output_scale;
        for (i, x) in self.between.xyz.iter().enumerate() {
            let x = self.domain.normalise(*x, self.between.t[i]);
            let class = self.between.class[i];
            let mut target = self.between.target[i] / sigma;
            if let (Some(e), true) = (&self.extents, target < 0.0) {
                target = target.max(-e.depth(x, class as usize));
            }
            b.plane_x.push(x);
            b.plane.push(PlaneSample {
                class,
                target,
                kind: PlaneKind::Between,
                weight: 0.0,
            });
        }
        let weighted =
            Self::weighted_classes(&mut self.per_class, &self.class_weight, &self.between.class);
        for (s, (_, w)) in b.plane[first..].iter_mut().zip(weighted) {
            s.weight = w;
        }
    }
}

/// The fewest cap samples a class gets per step.
const MIN_CAP_SAMPLES: usize = 16;

impl Sampler for DataSampler {
    fn sample(&mut self, seed: u64, step: u64, b: &mut Batch) {
        let mut rng = SampleRng::new(seed, step);
        self.index
            .sample_contours(&mut rng, &self.contour_split, &mut self.contour);
        self.index
            .sample_planes(&mut rng, &self.plane_split, &self.plane, &mut self.planes);
        self.index.sample_between(
            &mut rng,
            &self.between_split,
            &self.plane,
            &mut self.between,
        );
        sample_space_time(
            &mut rng,
            self.counts.space,
            &self.cube,
            self.times,
            &mut self.space,
        );

        let sigma = self.domain.output_scale;
        self.normalise_into(&self.contour.xyz, &self.contour.t, &mut b.contour_x);
        b.contour_normal.clone_from(&self.contour.normal);
        let weighted =
            Self::weighted_classes(&mut self.per_class, &self.class_weight, &self.contour.class);
        b.contour.clear();
        b.contour
            .extend(weighted.map(|(class, weight)| ContourSample { class, weight }));
        self.normalise_into(&self.planes.xyz, &self.planes.t, &mut b.plane_x);
        let weighted =
            Self::weighted_classes(&mut self.per_class, &self.class_weight, &self.planes.class);
        b.plane.clear();
        for (i, (class, weight)) in weighted.enumerate() {
            let mut target = self.planes.target[i] / sigma;
            // Inside the class, no deeper than its extent allows (near its end planes).
            if let (Some(e), true) = (&self.extents, target < 0.0) {
                target = target.max(-e.depth(b.plane_x[i], class as usize));
            }
            b.plane.push(PlaneSample {
                class,
                target,
                kind: match self.planes.kind[i] {
                    PlaneTarget::Sdf => PlaneKind::Sdf,
                    PlaneTarget::LowerBound => PlaneKind::Absent,
                },
                weight,
            });
        }
        self.normalise_into(&self.space.xyz, &self.space.t, &mut b.space_x);
        match &self.extents {
            Some(e) => e.lower_bounds(&b.space_x, &mut b.space_floor),
            None => b.space_floor.clear(),
        }
        // After the hole samples: a blended target is no depth a hole bound could rest on.
        self.hole_samples(b);
        self.between_samples(b);
        self.cap_samples(&mut rng, b);
    }

    fn max_set_len(&self) -> usize {
        let sum = |split: &[usize]| split.iter().sum::<usize>();
        // Plane samples, as many hole samples at most, and the cap samples.
        let caps: usize = match &self.extents {
            Some(_) => self
                .plane_split
                .iter()
                .map(|&n| (n / 4).max(MIN_CAP_SAMPLES))
                .sum(),
            None => 0,
        };
        sum(&self.contour_split)
            .max(2 * sum(&self.plane_split) + sum(&self.between_split) + caps)
            .max(self.counts.space)
    }

    fn fingerprint(&self) -> u64 {
        self.fingerprint
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};

    fn sampler() -> DataSampler {
        let bench = BenchmarkOptions {
            timesteps: 5,
            train_every: 2,
            planes: Some((2, 2)),
            plane_resolution: 48,
            volume_resolution: 8,
        };
        let seq = slice_sequence(Shape::Chambers, &bench).unwrap();
        let counts = SampleCounts {
            contour_per_class: 32,
            plane_per_class: 32,
            space: 16,
            ..SampleCounts::default()
        };
        DataSampler::new(&seq, domain_for(&seq), counts)
    }

    /// Up to the budget's classes each class gets its full count; past it the total stays the
    /// budget's (or the floors'), each class gets at least the floor, and the rest follows the
    /// contour lengths.
    #[test]
    fn shared_budget_splits_by_contour_length_with_a_floor() {
        let counts = SampleCounts::default();
        assert_eq!(counts.contour_split(&[1.0, 5.0, 0.5]), vec![1024; 3]);
        let lengths: Vec<f64> = (1..=41).map(f64::from).collect();
        let split = counts.contour_split(&lengths);
        assert_eq!(split.iter().sum::<usize>(), 3 * 1024);
        assert_eq!(counts.total(1024, 41), 3 * 1024);
        assert!(split.iter().all(|&n| n >= 64), "{split:?}");
        assert!(split.windows(2).all(|w| w[0] <= w[1]), "{split:?}");
        // 41 · 64 = 2624 floors, 448 by length: the longest (41/861 of it) gets 21 more.
        assert_eq!((split[0], split[40]), (64, 64 + 21));
        let many = counts.plane_split(&[0.0; 64]);
        assert_eq!(many, vec![64; 64], "the floors exceed the budget");
        let zero_rest = counts.plane_split(&[0.0; 41]);
        assert_eq!(zero_rest.iter().sum::<usize>(), 3 * 1024);
        assert!(
            zero_rest.iter().all(|&n| n == 74 || n == 75),
            "{zero_rest:?}"
        );
        let small = SampleCounts {
            contour_per_class: 32,
            ..counts
        };
        assert_eq!(small.contour_split(&[1.0, 9.0, 1.0, 1.0, 1.0]), vec![32; 5]);
    }

    /// Between neighbouring parallel planes that both outline a class, half its plane samples
    /// more, with blended targets, a mean of their own per class, before the caps; planes in
    /// several orientations get none (their plane set is the plane samples alone).
    #[test]
    fn between_samples_only_across_parallel_planes() {
        use crate::spatial_bound::tests::benchmark;
        let counts = SampleCounts {
            contour_per_class: 32,
            plane_per_class: 32,
            space: 16,
            ..SampleCounts::default()
        };
        let parallel = benchmark((0, 4));
        let mut p = DataSampler::new(&parallel, domain_for(&parallel), counts);
        assert!(
            p.neighbour_pairs().iter().all(|&n| n > 0),
            "{:?}",
            p.neighbour_pairs()
        );
        let mut b = Batch::default();
        p.sample(5, 2, &mut b);
        // Plane samples, then the between samples, then the caps (no nesting here).
        let between = &b.plane[32..48];
        assert!(between.iter().all(|s| s.kind == PlaneKind::Between));
        let total: f32 = between.iter().map(|s| s.weight).sum();
        assert!((total - 1.0).abs() < 1e-5, "a mean: {total}");
        assert_eq!(b.plane[48].kind, PlaneKind::Outside, "caps follow");
        assert!(b.plane.len() <= p.max_set_len());
        let mixed = benchmark((1, 4));
        let mut m = DataSampler::new(&mixed, domain_for(&mixed), counts);
        assert!(m.neighbour_pairs().iter().all(|&n| n == 0));
        m.sample(5, 2, &mut b);
        assert_eq!(b.plane.len(), 32, "no between samples, no caps");
    }

    /// Class weights scale exactly their class's contour and plane sample weights, change the
    /// fingerprint, and are validated.
    #[test]
    fn class_weights_scale_their_class() {
        let (mut plain, mut weighted) = (Batch::default(), Batch::default());
        let base = sampler();
        let print = base.fingerprint();
        let mut base = base;
        base.sample(3, 7, &mut plain);
        let mut w = sampler().with_class_weights(&[1.0, 4.0, 0.5]).unwrap();
        assert_ne!(w.fingerprint(), print);
        w.sample(3, 7, &mut weighted);
        assert_eq!(plain.contour_x, weighted.contour_x, "same samples");
        let scale = [1.0, 4.0, 0.5];
        for (a, b) in plain.contour.iter().zip(&weighted.contour) {
            assert_eq!(b.weight, a.weight * scale[a.class as usize]);
        }
        for (a, b) in plain.plane.iter().zip(&weighted.plane) {
            assert_eq!(b.weight, a.weight * scale[a.class as usize]);
        }
        assert_eq!(plain.space_x, weighted.space_x);
        let error = |w: &[f32]| sampler().with_class_weights(w).err().unwrap_or_default();
        assert!(error(&[1.0, 1.0]).contains("2 class weights for 3"));
        let e = error(&[1.0, 0.0, 1.0]);
        assert!(e.contains("class 2 has weight 0"), "{e}");
        assert!(sampler().with_class_weights(&[1.0, f32::NAN, 1.0]).is_err());
    }
}
