//! `dynaslice._dynaslice.train`: `dynaslice train` as a function, over the same job
//! ([`dynaslice_train::job`]). A keyword is a training option of the command line's table
//! (`dynaslice_train::flags`: `--lr` is `lr`) or an input option ([`InputSpec::set`]), its value
//! read as the flag's text is, so defaults, rules, messages, files and the extent warnings (to
//! Python's `logging`) are the command line's. The GIL is released while the job runs, progress
//! is handed to a Python callable, and Ctrl-C stops at a checkpoint.

use crate::model::PyModel;
use crate::DynasliceError;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_train::job::{self, Job, SetError, Words};
use dynaslice_train::{fit::Observer, spec::SpecError, spec::TrainSpec, trainer::Progress};
use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{IntoPyDict, PyDict, PyString};
use std::time::{Duration, Instant};
use std::{ops::ControlFlow, path::PathBuf};

/// How often Python is asked for Ctrl-C (and the callback is called) at the most: often enough
/// to stop within a blink, rarely enough to cost nothing next to a step.
const POLL: Duration = Duration::from_millis(50);

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
    let job = Job::new(&input, &spec, &output, Words::PYTHON);
    let mut watch = Watch(progress, None, None);
    let finished = py
        .detach(|| job::run(&job, &mut watch))
        .map_err(job_error)?;
    let Some(e) = watch.1 else {
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

/// How often the index's progress is printed while it is built.
const INDEXING_LINES: Duration = Duration::from_secs(5);

/// The run as Python sees it: the `progress` callback and Ctrl-C, polled at most every
/// [`POLL`] (the last poll's time); why training stopped early (Ctrl-C or the callback's
/// exception), raised after the job.
struct Watch(Option<Py<PyAny>>, Option<PyErr>, Option<Instant>);

impl Observer for Watch {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        if self.2.is_some_and(|t| t.elapsed() < POLL) && p.step < p.steps {
            return ControlFlow::Continue(());
        }
        self.2 = Some(Instant::now());
        let polled = Python::attach(|py| -> PyResult<()> {
            py.check_signals()?;
            if let Some(callback) = &self.0 {
                let info = [("step", p.step), ("steps", p.steps)].into_py_dict(py)?;
                for (key, value) in p.figures() {
                    info.set_item(key, value)?;
                }
                callback.call1(py, (info,))?;
            }
            Ok(())
        });
        self.1 = polled.err();
        self.1
            .as_ref()
            .map_or(ControlFlow::Continue(()), |_| ControlFlow::Break(()))
    }

    fn note(&mut self, line: &str) {
        // Where `dynaslice train` prints it: standard error.
        eprintln!("{line}");
    }

    fn indexing(&mut self, done: usize, total: usize) {
        // A line every few seconds, as the command line prints one, and the last.
        if done == total || self.2.is_none_or(|t| t.elapsed() >= INDEXING_LINES) {
            eprintln!("building the sampling index: annotation {done}/{total}");
            self.2 = Some(Instant::now());
        }
    }
}
