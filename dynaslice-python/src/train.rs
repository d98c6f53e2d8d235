//! `dynaslice._dynaslice.train`: `dynaslice train` as a function, the GIL released while the
//! network trains, progress handed to a Python callable, Ctrl-C stopping at a checkpoint.

use crate::model::PyModel;
use crate::{data_error, DynasliceError};
use dynaslice_data::atomic::write_atomically;
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::input::{self, InputOptions};
use dynaslice_data::reslice::ResliceOptions;
use dynaslice_data::LabelTable;
use dynaslice_train::data_sampler::{domain_for, DataSampler, SampleCounts};
use dynaslice_train::loss::LossWeights;
use dynaslice_train::model_file::TrainedModel;
use dynaslice_train::temporal_bound::{temporal_bound, DEFAULT_TEMPORAL_FACTOR};
use dynaslice_train::trainer::{self, TrainOptions};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The path beside `model` with `suffix` appended (`heart.dsm` → `heart.dsm.ckpt`), where
/// `dynaslice train` keeps its checkpoint.
fn beside(model: &Path, suffix: &str) -> PathBuf {
    let mut s = model.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// How often Python is asked for Ctrl-C (and the callback is called) at the most: often enough
/// to stop within a blink, rarely enough to cost nothing next to a step.
const POLL: Duration = Duration::from_millis(50);

/// Trains a model on `inputs` as `dynaslice train INPUTS -o OUTPUT` does, writes it to
/// `output` (checkpoint beside it, `OUTPUT.ckpt`) and returns it. Every option has the
/// command line's default and meaning (`dynaslice train --help`). `progress`, when given, is
/// called with a dict (step, steps, loss, lr, elapsed, surface, orientation, plane, eikonal,
/// spurious) at most every 50 ms and after the last step. Ctrl-C (or an exception raised by
/// `progress`) stops training, saves the checkpoint and raises.
#[pyfunction]
#[pyo3(signature = (
    inputs, output, *, steps = None, minutes = None, seed = 0, threads = None, progress = None,
    frames = None, label_names = None, planes = None, drawn_axes = None, rotated_planes = None, axial_step = None, labels = None,
    pixel = None, resume = false, no_temporal_control = false, no_orientation = false,
    widths = None, omega0 = None, init_offset = None, temporal_factor = None, lr = None,
    warmup_steps = None, lambda_orientation = None, lambda_plane = None,
    lambda_regulariser = None, alpha = None, contour_samples = None, plane_samples = None,
    space_samples = None, class_weights = None, checkpoint_minutes = 2.0
))]
#[allow(clippy::too_many_arguments)]
pub fn train(
    py: Python<'_>,
    inputs: Vec<PathBuf>,
    output: PathBuf,
    steps: Option<u64>,
    minutes: Option<f64>,
    seed: u64,
    threads: Option<usize>,
    progress: Option<Py<PyAny>>,
    frames: Option<String>,
    label_names: Option<PathBuf>,
    planes: Option<String>,
    drawn_axes: Option<String>,
    rotated_planes: Option<usize>,
    axial_step: Option<usize>,
    labels: Option<Vec<i32>>,
    pixel: Option<f64>,
    resume: bool,
    no_temporal_control: bool,
    no_orientation: bool,
    widths: Option<Vec<u32>>,
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
    class_weights: Option<Vec<f32>>,
    checkpoint_minutes: f64,
) -> PyResult<PyModel> {
    let frames: FrameRange = match &frames {
        Some(s) => s
            .parse()
            .map_err(|e| PyValueError::new_err(format!("frames {s:?}: {e}")))?,
        None => FrameRange::ALL,
    };
    let mut input_options = InputOptions::default();
    if let Some(s) = &planes {
        input_options.planes = s
            .parse()
            .map_err(|e| PyValueError::new_err(format!("planes {s:?}: {e}")))?;
    }
    if let Some(s) = &drawn_axes {
        input_options.sparse_axes = s
            .parse()
            .map_err(|e| PyValueError::new_err(format!("drawn_axes {s:?}: {e}")))?;
    }
    if minutes.is_some_and(|m| !(m.is_finite() && m > 0.0)) {
        return Err(PyValueError::new_err("minutes must be a positive number"));
    }
    if !(checkpoint_minutes.is_finite() && checkpoint_minutes > 0.0) {
        return Err(PyValueError::new_err(
            "checkpoint_minutes must be a positive number",
        ));
    }
    let defaults = TrainOptions::default();
    let reslice_defaults = ResliceOptions::default();
    let sample_defaults = SampleCounts::default();
    let lr = lr.unwrap_or(defaults.lr);
    let temporal_factor = temporal_factor.unwrap_or(DEFAULT_TEMPORAL_FACTOR);
    let counts = SampleCounts {
        contour_per_class: contour_samples.unwrap_or(sample_defaults.contour_per_class),
        plane_per_class: plane_samples.unwrap_or(sample_defaults.plane_per_class),
        space: space_samples.unwrap_or(sample_defaults.space),
        ..sample_defaults
    };
    let describe = inputs
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(" + ");

    let seq = py
        .detach(|| {
            let table = match &label_names {
                Some(p) => LabelTable::read(p)?,
                None => LabelTable::default(),
            };
            let options = InputOptions {
                frames,
                table,
                reslice: ResliceOptions {
                    rotated: rotated_planes.unwrap_or(reslice_defaults.rotated),
                    axial_step: axial_step.unwrap_or(reslice_defaults.axial_step),
                    frames: FrameRange::ALL,
                    labels,
                    pixel,
                },
                // The command line's defaults for what is not set here.
                ..input_options
            };
            input::read(&inputs, &options)
        })
        .map_err(data_error)?;
    let domain = domain_for(&seq);
    let omega_t_max = temporal_bound(&seq, &domain, temporal_factor, !no_temporal_control);
    let checkpoint = beside(&output, ".ckpt");
    let options = TrainOptions {
        widths: widths.unwrap_or(defaults.widths),
        steps: steps.unwrap_or(defaults.steps),
        time_limit: minutes.map(|m| Duration::from_secs_f64(m * 60.0)),
        omega_0: omega0.unwrap_or(defaults.omega_0),
        offset: init_offset.unwrap_or(defaults.offset),
        seed,
        threads: threads.unwrap_or(defaults.threads).max(1),
        lr,
        lr_final: lr / 10.0,
        warmup_steps: warmup_steps.unwrap_or(defaults.warmup_steps),
        loss: LossWeights {
            orientation: if no_orientation {
                0.0
            } else {
                lambda_orientation.unwrap_or(defaults.loss.orientation)
            },
            plane: lambda_plane.unwrap_or(defaults.loss.plane),
            regulariser: lambda_regulariser.unwrap_or(defaults.loss.regulariser),
            alpha: alpha.unwrap_or(defaults.loss.alpha),
        },
        omega_t_max,
        checkpoint: Some(checkpoint.clone()),
        checkpoint_every: Duration::from_secs_f64(checkpoint_minutes * 60.0),
        resume,
    };
    let mut sampler = DataSampler::new(&seq, domain, counts);
    if let Some(w) = &class_weights {
        sampler = sampler
            .with_class_weights(w)
            .map_err(|e| PyValueError::new_err(format!("class_weights: {e}")))?;
    }
    let k = seq.classes().len();

    // Why training stopped early: Ctrl-C or the callback's exception, raised once the
    // checkpoint is written.
    let mut stopped: Option<PyErr> = None;
    let mut last_poll: Option<Instant> = None;
    let outcome = py.detach(|| {
        trainer::train(&options, k, &mut sampler, |p| {
            let due = last_poll.is_none_or(|t| t.elapsed() >= POLL) || p.step == p.steps;
            if !due {
                return ControlFlow::Continue(());
            }
            last_poll = Some(Instant::now());
            let result = Python::attach(|py| -> PyResult<()> {
                py.check_signals()?;
                if let Some(callback) = &progress {
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
                    stopped = Some(e);
                    ControlFlow::Break(())
                }
            }
        })
    });
    let outcome =
        outcome.map_err(|e| DynasliceError::new_err(format!("training failed: {e:#}")))?;
    if let Some(e) = stopped {
        let note = format!(
            "training stopped at step {} of {}; checkpoint saved to {} (train again with \
             resume=True to continue)",
            outcome.steps_done,
            options.steps,
            checkpoint.display()
        );
        if e.is_instance_of::<PyKeyboardInterrupt>(py) {
            return Err(PyKeyboardInterrupt::new_err(note));
        }
        // The callback's own exception, with where the run stands as a note.
        let _ = e.value(py).call_method1("add_note", (note,));
        return Err(e);
    }

    let bytes = TrainedModel {
        outcome: &outcome,
        domain,
        classes: seq.classes(),
        options: &options,
        counts,
        temporal_factor,
        class_weights: class_weights.as_deref(),
        input: &format!("input = {describe}\nframes = {frames}"),
    }
    .to_bytes()
    .map_err(|e| DynasliceError::new_err(format!("cannot write the model: {e}")))?;
    py.detach(|| write_atomically(&output, &bytes))
        .map_err(|e| DynasliceError::new_err(format!("{e:#}")))?;
    PyModel::from_model_bytes(bytes, &output.display().to_string())
}
