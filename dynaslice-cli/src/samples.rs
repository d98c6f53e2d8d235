//! The samples each training step draws: the options `train` and `bench` share.

use super::options::{count, MAX_SAMPLES_PER_STEP};
use dynaslice_core::format::MAX_CLASSES;
use dynaslice_train::data_sampler::SampleCounts;
use dynaslice_train::spec::TrainSpec;

/// Samples per step (`dynaslice_train::data_sampler::SampleCounts`).
#[derive(clap::Args, Debug)]
pub struct SampleArgs {
    /// Contour points per class per step (up to --budget-classes classes).
    #[arg(long, default_value_t = SampleCounts::default().contour_per_class,
          value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    contour_samples: usize,
    /// Plane samples per class per step (up to --budget-classes classes).
    #[arg(long, default_value_t = SampleCounts::default().plane_per_class,
          value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    plane_samples: usize,
    /// With more classes than this, the classes share the contour and plane samples of this
    /// many, split by contour length with at least --min-class-samples each, so a step of 41
    /// classes costs about what a step of 3 does (`dynaslice bench`). 64 gives every class its
    /// full count.
    #[arg(long, default_value_t = SampleCounts::default().budget_classes,
          value_parser = count(1, MAX_CLASSES))]
    budget_classes: usize,
    /// The fewest contour and plane samples of a class when classes share the budget.
    #[arg(long, default_value_t = SampleCounts::default().min_per_class,
          value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    min_class_samples: usize,
    /// Space-time samples per step.
    #[arg(long, default_value_t = SampleCounts::default().space,
          value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    space_samples: usize,
}

impl SampleArgs {
    /// `spec` with these options set.
    pub fn apply(&self, spec: TrainSpec) -> TrainSpec {
        TrainSpec {
            contour_samples: Some(self.contour_samples),
            plane_samples: Some(self.plane_samples),
            space_samples: Some(self.space_samples),
            budget_classes: Some(self.budget_classes),
            min_class_samples: Some(self.min_class_samples),
            ..spec
        }
    }

    /// The counts these options give.
    pub fn counts(&self) -> SampleCounts {
        self.apply(TrainSpec::default()).counts()
    }
}
