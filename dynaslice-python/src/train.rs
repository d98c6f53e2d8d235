//! `dynaslice._dynaslice.train`: `dynaslice train` as a function. An adapter over
//! [`dynaslice_train::fit`], as the command line is: the keywords are the command line's flags
//! (`--lr` is `lr`) and map onto the same [`TrainSpec`] and [`InputSpec`], so defaults, rules and
//! error messages are the same. The GIL is released while the network trains, progress is handed
//! to a Python callable, and Ctrl-C stops at a checkpoint.

use crate::model::PyModel;
use crate::{data_error, DynasliceError};
use dynaslice_data::input_spec::InputSpec;
use dynaslice_figures::plot::loss_curve;
use dynaslice_output::{Kind, Plan};
use dynaslice_train::fit::{fit, InputRecord, Observer, RunFiles, Trained};
use dynaslice_train::journal::TERM_NAMES;
use dynaslice_train::spec::{SpecError, TrainSpec};
use dynaslice_train::trainer::Progress;
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};

/// How often Python is asked for Ctrl-C (and the callback is called) at the most: often enough
/// to stop within a blink, rarely enough to cost nothing next to a step.
const POLL: Duration = Duration::from_millis(50);

/// A bad option as Python's `ValueError`, with the command line's words: `lr: -1: out of
/// range; allowed: …`.
fn spec_error(e: &SpecError) -> PyErr {
    PyValueError::new_err(format!("{}: {}", e.option, e.message))
}

/// A training error: a bad option as `ValueError`, anything else as `DynasliceError` with the
/// full cause chain, as `dynaslice` prints it.
fn fit_error(e: anyhow::Error) -> PyErr {
    match e.downcast_ref::<SpecError>() {
        Some(s) => spec_error(s),
        None => DynasliceError::new_err(format!("{e:#}")),
    }
}

/// A string keyword parsed as the command line parses its flag.
fn parsed<T: FromStr>(name: &str, value: Option<&str>) -> PyResult<Option<T>>
where
    T::Err: std::fmt::Display,
{
    value
        .map(|s| {
            s.parse()
                .map_err(|e| PyValueError::new_err(format!("{name} {s:?}: {e}")))
        })
        .transpose()
}

/// A list keyword as a Python user writes it: a list (`[1, 2, 3]`) or the command line's text
/// (`"1,2,3"`).
#[derive(FromPyObject)]
pub enum ListOrText<T> {
    /// A Python list or tuple.
    List(Vec<T>),
    /// Comma-separated, as the command line's flag takes it.
    Text(String),
}

impl<T: FromStr> ListOrText<T>
where
    T::Err: std::fmt::Display,
{
    /// The values; a text's items parsed as the flag parses them, an error naming `name`.
    fn values(self, name: &str) -> PyResult<Vec<T>> {
        match self {
            ListOrText::List(v) => Ok(v),
            ListOrText::Text(s) => s
                .split(',')
                .map(|item| {
                    item.trim()
                        .parse()
                        .map_err(|e| PyValueError::new_err(format!("{name} {s:?}: {item:?}: {e}")))
                })
                .collect(),
        }
    }
}

