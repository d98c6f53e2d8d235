//! The native part of the `dynaslice` Python package (`dynaslice._dynaslice`): the model and
//! its NumPy batch queries ([`model`], [`batch`]), meshes and label volumes through
//! dynaslice-mesh and dynaslice-volume, and training through dynaslice-train ([`train`]).
//! `python/dynaslice/__init__.py` wraps it in the documented API (docs/python.md).
//!
//! Every long call releases the GIL (`Python::detach`); Rust errors become
//! `dynaslice.DynasliceError` with the message the command line prints, bad array shapes and
//! dtypes `ValueError`.

#![warn(missing_docs)]

pub mod batch;
pub mod figures;
pub mod model;
pub mod progress;
pub mod train;

use dynaslice_core::{format::ModelWriter, ModelBytes};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use std::time::Instant;

// Named `dynaslice.DynasliceError` in tracebacks: the package re-exports it.
create_exception!(
    dynaslice,
    DynasliceError,
    PyException,
    "A DynaSlice operation failed: unreadable or invalid model or input files, training or \
     meshing errors. The message is the one the `dynaslice` command line prints."
);

/// A model-evaluation error as a Python exception.
pub(crate) fn core_error(e: dynaslice_core::Error) -> PyErr {
    DynasliceError::new_err(e.to_string())
}

/// Runs `f` with the GIL released; its error becomes a DynasliceError with the full cause
/// chain, as `dynaslice` prints it (`error: {e:#}`).
pub(crate) fn detach_result<T: Send>(
    py: Python<'_>,
    f: impl Send + FnOnce() -> anyhow::Result<T>,
) -> PyResult<T> {
    py.detach(f)
        .map_err(|e| DynasliceError::new_err(format!("{e:#}")))
}

/// A worker pool of `threads` threads (None: one per core), as the command line builds one
/// per command.
pub(crate) fn pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    use anyhow::Context;
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}

/// Name of the batch kernels this CPU gets ("avx512", "avx2" or "portable").
#[pyfunction]
fn kernel_name() -> &'static str {
    dynaslice_core::kernel_name()
}

/// A model with random weights (a SIREN with the given hidden widths and K classes; with
/// `motion_widths`, a motion model whose motion network has those widths): for tests and
/// benchmarks that need a model of a given size without training one.
#[pyfunction]
#[pyo3(signature = (widths, num_classes, seed = 0, motion_widths = None))]
fn random_model(
    widths: Vec<u32>,
    num_classes: u32,
    seed: u64,
    motion_widths: Option<Vec<u32>>,
) -> PyResult<model::PyModel> {
    let mut writer = match motion_widths {
        Some(m) => ModelWriter::random_motion(&widths, num_classes, &m, seed),
        None => ModelWriter::random_siren(&widths, num_classes, seed),
    };
    writer.metadata = "random weights (dynaslice.random_model)".into();
    let bytes = writer
        .try_to_bytes()
        .map_err(|e| PyValueError::new_err(format!("cannot build the model: {e}")))?;
    model::PyModel::from_model_bytes(ModelBytes::copy_from(&bytes), "random model")
}

/// The Rust reference rate of `Model.sdf`: `n` points spread over the model's bounds (seeded),
/// packed float32 in Rust memory, one time for all, evaluated by the same parallel batch
/// function `sdf` calls, timed inside Rust with no Python in between. Returns the best of
/// `repeats` runs in seconds, and the points (N, 3) so that the caller can time `sdf` on the
/// same batch.
#[pyfunction]
#[pyo3(signature = (model, n, t, repeats = 5))]
fn _bench_rust_batch<'py>(
    py: Python<'py>,
    model: &model::PyModel,
    n: usize,
    t: f32,
    repeats: usize,
) -> PyResult<(f64, Bound<'py, numpy::PyArray2<f32>>)> {
    use numpy::IntoPyArray;
    if n == 0 || n > 1 << 27 || repeats == 0 {
        return Err(PyValueError::new_err(
            "n must be in 1..=2^27 and repeats at least 1",
        ));
    }
    let m = &model.model();
    let (lo, hi) = m.domain().bounds();
    // SplitMix64: a fixed, dependency-free spread of points (the values do not matter, only
    // that both sides evaluate the same ones).
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let points: Vec<[f32; 3]> = (0..n)
        .map(|_| std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * next()))
        .collect();
    let best = py.detach(|| {
        let view = batch::Points::Packed(&points);
        let times = batch::Times::Scalar(t);
        let mut best = f64::INFINITY;
        for _ in 0..repeats {
            let start = Instant::now();
            let answers = batch::evaluate(m, &view, &times, batch::Query::Values)?;
            best = best.min(start.elapsed().as_secs_f64());
            std::hint::black_box(answers);
        }
        Ok::<_, dynaslice_core::Error>(best)
    });
    let best = best.map_err(core_error)?;
    let array = numpy::ndarray::Array2::from_shape_vec((n, 3), points.into_flattened())
        .expect("N × 3")
        .into_pyarray(py);
    Ok((best, array))
}

/// The `dynaslice._dynaslice` extension module.
#[pymodule]
fn _dynaslice(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The library's `log` records go to Python's `logging`, to the logger named after the Rust
    // module (`dynaslice_data.csl`, …): what the command line prints as warnings. A second
    // logger already installed (another extension's) keeps its place. Nothing is cached, so
    // levels set later (logging.basicConfig, pytest's caplog) take effect: the library logs
    // rarely (warnings, notes), never in a loop.
    if let Ok(logger) = pyo3_log::Logger::new(m.py(), pyo3_log::Caching::Nothing) {
        let _ = logger.install();
    }
    m.add("DynasliceError", m.py().get_type::<DynasliceError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // The one default of `dynaslice mesh`, `measure` and `report --resolution`.
    m.add(
        "DEFAULT_RESOLUTION",
        dynaslice_mesh::lattice::DEFAULT_RESOLUTION,
    )?;
    m.add_class::<model::PyModel>()?;
    m.add_function(wrap_pyfunction!(train::train, m)?)?;
    m.add_function(wrap_pyfunction!(figures::description, m)?)?;
    m.add_function(wrap_pyfunction!(figures::measure_json, m)?)?;
    m.add_function(wrap_pyfunction!(figures::report, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_name, m)?)?;
    m.add_function(wrap_pyfunction!(random_model, m)?)?;
    m.add_function(wrap_pyfunction!(_bench_rust_batch, m)?)?;
    Ok(())
}
