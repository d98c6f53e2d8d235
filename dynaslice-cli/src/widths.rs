//! The layer-count check of `--widths`, which `train`, `bench` and the lab share: clap checks
//! each width (1 to `MAX_WIDTH`), this checks how many there are, before any work starts, by
//! the training specification's own rule ([`TrainSpec::validate`]).

use anyhow::Result;
use dynaslice_train::spec::TrainSpec;

/// An error naming `--widths` unless there are 1 to `MAX_SINE_LAYERS` sine-layer widths.
pub fn check_widths(widths: &[u32]) -> Result<()> {
    TrainSpec {
        widths: Some(widths.to_vec()),
        ..TrainSpec::default()
    }
    .validate()?;
    Ok(())
}
