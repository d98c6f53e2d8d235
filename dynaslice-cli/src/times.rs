//! The times a command evaluates a model at. A static model ([`ModelFile::is_static`]: trained
//! on one timestep, ω_t^max = 0) gives the same field at every time, so a list of times is one
//! time for it: the work is done once, with a note saying why, instead of N identical outputs.

use super::console::errln;
use anyhow::Result;
use dynaslice_data::TimeSeries;
use dynaslice_model::ModelFile;

/// How a message names one time of `--times`: with the series as the user typed it, so that a
/// time the series made (1.5 of `0:2:5`) is seen to come from what they typed.
pub(crate) fn times_option(series: Option<&TimeSeries>) -> String {
    match series {
        Some(series) => format!("--times {series}: time"),
        None => "--times".into(),
    }
}

/// The times to evaluate `file`'s model at for `requested` (given with `option`):
/// [`ModelFile::times_for`], its note (a static model's one time) on standard error. `what`
/// names the outputs in the note ("one mesh per class").
pub(crate) fn model_times(
    file: &ModelFile,
    option: &str,
    requested: &[f32],
    what: &str,
) -> Result<Vec<f32>> {
    let (times, static_note) = file.times_for(option, requested, what)?;
    if let Some(message) = static_note {
        note(&message);
    }
    Ok(times)
}

/// Prints `message` as a note on standard error (information, not a warning).
pub(crate) fn note(message: &str) {
    errln!("note: {message}");
}