/// Trains a model on `inputs` as `dynaslice train INPUTS -o OUTPUT` does, writes it to
/// `output` with its loss log and curve beside it (and, while it runs, the checkpoint
/// `OUTPUT.ckpt`, removed when it finishes) and returns it. Every keyword is the command line's
/// flag of the same name (`dynaslice train --help`), with its default and rules. `progress`,
/// when given, is called with a dict (step, steps, loss, lr, elapsed, surface, orientation,
/// plane, eikonal, spurious) at most every 50 ms and after the last step. Ctrl-C (or an
/// exception raised by `progress`) stops training, saves the checkpoint and raises.
#[pyfunction]
#[pyo3(signature = (
    inputs, output, *, steps = None, minutes = None, seed = None, threads = None, progress = None,
    frames = None, label_names = None, planes = None, drawn_axes = None, roi_extent = None,
    rotated_planes = None, axial_step = None, labels = None, pixel = None, nesting = None,
    header_spacing = None, resume = false,
    force = false, no_temporal_control = false, no_orientation = false, widths = None,
    omega0 = None, init_offset = None, temporal_factor = None, lr = None, warmup_steps = None,
    lambda_orientation = None, lambda_plane = None, lambda_regulariser = None, alpha = None,
    contour_samples = None, plane_samples = None, space_samples = None, budget_classes = None,
    min_class_samples = None, class_weights = None, checkpoint_minutes = None
))]
#[allow(clippy::too_many_arguments)]
pub fn train(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    steps: Option<u64>,
    minutes: Option<f64>,
    seed: Option<u64>,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
    frames: Option<String>,
    label_names: Option<PathBuf>,
    planes: Option<String>,
    drawn_axes: Option<String>,
    roi_extent: Option<String>,
    rotated_planes: Option<usize>,
    axial_step: Option<usize>,
    labels: Option<ListOrText<i32>>,
    pixel: Option<f64>,
    nesting: Option<String>,
    header_spacing: Option<String>,
    resume: bool,
    force: bool,
    no_temporal_control: bool,
    no_orientation: bool,
    widths: Option<ListOrText<u32>>,
    omega0: Option<f32>,
    init_offset: Option<f32>,
    temporal_factor: Option<f32>,
    lr: Option<f32>,
    warmup_steps: Option<u64>,
    lambda_orientation: Option<f32>,
    lambda_plane: Option<f32>,
    lambda_regulariser: Option<f32>,
    alpha: Option<f32>,
    contour_samples: Option<usize>,
    plane_samples: Option<usize>,
    space_samples: Option<usize>,
    budget_classes: Option<usize>,
    min_class_samples: Option<usize>,
    class_weights: Option<ListOrText<f32>>,
    checkpoint_minutes: Option<f64>,
) -> PyResult<PyModel> {
    let labels = labels.map(|l| l.values("labels")).transpose()?;
    let widths = widths.map(|w| w.values("widths")).transpose()?;
    let class_weights = class_weights
        .map(|w| w.values("class_weights"))
        .transpose()?;
    let spec = TrainSpec {
        steps,
        minutes,
        seed,
        threads,
        no_temporal_control,
        no_orientation,
        widths,
        omega0,
        init_offset,
        temporal_factor,
        lr,
        warmup_steps,
        lambda_orientation,
        lambda_plane,
        lambda_regulariser,
        alpha,
        contour_samples,
        plane_samples,
        space_samples,
        budget_classes,
        min_class_samples,
        class_weights,
        checkpoint_minutes,
        resume,
        force,
    };
    // Every option first, before any file is read.
    spec.validate().map_err(|e| spec_error(&e))?;
    let files = RunFiles::beside(&output);
    // The command line's one output check and claims, held until the model is written: an
    // existing model or loss log is replaced only with force=True, and a second run on the
    // same output refuses instead of mixing its files with this one's.
    let mut plan = Plan::new(inputs.iter().chain(&label_names), force).force_option("force=True");
    let planned = (|| {
        plan.file("output", &files.model, Kind::Model)?;
        plan.beside(&files.csv)?;
        plan.beside(&files.png)?;
        plan.continued(&files.checkpoint)?;
        plan.continued(&files.journal)
    })();
    planned.map_err(|e| DynasliceError::new_err(format!("{e:#}")))?;
    let input = InputSpec {
        inputs,
        frames: parsed("frames", frames.as_deref())?,
        label_names,
        planes: parsed("planes", planes.as_deref())?,
        drawn_axes: parsed("drawn_axes", drawn_axes.as_deref())?,
        roi_extent: parsed("roi_extent", roi_extent.as_deref())?,
        rotated_planes,
        axial_step,
        labels,
        pixel,
        nesting: parsed("nesting", nesting.as_deref())?,
        header_spacing: parsed("header_spacing", header_spacing.as_deref())?,
    };
    files.check_state(&spec).map_err(fit_error)?;
    let (seq, space) = py
        .detach(|| Ok((input.read()?, input.space()?)))
        .map_err(data_error)?;
    let record = InputRecord {
        description: input.describe(),
        frames: input.frames().to_string(),
        reading: input.reading(),
        space: space.0,
        units: space.1,
    };
    let mut watch = Watch {
        progress,
        stopped: None,
        last_poll: None,
    };
    let trained: Result<Trained, _> =
        py.detach(|| fit(&seq, &spec, &record, Some(&files), &mut watch));
    let trained = trained.map_err(fit_error)?;
    if let Some(e) = watch.stopped {
        let note = format!(
            "training stopped at step {} of {}; checkpoint saved to {} (train again with \
             resume=True to continue)",
            trained.steps_done,
            trained.schedule_steps,
            files.checkpoint.display()
        );
        if e.is_instance_of::<PyKeyboardInterrupt>(py) {
            return Err(PyKeyboardInterrupt::new_err(note));
        }
        // The callback's own exception, with where the run stands as a note.
        let _ = e.value(py).call_method1("add_note", (note,));
        return Err(e);
    }
    py.detach(|| {
        trained.write(&files)?;
        let rows: Vec<(u64, &[f64])> = trained.rows.iter().map(|r| (r.0, &r.1[..])).collect();
        loss_curve(&files.png, &TERM_NAMES, &rows)
    })
    .map_err(|e| DynasliceError::new_err(format!("{e:#}")))?;
    drop(plan);
    PyModel::from_model_bytes(trained.bytes, &output.display().to_string())
}

/// The run as Python sees it: the callback and Ctrl-C, polled at most every [`POLL`].
struct Watch {
    progress: Option<Py<PyAny>>,
    /// Why training stopped early: Ctrl-C or the callback's exception, raised once the
    /// checkpoint is written.
    stopped: Option<PyErr>,
    last_poll: Option<Instant>,
}

impl Observer for Watch {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        let due = self.last_poll.is_none_or(|t| t.elapsed() >= POLL) || p.step == p.steps;
        if !due {
            return ControlFlow::Continue(());
        }
        self.last_poll = Some(Instant::now());
        let progress = &self.progress;
        let result = Python::attach(|py| -> PyResult<()> {
            py.check_signals()?;
            if let Some(callback) = progress {
                let info = PyDict::new(py);
                info.set_item("step", p.step)?;
                info.set_item("steps", p.steps)?;
                info.set_item("loss", p.loss)?;
                info.set_item("lr", p.lr)?;
                info.set_item("elapsed", p.elapsed)?;
                let t = &p.terms;
                info.set_item("surface", t.surface)?;
                info.set_item("orientation", t.orientation)?;
                info.set_item("plane", t.plane)?;
                info.set_item("eikonal", t.eikonal)?;
                info.set_item("spurious", t.spurious)?;
                callback.call1(py, (info,))?;
            }
            Ok(())
        });
        match result {
            Ok(()) => ControlFlow::Continue(()),
            Err(e) => {
                self.stopped = Some(e);
                ControlFlow::Break(())
            }
        }
    }

    fn note(&mut self, line: &str) {
        // Where `dynaslice train` prints it: standard error.
        eprintln!("{line}");
    }
}
