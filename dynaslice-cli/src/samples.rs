//! The samples each training step draws: the options `train` and `bench` share, the rows
//! `dynaslice_train::flags::SAMPLE_COUNTS` of the training options' table.

use crate::options::flag_args;
use dynaslice_train::data_sampler::SampleCounts;
use dynaslice_train::flags::SAMPLE_COUNTS;
use dynaslice_train::spec::TrainSpec;

flag_args!(
    /// Samples per step (`dynaslice_train::data_sampler::SampleCounts`), with the table's
    /// help, defaults and limits.
    SampleArgs,
    SAMPLE_COUNTS
);

impl SampleArgs {
    /// The counts these options give.
    pub fn counts(&self) -> SampleCounts {
        self.apply(TrainSpec::default()).counts()
    }
}
