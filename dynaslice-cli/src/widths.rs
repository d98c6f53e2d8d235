//! The layer-count check of `--widths`, which `train`, `bench` and the lab share: clap checks
//! each width (1 to `MAX_WIDTH`), this checks how many there are, before any work starts.

use anyhow::{bail, Result};
use dynaslice_core::format::MAX_SINE_LAYERS;

/// An error naming `--widths` unless there are 1 to `MAX_SINE_LAYERS` sine-layer widths.
pub fn check_widths(widths: &[u32]) -> Result<()> {
    if widths.is_empty() || widths.len() > MAX_SINE_LAYERS {
        bail!(
            "--widths: {} layers; a model has 1 to {MAX_SINE_LAYERS} sine layers",
            widths.len()
        );
    }
    Ok(())
}
