//! The times a command evaluates a model at. A static model ([`ModelFile::is_static`]: trained
//! on one timestep, ω_t^max = 0) gives the same field at every time, so a list of times is one
//! time for it: the work is done once, with a note saying why, instead of N identical outputs.

use super::console::errln;
use anyhow::Result;
use dynaslice_data::TimeSeries;
use dynaslice_model::ModelFile;
use std::path::Path;

/// How a message names one time of `--times`: with the series as the user typed it, so that a
/// time the series made (1.5 of `0:2:5`) is seen to come from what they typed.
pub(crate) fn times_option(series: Option<&TimeSeries>) -> String {
    match series {
        Some(series) => format!("--times {series}: time"),
        None => "--times".into(),
    }
}

/// The times to evaluate `file`'s model (read from `path`) at for `requested` (given with `option`): a moving
/// model's, each checked against its time range; a static model's one time (the start of its
/// nominal range), with a note on standard error when more times, or another time, were asked
/// for. `what` names the outputs in the note ("one mesh per class").
pub(crate) fn model_times(
    file: &ModelFile,
    path: &Path,
    option: &str,
    requested: &[f32],
    what: &str,
) -> Result<Vec<f32>> {
    if !file.is_static() {
        for &t in requested {
            file.check_time(option, t)?;
        }
        return Ok(requested.to_vec());
    }
    let t0 = file.model().domain().time_range().0;
    if requested.iter().any(|&t| t != t0) || requested.len() > 1 {
        note(&format!(
            "{}: a static model (trained on one timestep, ω_t^max = 0) is the same at every \
             time; {what} at its time {t0}, not at the {} time(s) of {option}",
            path.display(),
            requested.len()
        ));
    }
    Ok(vec![t0])
}

/// Prints `message` as a note on standard error (information, not a warning).
pub(crate) fn note(message: &str) {
    errln!("note: {message}");
}
