//! Batch queries over NumPy inputs: the points and times as the caller gave them (float32 or
//! float64, contiguous or strided, read in place), evaluated in parallel chunks with the core's
//! SIMD batch kernels, each worker thread with its own [`Scratch`].

use dynaslice_core::{Domain, Model, Scratch, UNDEFINED_LABEL};
use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use std::cell::RefCell;

/// Points per task: enough to amortise a task and fill the 64-row kernel blocks, small enough
/// for the chunk's inputs and outputs to stay in cache (the size dynaslice-volume uses).
pub const CHUNK: usize = 4096;

thread_local! {
    /// One batch scratch (≈ 330 KiB) per thread, made on its first batch and kept, as the C ABI
    /// does: no allocation per call or per task.
    static SCRATCH: RefCell<Option<Box<Scratch>>> = const { RefCell::new(None) };
}

/// Runs `body` with this thread's scratch.
fn with_scratch<R>(body: impl FnOnce(&mut Scratch) -> R) -> R {
    SCRATCH.with(|cell| {
        let mut slot = cell.borrow_mut();
        body(slot.get_or_insert_with(Scratch::boxed))
    })
}

/// The (N, 3) query points, borrowed from the caller's array.
pub enum Points<'a> {
    /// float32, C-contiguous: handed to the kernels as they are.
    Packed(&'a [[f32; 3]]),
    /// float32, strided.
    F32(ArrayView2<'a, f32>),
    /// float64 (rounded to f32 per chunk, the network's precision).
    F64(ArrayView2<'a, f64>),
}

impl Points<'_> {
    /// N.
    pub fn len(&self) -> usize {
        match self {
            Points::Packed(p) => p.len(),
            Points::F32(a) => a.nrows(),
            Points::F64(a) => a.nrows(),
        }
    }

    /// No points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Points `start..start + n`, borrowed when packed, else converted into `buf`.
    fn chunk<'s>(&'s self, start: usize, n: usize, buf: &'s mut Vec<[f32; 3]>) -> &'s [[f32; 3]] {
        buf.clear();
        match self {
            Points::Packed(p) => return &p[start..start + n],
            Points::F32(a) => {
                buf.extend((start..start + n).map(|i| [a[[i, 0]], a[[i, 1]], a[[i, 2]]]))
            }
            Points::F64(a) => buf.extend(
                (start..start + n).map(|i| [a[[i, 0]], a[[i, 1]], a[[i, 2]]].map(|v| v as f32)),
            ),
        }
        buf
    }
}

/// The query times: one for all points, or one per point.
pub enum Times<'a> {
    /// The same time for every point.
    Scalar(f32),
    /// float32, contiguous.
    Packed(&'a [f32]),
    /// float32, strided.
    F32(ArrayView1<'a, f32>),
    /// float64.
    F64(ArrayView1<'a, f64>),
}

impl Times<'_> {
    /// Times `start..start + n`, borrowed when packed, else written into `buf`.
    fn chunk<'s>(&'s self, start: usize, n: usize, buf: &'s mut Vec<f32>) -> &'s [f32] {
        buf.clear();
        match self {
            Times::Packed(t) => return &t[start..start + n],
            Times::Scalar(t) => buf.resize(n, *t),
            Times::F32(a) => buf.extend((start..start + n).map(|i| a[i])),
            Times::F64(a) => buf.extend((start..start + n).map(|i| a[i] as f32)),
        }
        buf
    }
}

/// The caller's points array, held borrowed (read-only) while the query runs.
pub enum PointsArg<'py> {
    /// float32.
    F32(PyReadonlyArray2<'py, f32>),
    /// float64.
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> PointsArg<'py> {
    /// Checks `obj` is an (N, 3) float32 or float64 NumPy array; a ValueError saying what it is
    /// otherwise.
    pub fn extract(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        let array = obj.cast::<PyUntypedArray>().map_err(|_| {
            PyValueError::new_err(format!(
                "points must be a NumPy array of shape (N, 3), not {}",
                type_name(obj)
            ))
        })?;
        if array.ndim() != 2 || array.shape()[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "points must have shape (N, 3), not {:?}",
                array.shape()
            )));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, f32>>() {
            return Ok(PointsArg::F32(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray2<'py, f64>>() {
            return Ok(PointsArg::F64(a));
        }
        Err(PyValueError::new_err(format!(
            "points must be float32 or float64, not {}",
            dtype_name(array)
        )))
    }

    /// The points, packed when the array is C-contiguous float32.
    pub fn view(&self) -> Points<'_> {
        match self {
            PointsArg::F32(a) => {
                let view = a.as_array();
                // ndarray's `to_slice` is C order only (NumPy's also takes Fortran order): an
                // (N, 3) C-contiguous float32 array is N packed [f32; 3] (align 4).
                match view
                    .to_slice()
                    .map(bytemuck::try_cast_slice::<f32, [f32; 3]>)
                {
                    Some(Ok(p)) => Points::Packed(p),
                    _ => Points::F32(view),
                }
            }
            PointsArg::F64(a) => Points::F64(a.as_array()),
        }
    }
}

/// The caller's times: a number, or an (N,) array held borrowed while the query runs.
pub enum TimesArg<'py> {
    /// One time.
    Scalar(f32),
    /// float32 per point.
    F32(PyReadonlyArray1<'py, f32>),
    /// float64 per point.
    F64(PyReadonlyArray1<'py, f64>),
}

impl<'py> TimesArg<'py> {
    /// A Python number, a 0-d array, or an (n,) float32/float64 array; a ValueError otherwise.
    pub fn extract(obj: &Bound<'py, PyAny>, n: usize) -> PyResult<Self> {
        let Ok(array) = obj.cast::<PyUntypedArray>() else {
            let t: f64 = obj.extract().map_err(|_| {
                PyValueError::new_err(format!(
                    "t must be a number or a NumPy array of shape (N,), not {}",
                    type_name(obj)
                ))
            })?;
            return Ok(TimesArg::Scalar(t as f32));
        };
        if array.ndim() == 0 {
            let t: f64 = obj.call_method0("item")?.extract()?;
            return Ok(TimesArg::Scalar(t as f32));
        }
        if array.ndim() != 1 || array.shape()[0] != n {
            return Err(PyValueError::new_err(format!(
                "t must be a number or have shape ({n},), one time per point, not {:?}",
                array.shape()
            )));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray1<'py, f32>>() {
            return Ok(TimesArg::F32(a));
        }
        if let Ok(a) = obj.extract::<PyReadonlyArray1<'py, f64>>() {
            return Ok(TimesArg::F64(a));
        }
        Err(PyValueError::new_err(format!(
            "t must be float32 or float64, not {}",
            dtype_name(array)
        )))
    }

    /// The first time outside `domain`'s range ([`Domain::contains_time`], the rule of every
    /// front end), with its point's index.
    pub fn first_outside(&self, domain: &Domain) -> Option<(usize, f32)> {
        self.find(|t| !domain.contains_time(t))
    }

    /// The first time that is not a finite number, with its point's index.
    pub fn first_not_finite(&self) -> Option<(usize, f32)> {
        self.find(|t| !t.is_finite())
    }

    /// The first time other than `t0`, with its point's index.
    pub fn first_other_than(&self, t0: f32) -> Option<(usize, f32)> {
        self.find(|t| t != t0)
    }

    /// The first time (as the network takes it, f32) for which `test` holds.
    fn find(&self, test: impl Fn(f32) -> bool) -> Option<(usize, f32)> {
        match self {
            TimesArg::Scalar(t) => test(*t).then_some((0, *t)),
            TimesArg::F32(a) => a
                .as_array()
                .iter()
                .copied()
                .enumerate()
                .find(|&(_, t)| test(t)),
            TimesArg::F64(a) => a
                .as_array()
                .iter()
                .map(|&t| t as f32)
                .enumerate()
                .find(|&(_, t)| test(t)),
        }
    }

    /// The times, packed when contiguous float32.
    pub fn view(&self) -> Times<'_> {
        match self {
            TimesArg::Scalar(t) => Times::Scalar(*t),
            TimesArg::F32(a) => match a.as_slice() {
                Ok(s) => Times::Packed(s),
                Err(_) => Times::F32(a.as_array()),
            },
            TimesArg::F64(a) => Times::F64(a.as_array()),
        }
    }
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an unknown type".into())
}

