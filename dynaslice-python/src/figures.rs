//! What `dynaslice info`, `measure` and `report` give, as functions of a loaded model: the same
//! library calls ([`describe`], [`Measurement::of_file`], [`dynaslice_report::assemble_with_input`]),
//! so the same model gives the same description, figures and page from either front end
//! (`tests/test_parity.py`).

use crate::model::PyModel;
use crate::{detach_result, DynasliceError};
use anyhow::Context;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_data::TimeSeries;
use dynaslice_mesh::lattice::{MAX_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::measurement::{times_of, Measurement};
use dynaslice_model::{describe, ModelFile};
use dynaslice_output::{write_via, Kind, Plan};
use dynaslice_train::fit::RunFiles;
use dynaslice_train::job::input_as_trained;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The lines `dynaslice info` prints of the model itself: size, layer widths, cost per point,
/// world bounds, time range, classes and metadata.
#[pyfunction]
pub fn description(model: &PyModel) -> Vec<String> {
    let file = model.file();
    describe(&file.model(), file.len())
}

/// The times and lattice of a measurement as `dynaslice measure` reads `--times` (the command
/// line's text: a list `0,0.5,1` or `A:B:N`; None: its default) and `--resolution`.
fn measured_at(file: &ModelFile, times: Option<&str>, resolution: u32) -> PyResult<Vec<f64>> {
    if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&resolution) {
        return Err(PyValueError::new_err(format!(
            "resolution {resolution}: out of range; allowed: {MIN_RESOLUTION} to {MAX_RESOLUTION}"
        )));
    }
    let series = times
        .map(|text| {
            text.parse::<TimeSeries>()
                .map_err(|e| PyValueError::new_err(format!("times {text:?}: {e}")))
        })
        .transpose()?;
    let option = match &series {
        Some(series) => format!("times {series}: time"),
        None => "times".into(),
    };
    times_of(file, series.as_ref(), &option).map_err(|e| PyValueError::new_err(format!("{e:#}")))
}

/// The figures of `dynaslice measure MODEL --json` as its JSON text: per class and time the
/// volume, centroid and box in the input's units and patient frame; per class the cycle.
#[pyfunction]
#[pyo3(signature = (model, times = None, resolution = dynaslice_mesh::lattice::DEFAULT_RESOLUTION))]
pub fn measure_json(
    py: Python<'_>,
    model: &PyModel,
    times: Option<String>,
    resolution: u32,
) -> PyResult<String> {
    let file = model.file();
    let times = measured_at(file, times.as_deref(), resolution)?;
    let m = detach_result(py, || Measurement::of_file(file, &times, resolution, || {}))?;
    serde_json::to_string(&m.to_json(file.path()))
        .map_err(|e| DynasliceError::new_err(e.to_string()))
}

/// Writes the page of `dynaslice report MODEL [INPUT…] -o output` (the loss curve from the log
/// beside the model file where there is one; with `inputs`, read as the model was trained on
/// them, the plane view). Refuses to replace an existing page unless `force`.
#[pyfunction]
#[pyo3(signature = (model, output, inputs = Vec::new(), times = None, resolution = dynaslice_mesh::lattice::DEFAULT_RESOLUTION, force = false))]
pub fn report(
    py: Python<'_>,
    model: &PyModel,
    output: PathBuf,
    inputs: Vec<PathBuf>,
    times: Option<String>,
    resolution: u32,
    force: bool,
) -> PyResult<()> {
    let file = model.file();
    let loss_csv = RunFiles::beside(file.path()).csv;
    let times = measured_at(file, times.as_deref(), resolution)?;
    detach_result(py, || {
        let mut plan = Plan::new(
            [file.path(), &loss_csv]
                .into_iter()
                .chain(inputs.iter().map(|p| p.as_path())),
            force,
        )
        .force_option("force=True");
        plan.file("output", &output, Kind::Html)?;
        let m = Measurement::of_file(file, &times, resolution, || {})?;
        let seq = if inputs.is_empty() {
            None
        } else {
            let spec = InputSpec {
                inputs: inputs.clone(),
                ..InputSpec::default()
            };
            let (spec, taken) = input_as_trained(spec, file)?;
            if let Some(taken) = taken {
                log::info!("{taken}");
            }
            Some((spec.read()?, spec.describe()))
        };
        let input = seq
            .as_ref()
            .map(|(sequence, name)| dynaslice_report::Input {
                sequence,
                name: name.clone(),
            });
        let html =
            dynaslice_report::assemble_with_input(file, &m, Some(&loss_csv), input.as_ref())?
                .to_html();
        write_via(&output, |tmp| {
            std::fs::write(tmp, &html).with_context(|| format!("cannot write {}", tmp.display()))
        })
    })
}
