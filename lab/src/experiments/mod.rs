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

use anyhow::Result;
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::{Sequence, Space, TimeUnit, Units};
use dynaslice_train::fit::{self, InputRecord, Observer, Quiet};
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::trainer::TrainOptions;

/// What every run shares.
#[derive(Clone, Debug)]
pub struct Protocol {
    /// Training wall time per run, turned into a step count per input by [`Protocol::steps_for`].
    pub minutes: f64,
    /// Steps per run instead of calibrating `minutes` ([`Protocol::steps_for`]): a comparison of
    /// settings that the machine's load cannot tilt.
    pub steps: Option<u64>,
    /// Base training options (steps, time, temporal control and orientation are set per run).
    pub spec: TrainSpec,
}

impl Protocol {
    /// The options of a run for `steps` steps, with or without temporal control (Eq. 4) and
    /// the orientation loss (Eq. 6).
    pub fn spec(&self, steps: u64, temporal_control: bool, orientation: bool) -> TrainSpec {
        TrainSpec {
            steps: Some(steps),
            minutes: None,
            no_temporal_control: !temporal_control,
            no_orientation: !orientation,
            ..self.spec.clone()
        }
    }

    /// The trainer's options the base spec resolves to (for the tables' headers).
    pub fn options(&self) -> TrainOptions {
        self.spec.options(f32::INFINITY, None)
    }

    /// Steps of the full method on `seq` that take `self.minutes` on this machine now, from a
    /// short run's median step time ([`fit::Trained::median_step_seconds`], the measure the
    /// trainer's own `--minutes` plan uses).
    /// With `steps` set, those steps.
    pub fn steps_for(&self, seq: &Sequence) -> Result<u64> {
        match self.steps {
            Some(steps) => Ok(steps),
            None => self.steps_for_minutes(seq, self.minutes),
        }
    }

    /// How each run's steps were chosen, for the tables' headers.
    pub fn budget(&self) -> String {
        match self.steps {
            Some(steps) => format!("{steps} steps (`--steps`)"),
            None => format!("the steps calibrated to take {} min", self.minutes),
        }
    }

    /// Steps of the full method on `seq` that take `minutes` on this machine now, measured as
    /// [`Protocol::steps_for`] does.
    pub fn steps_for_minutes(&self, seq: &Sequence, minutes: f64) -> Result<u64> {
        const PROBE: u64 = 6;
        let probe = fit(
            seq,
            &self.spec(PROBE, true, true),
            "calibration",
            &mut Quiet,
        )?;
        let per_step = probe.per_step.unwrap_or(probe.seconds / PROBE as f64);
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
    /// The median step time after the first.
    pub per_step: Option<f64>,
}

impl Fitted {
    /// The model (validated when it was made).
    pub fn model(&self) -> Model<'_> {
        self.bytes.model().expect("validated by fit")
    }
}

/// Trains a model of `seq` as `spec` asks, through the one training entry
/// ([`dynaslice_train::fit::fit`]), in memory; `input` says what `seq` is in the model's
/// metadata (the lab's inputs are in their files' own coordinates).
pub fn fit(
    seq: &Sequence,
    spec: &TrainSpec,
    input: &str,
    observer: &mut dyn Observer,
) -> Result<Fitted> {
    let record = InputRecord {
        description: input.to_string(),
        frames: "0:".into(),
        reading: None,
        space: Space::Ras,
        units: Units::Plain,
        time_unit: TimeUnit::Plain,
    };
    let trained = fit::fit(seq, spec, &record, None, observer)?;
    Ok(Fitted {
        seconds: trained.elapsed.as_secs_f64(),
        per_step: trained.median_step_seconds,
        steps: trained.steps_done,
        bytes: trained.bytes,
    })
}

/// `v` with `digits` decimals, or "–" where undefined.
pub(crate) fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}
