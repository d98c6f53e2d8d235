//! A trained network's model file: the network, its classes and domain, and the metadata every
//! way of training records (the `dynaslice train` command and the lab's experiments alike).

use crate::data_sampler::SampleCounts;
use crate::trainer::{Outcome, TrainOptions};
use dynaslice_core::format::{MAX_CLASSES, MAX_NAME_LEN};
use dynaslice_core::{Domain, Error, ModelBytes};
use dynaslice_model::RunRecord;
use dynaslice_sequence::ClassInfo;

/// Checks, before any training, that a model of `classes` in `domain` (from
/// [`crate::data_sampler::domain_for`]) fits the model format: at most [`MAX_CLASSES`] classes,
/// names of at most [`MAX_NAME_LEN`] bytes, and a domain whose centre, scale and time range are
/// representable in the f32 header ([`Domain::validate`]: coordinates or an affine near 1e30
/// are not). Without it such input is refused only when the trained model is written.
pub fn check_model_limits(classes: &[ClassInfo], domain: &Domain) -> Result<(), String> {
    if classes.len() > MAX_CLASSES {
        return Err(format!(
            "{} classes; a model holds at most {MAX_CLASSES} (select fewer, e.g. --labels)",
            classes.len()
        ));
    }
    if let Some(c) = classes.iter().find(|c| c.name.len() > MAX_NAME_LEN) {
        return Err(format!(
            "class name {:?} (label {}) is {} bytes long; a model stores at most {MAX_NAME_LEN} \
             (rename it, e.g. with --label-names)",
            // A name of megabytes is quoted as its first 80 bytes (issue 37).
            dynaslice_sequence::error::excerpt(&c.name),
            c.label,
            c.name.len()
        ));
    }
    domain.validate().map_err(|e| {
        format!(
            "the cross-sections' extent (centre {:?}, half-width {}, times {} + {}) does not fit \
             a model's 32-bit header: {e}",
            domain.center, domain.scale[0], domain.time_origin, domain.time_span
        )
    })
}

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
    /// How far past its contours each class's extent reached (world units), where one was
    /// imposed ([`crate::extent_bound`]).
    pub extent_margin: Option<f32>,
    /// Per class, the neighbouring plane pairs between which samples took their blended
    /// in-plane distances as target, where any class had one ([`crate::sampling`]).
    pub between_pairs: Option<Vec<u32>>,
    /// What was trained on: `input`, `frames`, `space` and `units` of the record (the rest is
    /// filled from the fields above).
    pub input: RunRecord,
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
            .to_writer(self.domain, classes, self.record().emit())
            .try_to_bytes()?;
        Ok(ModelBytes::copy_from(&bytes))
    }

    /// The run record the model's metadata holds (`dynaslice info` prints it).
    pub fn record(&self) -> RunRecord {
        let (o, l) = (self.options, &self.options.loss);
        RunRecord {
            trainer: Some(format!("dynaslice {}", env!("CARGO_PKG_VERSION"))),
            widths: Some(o.widths.clone()),
            steps: Some(o.steps),
            seed: Some(o.seed),
            threads: Some(o.threads),
            omega_0: Some(o.omega_0),
            offset: Some(o.offset),
            omega_t_max: Some(o.omega_t_max),
            plane_band: o.plane_band.map(|b| b.max),
            extent_margin: self.extent_margin,
            between_pairs: self.between_pairs.clone(),
            lr: Some((o.lr, o.lr_final)),
            warmup_steps: Some(o.warmup_steps),
            lambda_orientation: Some(l.orientation),
            lambda_plane: Some(l.plane),
            lambda_regulariser: Some(l.regulariser),
            alpha: Some(l.alpha),
            temporal_factor: Some(self.temporal_factor),
            steps_done: Some(self.outcome.steps_done),
            // A timed run's schedule length: what its cosine was fitted to (--minutes).
            planned_steps: self.outcome.planned_steps,
            samples: Some(self.counts.record()),
            class_weights: self.class_weights.map(<[f32]>::to_vec),
            class_colors: RunRecord::colors_of(self.classes),
            final_loss: self.outcome.last.map(|last| last.2),
            ..self.input.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn class(name: &str, label: i32) -> ClassInfo {
        ClassInfo {
            name: name.into(),
            label,
            color: None,
        }
    }

    /// The readers refuse a label map past the model's class limit before tracing it, by
    /// their own copy of the limit (the input side does not depend on the core).
    #[test]
    fn the_readers_class_limit_is_the_model_format_s() {
        assert_eq!(dynaslice_data::label_census::MAX_CLASSES, MAX_CLASSES);
    }

    #[test]
    fn limits_of_the_format_are_checked() {
        let d = Domain::IDENTITY;
        assert!(check_model_limits(&[class("liver", 1)], &d).is_ok());
        let long = "x".repeat(MAX_NAME_LEN + 1);
        let e = check_model_limits(&[class(&long, 3)], &d).unwrap_err();
        assert!(e.contains("57 bytes") && e.contains("label 3"), "{e}");
        let huge_name = "y".repeat(200_000);
        let e = check_model_limits(&[class(&huge_name, 3)], &d).unwrap_err();
        assert!(
            e.len() < 400 && e.contains("200000 bytes"),
            "{} bytes",
            e.len()
        );
        let many: Vec<ClassInfo> = (0..65).map(|i| class("c", i)).collect();
        assert!(check_model_limits(&many, &d)
            .unwrap_err()
            .contains("65 classes"));
        let huge = Domain {
            scale: [f32::INFINITY; 3],
            ..d
        };
        assert!(check_model_limits(&[class("a", 1)], &huge)
            .unwrap_err()
            .contains("32-bit"));
    }
}