fn dtype_name(array: &Bound<'_, PyUntypedArray>) -> String {
    array
        .dtype()
        .str()
        .map(|s| s.to_string())
        .unwrap_or_else(|_| "an unknown dtype".into())
}

/// What a batch query computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    /// f.
    Values,
    /// f and ∇ₓf.
    Gradient,
    /// f, ∇ₓf and ∂f/∂t.
    Jacobian,
    /// Eq. 11 label indices (0 background, k class k, [`UNDEFINED_LABEL`] for non-finite f).
    Labels,
    /// A motion model's displacement u (world units; zero without motion).
    Displacement,
}

/// The answers of a batch query, point-major (`f[i*K + k]`); the buffers a query does not
/// compute are empty.
#[derive(Default)]
pub struct Answers {
    /// f, N × K.
    pub f: Vec<f32>,
    /// ∇ₓf, N × K.
    pub grad: Vec<[f32; 3]>,
    /// ∂f/∂t, N × K.
    pub dfdt: Vec<f32>,
    /// Label indices, N.
    pub labels: Vec<u32>,
    /// Displacements, N.
    pub displacement: Vec<[f32; 3]>,
}

/// The output buffers of one chunk.
struct Task<'o> {
    start: usize,
    n: usize,
    f: &'o mut [f32],
    grad: &'o mut [[f32; 3]],
    dfdt: &'o mut [f32],
    labels: &'o mut [u32],
    displacement: &'o mut [[f32; 3]],
}

