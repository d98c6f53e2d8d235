//! Deterministic samplers producing flat, batch-ready arrays for the trainer.
//!
//! Build a [`SamplingIndex`] once per [`dynaslice_sequence::Sequence`], keep one batch of each kind, and
//! refill them every step:
//! ```
//! # use dynaslice_train::sampling::*;
//! # fn demo(seq: &dynaslice_sequence::Sequence, step: u64) {
//! let index = SamplingIndex::new(seq);
//! let (mut contour, mut plane, mut space) = (ContourBatch::default(), PlaneBatch::default(),
//!     SpaceTimeBatch::default());
//! let b = seq.bounding_box();
//! let diag = (0..3).map(|k| (b.max[k] - b.min[k]).powi(2)).sum::<f64>().sqrt();
//! let how = PlaneSampling::for_scene(diag);
//! let mut rng = SampleRng::new(42, step);
//! let per_class = vec![1024; seq.classes().len()];
//! index.sample_contours(&mut rng, &per_class, &mut contour);
//! index.sample_planes(&mut rng, &per_class, &how, &mut plane);
//! sample_space_time(&mut rng, 4096, &b, seq.time_range(), &mut space);
//! # }
//! ```
//! | batch | paper term | fields |
//! | --- | --- | --- |
//! | [`ContourBatch`] | \|f(x, tᵢ)\| and 𝒩 (Eq. 5, 6) | world xyz, world outward normal, t, class |
//! | [`PlaneBatch`] | 𝒟 (Eq. 7), plus absences | world xyz, t, class, target, [`PlaneTarget`] |
//! | [`SpaceTimeBatch`] | ℛ (Eq. 8) | world xyz, t |
//! | [`PlaneBatch`] from [`SamplingIndex::sample_between`] | between neighbouring parallel planes: f on the side of their blended in-plane distances (not in the paper) | world xyz, t, class, blended target |
//!
//! Results depend only on the sequence, the counts and the [`SampleRng`] seed and stream: the
//! same on every platform and thread count. Use one stream per step (or per worker) for
//! independent batches. Sampling allocates nothing once the batches have reached their size.

mod between;
mod contour;
mod index;
mod plane;
mod rng;
mod spacetime;

pub use contour::ContourBatch;
pub use index::SamplingIndex;
pub use plane::{PlaneBatch, PlaneSampling, PlaneTarget};
pub use rng::SampleRng;
pub use spacetime::{sample_space_time, SpaceTimeBatch};

use crate::objective::Batch;

/// A source of training samples in the network's normalised frame.
pub trait Sampler {
    /// Fills `batch` with the samples of step `step`: a pure function of (seed, step), so a
    /// resumed run sees the same samples.
    fn sample(&mut self, seed: u64, step: u64, batch: &mut Batch);
    /// Upper bound on the samples in any one set of a batch (sizes the buffers).
    fn max_set_len(&self) -> usize;
    /// A digest of the data, stored in checkpoints.
    fn fingerprint(&self) -> u64;
}
