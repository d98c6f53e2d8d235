//! A trained network's model file: the network, its classes and domain, and the metadata every
//! way of training records (the `dynaslice train` command and the lab's experiments alike).

use crate::data_sampler::SampleCounts;
use crate::trainer::{Outcome, TrainOptions};
use dynaslice_core::{Domain, Error, ModelBytes};
use dynaslice_data::ClassInfo;

/// A training run's result with everything its model file records.
pub struct TrainedModel<'a> {
    /// What training produced.
    pub outcome: &'a Outcome,
    /// The world ↔ normalised map the network was trained in.
    pub domain: Domain,
    /// The trained classes, in channel order.
    pub classes: &'a [ClassInfo],
    /// The options it was trained with.
    pub options: &'a TrainOptions,
    /// Samples drawn per step.
    pub counts: SampleCounts,
    /// c of ω_t^max = c·π/Δt (Eq. 4), recorded even where temporal control was off.
    pub temporal_factor: f32,
    /// Per-class weights of the contour and plane terms, where given.
    pub class_weights: Option<&'a [f32]>,
    /// What was trained on, as `key = value` lines (`dynaslice train`: `input = PATH` and
    /// `frames = A:B:STEP`).
    pub input: &'a str,
}

impl TrainedModel<'_> {
    /// The model file, in aligned storage ready for [`ModelBytes::model`].
    pub fn to_bytes(&self) -> Result<ModelBytes, Error> {
        let classes = self
            .classes
            .iter()
            .map(|c| (c.name.clone(), c.label))
            .collect();
        let bytes = self
            .outcome
            .network
            .to_writer(self.domain, classes, self.metadata())
            .try_to_bytes()?;
        Ok(ModelBytes::copy_from(&bytes))
    }

    /// The metadata `dynaslice info` prints: `key = value` lines, in a fixed order.
    fn metadata(&self) -> String {
        let c = self.counts;
        let mut m = format!("trainer = dynaslice {}\n", env!("CARGO_PKG_VERSION"));
        m += self.input;
        m.push('\n');
        m += &self.options.describe();
        m += &format!(
            "temporal_factor = {}\nsteps_done = {}\n",
            self.temporal_factor, self.outcome.steps_done
        );
        m += &format!(
            "samples = {} contour + {} plane per class, {} space-time\n",
            c.contour_per_class, c.plane_per_class, c.space
        );
        if let Some(w) = self.class_weights {
            m += &format!("class_weights = {w:?}\n");
        }
        if let Some(last) = self.outcome.history.last() {
            m += &format!("final_loss = {}\n", last.2);
        }
        m
    }
}
