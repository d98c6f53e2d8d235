//! The paper's experiments, reproduced (`dynaslice-lab results`, written to lab/results/results.md).
//!
//! - [`synthetic`]: Table 3's layout on the synthetic benchmark: 4D SIREN, + orientation and
//!   full DynaSlice, scored by 3D IoU and Chamfer distance against the exact shapes.
//! - [`multiclass`]: Table 2's idea: independent per-class models, one shared multi-class model,
//!   and the shared model without temporal control, scored on held-out slices.
//! - [`mod@reference`]: static reconstructions of `.csl` cross-sections against reference meshes.
//! - [`schedule`]: timed training, the planned schedule against a cut-off one, at equal wall time.
//! - [`torch_step`]: one training step against the same step in PyTorch, in the same run.
//!
//! Every run of one table trains for the same number of steps, calibrated once per input to
//! take the requested wall time ([`Protocol::steps_for`]): equal compute, and a comparison a busy machine cannot tilt.

pub mod multiclass;
pub mod reference;
pub mod schedule;
pub mod synthetic;
pub mod torch_step;

use anyhow::{anyhow, Result};
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::Sequence;
use dynaslice_train::data_sampler::{domain_for, DataSampler, SampleCounts};
use dynaslice_train::model_file::TrainedModel;
use dynaslice_train::temporal_bound::temporal_bound;
use dynaslice_train::trainer::{train, TrainOptions};
use std::ops::ControlFlow;
use std::time::Instant;

/// What every run shares.
#[derive(Clone, Debug)]
pub struct Protocol {
    /// Training wall time per run, turned into a step count per input by [`Protocol::steps_for`].
    pub minutes: f64,
    /// Base training options (steps, time limit and ω_t^max are set per run).
    pub options: TrainOptions,
    /// Samples per step.
    pub counts: SampleCounts,
    /// c of ω_t^max = c·π/Δt.
    pub temporal_factor: f32,
}

impl Protocol {
    /// The options of a run on `seq` for `steps` steps, with or without temporal control
    /// (Eq. 4) and the orientation loss (Eq. 6).
    pub fn options(
        &self,
        seq: &Sequence,
        steps: u64,
        temporal_control: bool,
        orientation: bool,
    ) -> TrainOptions {
        let mut o = self.options.clone();
        o.steps = steps;
        o.time_limit = None;
        o.checkpoint = None;
        if !orientation {
            o.loss.orientation = 0.0;
        }
        o.omega_t_max = temporal_bound(
            seq,
            &domain_for(seq),
            self.temporal_factor,
            temporal_control,
        );
        o
    }

    /// Steps of the full method on `seq` that take `self.minutes` on this machine now, from a
    /// short timed run (its first step, which warms caches and allocators, is not counted).
    pub fn steps_for(&self, seq: &Sequence) -> Result<u64> {
        self.steps_for_minutes(seq, self.minutes)
    }

    /// Steps of the full method on `seq` that take `minutes` on this machine now, measured as
    /// [`Protocol::steps_for`] does.
    pub fn steps_for_minutes(&self, seq: &Sequence, minutes: f64) -> Result<u64> {
        const PROBE: u64 = 6;
        let probe = self.options(seq, PROBE, true, true);
        let mut sampler = DataSampler::new(seq, domain_for(seq), self.counts);
        let start = Instant::now();
        let mut first = None;
        train(&probe, seq.classes().len(), &mut sampler, |p| {
            if p.step == 1 {
                first = Some(start.elapsed());
            }
            ControlFlow::Continue(())
        })?;
        let per_step =
            (start.elapsed() - first.unwrap_or_default()).as_secs_f64() / (PROBE - 1) as f64;
        Ok(((minutes * 60.0 / per_step) as u64).max(1))
    }
}

/// A trained model and what it cost.
pub struct Fitted {
    /// The model file.
    pub bytes: ModelBytes,
    /// Steps completed.
    pub steps: u64,
    /// Training wall time.
    pub seconds: f64,
}

impl Fitted {
    /// The model (validated when it was made).
    pub fn model(&self) -> Model<'_> {
        self.bytes.model().expect("validated by fit")
    }
}

/// Trains a model of `seq` with `options` and `p`'s sample counts, in `seq`'s own domain. Its
/// metadata is `dynaslice train`'s, with `input` (`key = value` lines) saying what `seq` is.
pub fn fit(p: &Protocol, seq: &Sequence, options: &TrainOptions, input: &str) -> Result<Fitted> {
    let domain = domain_for(seq);
    let mut sampler = DataSampler::new(seq, domain, p.counts);
    let outcome = train(options, seq.classes().len(), &mut sampler, |_| {
        ControlFlow::Continue(())
    })?;
    let bytes = TrainedModel {
        outcome: &outcome,
        domain,
        classes: seq.classes(),
        options,
        counts: p.counts,
        temporal_factor: p.temporal_factor,
        class_weights: None,
        input,
    }
    .to_bytes()
    .map_err(|e| anyhow!("model: {e}"))?;
    bytes.model().map_err(|e| anyhow!("model: {e}"))?;
    Ok(Fitted {
        bytes,
        steps: outcome.steps_done,
        seconds: outcome.elapsed.as_secs_f64(),
    })
}

/// `v` with `digits` decimals, or "–" where undefined.
pub(crate) fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}
