//! `dynaslice._dynaslice.train`: `dynaslice train` as a function, over the same job
//! ([`dynaslice_train::job`]). A keyword is a training option of the command line's table
//! (`dynaslice_train::flags`: `--lr` is `lr`) or an input option ([`InputSpec::set`]), its value
//! read as the flag's text is, so defaults, rules, messages, files and the extent warnings (to
//! Python's `logging`) are the command line's. The GIL is released while the job runs, progress
//! is handed to a Python callable, and Ctrl-C stops at a checkpoint.

use crate::model::PyModel;
use crate::progress::Watch;
use crate::DynasliceError;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_figures::plot::loss_curve;
use dynaslice_train::job::{self, Job, SetError, Words};
use dynaslice_train::{spec::SpecError, spec::TrainSpec};
use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use std::path::PathBuf;

/// A bad option as `ValueError` with the command line's words (`lr: -1: out of range; …`);
/// any other failure as `DynasliceError` with the full cause chain, as `dynaslice` prints it.
fn job_error(e: anyhow::Error) -> PyErr {
    match e.downcast_ref::<SpecError>() {
        Some(s) => PyValueError::new_err(format!("{}: {}", s.option, s.message)),
        None => DynasliceError::new_err(format!("{e:#}")),
    }
}

/// The command line's text of a keyword's value: a list's items joined by commas (Python's
/// `str` of a float reads back as the same float).
fn text(v: &Bound<'_, PyAny>) -> PyResult<String> {
    match v.try_iter() {
        Ok(items) if !v.is_instance_of::<PyString>() => Ok(items
            .map(|i| Ok(i?.str()?.to_string()))
            .collect::<PyResult<Vec<_>>>()?
            .join(",")),
        _ => Ok(v.str()?.to_string()),
    }
}

/// Trains a model on `inputs` as `dynaslice train INPUTS -o OUTPUT` does (the same files,
/// checkpoint and warnings) and returns it; a keyword of `None` is the default. `progress`, when
/// given, is called with a dict (step, steps, loss, lr, elapsed and the loss terms) at most every
/// 50 ms and after the last step. Ctrl-C (or an exception from `progress`) stops training, saves
/// the checkpoint and raises.
#[pyfunction]
#[pyo3(signature = (inputs, output, *, progress = None, **options))]
pub fn train(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    progress: Option<Py<PyAny>>,
    options: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyModel> {
    let (mut spec, mut input) = (TrainSpec::default(), InputSpec::default());
    input.inputs = inputs;
    for (key, value) in options.into_iter().flatten().filter(|(_, v)| !v.is_none()) {
        let key: String = key.extract()?;
        job::set(&mut spec, &mut input, &key, &text(&value)?).map_err(|e| match e {
            SetError::Invalid(message) => PyValueError::new_err(message),
            SetError::Unknown => PyTypeError::new_err(format!(
                "train() got an unexpected keyword argument '{key}'"
            )),
        })?;
    }
    let job = Job::new(&input, &spec, &output, Words::PYTHON, loss_curve);
    let mut watch = Watch::new(progress);
    let finished = py
        .detach(|| job::run(&job, &mut watch))
        .map_err(job_error)?;
    let Some(e) = watch.stopped_by() else {
        return PyModel::from_model_bytes(finished.trained.bytes, &output.display().to_string());
    };
    let note = finished.interrupted("resume=True");
    if e.is_instance_of::<PyKeyboardInterrupt>(py) {
        return Err(PyKeyboardInterrupt::new_err(note));
    }
    // The callback's own exception, with where the run stands as a note.
    let _ = e.value(py).call_method1("add_note", (note,));
    Err(e)
}