/// Splits `v` into chunks of `size` elements (an empty `v` gives `count` empty chunks).
fn split<T>(v: &mut [T], size: usize, count: usize) -> Vec<&mut [T]> {
    if v.is_empty() {
        return (0..count).map(|_| &mut [][..]).collect();
    }
    v.chunks_mut(size).collect()
}

/// Evaluates `query` at every (point, time) on rayon's current pool. Needs no Python: call it
/// with the GIL released.
pub fn evaluate(
    model: &Model,
    points: &Points,
    times: &Times,
    query: Query,
) -> Result<Answers, dynaslice_core::Error> {
    let (n, k) = (points.len(), model.num_classes());
    let mut out = Answers::default();
    // Value buffers are written in full before being read: zeroed (calloc) memory is the
    // cheapest safe start.
    if matches!(query, Query::Values | Query::Gradient | Query::Jacobian) {
        out.f = vec![0.0; n * k];
    }
    if matches!(query, Query::Gradient | Query::Jacobian) {
        out.grad = vec![[0.0; 3]; n * k];
    }
    if query == Query::Jacobian {
        out.dfdt = vec![0.0; n * k];
    }
    if query == Query::Labels {
        out.labels = vec![0; n];
    }
    if query == Query::Displacement {
        out.displacement = vec![[0.0; 3]; n];
    }
    let count = n.div_ceil(CHUNK);
    let tasks: Vec<Task> = split(&mut out.f, CHUNK * k, count)
        .into_iter()
        .zip(split(&mut out.grad, CHUNK * k, count))
        .zip(split(&mut out.dfdt, CHUNK * k, count))
        .zip(split(&mut out.labels, CHUNK, count))
        .zip(split(&mut out.displacement, CHUNK, count))
        .enumerate()
        .map(|(c, ((((f, grad), dfdt), labels), displacement))| Task {
            start: c * CHUNK,
            n: CHUNK.min(n - c * CHUNK),
            f,
            grad,
            dfdt,
            labels,
            displacement,
        })
        .collect();
    tasks.into_par_iter().try_for_each_init(
        || (Vec::with_capacity(CHUNK), Vec::with_capacity(CHUNK)),
        |(xyz_buf, t_buf), task| {
            let xyz = points.chunk(task.start, task.n, xyz_buf);
            let t = times.chunk(task.start, task.n, t_buf);
            with_scratch(|s| match query {
                Query::Values => model.eval_batch(s, xyz, t, task.f),
                Query::Gradient => model.eval_grad_batch(s, xyz, t, task.f, task.grad),
                Query::Jacobian => {
                    model.eval_jacobian_batch(s, xyz, t, task.f, task.grad, task.dfdt)
                }
                Query::Labels => model.label_batch(s, xyz, t, task.labels),
                Query::Displacement => model.displacement_batch(s, xyz, t, task.displacement),
            })
        },
    )?;
    Ok(out)
}

/// The index of the first point whose label is undefined (a non-finite query or output).
pub fn first_undefined(labels: &[u32]) -> Option<usize> {
    labels.iter().position(|&l| l == UNDEFINED_LABEL)
}
