//! `dynaslice._dynaslice.Model`: a loaded model and its queries.

use crate::batch::{self, Answers, PointsArg, Query, TimesArg};
use crate::{core_error, detach_result, pool, DynasliceError};
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::nifti::read_volume;
use dynaslice_mesh::{self as mesh, Options};
use dynaslice_model::{recorded_class_colors, resolve_classes, ModelFile};
use dynaslice_sequence::palette;
use dynaslice_volume::{label_indices, source_labels, write_model_labels, VoxelGrid};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::ffi::CString;
use std::path::{Path, PathBuf};

/// (name, source label value, recorded colour): one class as Python sees it.
type ClassRecord = (String, i32, Option<Rgb>);

/// A colour (r, g, b), a tuple in Python.
type Rgb = (u8, u8, u8);

/// A DynaSlice model: one network f: R³ × [t₀, t₁] → R^K, one signed distance per class
/// (negative inside), in world units (the RAS frame of the images it was trained on).
///
/// Immutable: one Model may be queried from many threads at once. Batch queries release the
/// GIL and run on all cores (the `RAYON_NUM_THREADS` environment variable caps them).
#[pyclass(name = "Model", module = "dynaslice._dynaslice", frozen)]
pub struct PyModel {
    /// Validated once, at load, with its run record: the command line's `ModelFile`.
    file: ModelFile,
}

impl PyModel {
    /// Wraps validated bytes.
    pub fn from_model_bytes(bytes: ModelBytes, source: &str) -> PyResult<PyModel> {
        let file = ModelFile::from_bytes(bytes, Path::new(source))
            .map_err(|e| DynasliceError::new_err(format!("{e:#}")))?;
        Ok(PyModel { file })
    }

    /// The model (a view validated at load: free to call).
    pub(crate) fn model(&self) -> Model<'_> {
        self.file.model()
    }

    /// The model file, with its run record.
    pub(crate) fn file(&self) -> &ModelFile {
        &self.file
    }

    /// Runs a batch query with the GIL released.
    fn query(
        &self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        t: &Bound<'_, PyAny>,
        query: Query,
    ) -> PyResult<(usize, Answers)> {
        let points = PointsArg::extract(points)?;
        let view = points.view();
        let n = view.len();
        let mut times = TimesArg::extract(t, n)?;
        let model = &self.model();
        let at = |i: usize| {
            if n > 1 {
                format!(" (point {i})")
            } else {
                String::new()
            }
        };
        if let Some(t0) = self.static_time() {
            // Any time is answered at the model's one time, as `dynaslice query` does.
            if let Some((i, t)) = times.first_not_finite() {
                return Err(PyValueError::new_err(format!(
                    "time {t}{} is not a finite number",
                    at(i)
                )));
            }
            if let Some((_, t)) = times.first_other_than(t0) {
                static_note(t0, &format!("time {t}"), "answering");
            }
            times = TimesArg::Scalar(t0);
        } else if let Some((i, t)) = times.first_outside(model.domain()) {
            return Err(outside(model, t, &at(i)));
        }
        let times = times.view();
        let answers = py
            .detach(|| batch::evaluate(model, &view, &times, query))
            .map_err(core_error)?;
        Ok((n, answers))
    }

    /// The one time of a static model (trained on one timestep: ω_t^max = 0, every ω_t
    /// clamped to 0, so f does not depend on t; dynaslice-core's `Model::is_static`),
    /// the start of its nominal range; `None` for a moving model.
    fn static_time(&self) -> Option<f32> {
        let model = &self.model();
        model.is_static().then(|| model.domain().time_range().0)
    }

    /// The times a computation at `times` runs at ([`ModelFile::times_for`], the command
    /// line's rule): a moving model's as given, checked against its range (ValueError); a
    /// static model's one time, once, with its note on the logger where other times were asked
    /// for. `what` says what is done at them.
    fn model_times(&self, times: &[f64], what: &str) -> PyResult<Vec<f64>> {
        let requested: Vec<f32> = times.iter().map(|&t| t as f32).collect();
        let (at, note) = self
            .file
            .times_for("time", &requested, what)
            .map_err(|e| PyValueError::new_err(format!("{e:#}")))?;
        if let Some(note) = note {
            log::info!("{note}");
        }
        // A moving model keeps the caller's f64 times (frame spacings are written from them).
        Ok(match self.file.is_static() {
            true => at.into_iter().map(f64::from).collect(),
            false => times.to_vec(),
        })
    }

    /// (N, K) from a point-major buffer, without copying.
    fn per_class<'py>(&self, py: Python<'py>, n: usize, v: Vec<f32>) -> Bound<'py, PyArray2<f32>> {
        Array2::from_shape_vec((n, self.model().num_classes()), v)
            .expect("N × K values")
            .into_pyarray(py)
    }
}

#[pymethods]
impl PyModel {
    /// Reads and validates a model file (.dsm).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<PyModel> {
        let source = path.display().to_string();
        let bytes = py
            .detach(|| ModelBytes::read(&path))
            .map_err(|e| DynasliceError::new_err(format!("cannot read model {source}: {e}")))?;
        PyModel::from_model_bytes(bytes, &source)
    }

    /// Validates a model file's bytes (e.g. read from a database or an archive).
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<PyModel> {
        PyModel::from_model_bytes(ModelBytes::copy_from(data), "model bytes")
    }

    /// The model file's bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, self.file.bytes().as_bytes())
    }

    /// K, the number of classes.
    #[getter]
    fn num_classes(&self) -> usize {
        self.model().num_classes()
    }

    /// [(name, source label value, recorded colour or None)] of classes 1..K, in channel
    /// order: the colours the training input gave the classes, as the file records them. A
    /// malformed record warns (UserWarning) and counts as none.
    #[getter]
    fn class_records(&self, py: Python<'_>) -> PyResult<Vec<ClassRecord>> {
        let model = &self.model();
        let recorded = match recorded_class_colors(model) {
            Ok(colors) => colors,
            Err(e) => {
                let message = format!("{e}; the classes take the palette's colours");
                PyErr::warn(
                    py,
                    &py.get_type::<PyUserWarning>(),
                    &CString::new(message)?,
                    1,
                )?;
                vec![None; model.num_classes()]
            }
        };
        Ok(model
            .classes()
            .zip(recorded)
            .map(|(c, color)| {
                (
                    c.name.to_string(),
                    c.label,
                    color.map(|[r, g, b]| (r, g, b)),
                )
            })
            .collect())
    }

    /// [(r, g, b)] of classes 1..K: the colour each is shown in, its recorded colour
    /// (`class_records`) or else the palette's for its channel, as in every output of the
    /// command line (mesh files, colour tables, segmentations, pictures).
    #[getter]
    fn class_colors(&self, py: Python<'_>) -> PyResult<Vec<Rgb>> {
        Ok(self
            .class_records(py)?
            .into_iter()
            .enumerate()
            .map(|(k, (_, _, color))| {
                let [r, g, b] = palette::class_color(k, color.map(|(r, g, b)| [r, g, b]));
                (r, g, b)
            })
            .collect())
    }

    /// ((xmin, ymin, zmin), (xmax, ymax, zmax)): the training domain's box, world units.
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        self.model().domain().bounds()
    }

    /// (t_min, t_max): the time range the model was trained on, world time units. A static
    /// model (`is_static`) has one time t and gives (t, t); it answers any time there.
    #[getter]
    fn time_range(&self) -> (f32, f32) {
        match self.static_time() {
            Some(t0) => (t0, t0),
            None => self.model().domain().time_range(),
        }
    }

    /// Whether the model is static: trained on one timestep, the same at every time (no time
    /// axis: queries, meshes and label volumes at any time are answered at its one time,
    /// with a note on the `_dynaslice.model` logger).
    #[getter]
    fn is_static(&self) -> bool {
        self.static_time().is_some()
    }

    /// The trainer's metadata (`key = value` lines).
    #[getter]
    fn metadata(&self) -> &str {
        self.model().metadata()
    }

    /// f at each point: (N, K) float32.
    fn sdf<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (n, a) = self.query(py, points, t, Query::Values)?;
        Ok(self.per_class(py, n, a.f))
    }

    /// ∇ₓf at each point: (N, K, 3) float32, world units.
    fn gradient<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let (n, a) = self.query(py, points, t, Query::Gradient)?;
        let k = self.model().num_classes();
        Ok(Array3::from_shape_vec((n, k, 3), a.grad.into_flattened())
            .expect("N × K × 3 values")
            .into_pyarray(py))
    }

    /// ∂f/∂t at each point: (N, K) float32, world units per time unit.
    fn dfdt<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (n, a) = self.query(py, points, t, Query::Jacobian)?;
        Ok(self.per_class(py, n, a.dfdt))
    }

    /// (f, ∇ₓf, ∂f/∂t) in one pass: (N, K), (N, K, 3), (N, K) float32.
    #[allow(clippy::type_complexity)]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray3<f32>>,
        Bound<'py, PyArray2<f32>>,
    )> {
        let (n, a) = self.query(py, points, t, Query::Jacobian)?;
        let k = self.model().num_classes();
        let grad = Array3::from_shape_vec((n, k, 3), a.grad.into_flattened())
            .expect("N × K × 3 values")
            .into_pyarray(py);
        Ok((
            self.per_class(py, n, a.f),
            grad,
            self.per_class(py, n, a.dfdt),
        ))
    }

    /// Eq. 11 labels: (N,) int32, the classes' source label values (0 background), or with
    /// `index=True` the class numbers 0..K. A ValueError names the first point where the
    /// model is not finite (NaN or infinite input).
    #[pyo3(signature = (points, t, index = false))]
    fn labels<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
        index: bool,
    ) -> PyResult<Bound<'py, PyArray1<i32>>> {
        let (_, a) = self.query(py, points, t, Query::Labels)?;
        if let Some(i) = batch::first_undefined(&a.labels) {
            return Err(PyValueError::new_err(format!(
                "no label at point {i}: the model is not finite there (NaN or infinite input)"
            )));
        }
        let values: Vec<i32> = if index {
            a.labels.into_iter().map(|l| l as i32).collect()
        } else {
            let table: Vec<i32> = std::iter::once(0)
                .chain(self.model().classes().map(|c| c.label))
                .collect();
            a.labels.into_iter().map(|l| table[l as usize]).collect()
        };
        Ok(Array1::from_vec(values).into_pyarray(py))
    }

    /// A motion model's displacement u at each point: (N, 3) float32, world units, the offset
    /// that carries the point at its time to its canonical (reference-shape) position (zero
    /// for a model without motion). Times as for `sdf`.
    fn displacement<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        t: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (n, a) = self.query(py, points, t, Query::Displacement)?;
        Ok(
            Array2::from_shape_vec((n, 3), a.displacement.into_flattened())
                .expect("N × 3 values")
                .into_pyarray(py),
        )
    }

    /// Surfaces at world time `t`: for each requested class (keys: numbers 1..K or names;
    /// empty: all), (positions (V, 3) float32, triangles (F, 3) int64, normals (V, 3) float32,
    /// normal velocity (V,) float32), as `dynaslice mesh` extracts them.
    #[pyo3(signature = (t, classes, resolution = dynaslice_mesh::lattice::DEFAULT_RESOLUTION, non_overlapping = false, newton_steps = mesh::DEFAULT_NEWTON_STEPS,
                        safety = mesh::DEFAULT_SAFETY, dense = false, threads = None))]
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        t: f32,
        classes: Vec<String>,
        resolution: u32,
        non_overlapping: bool,
        newton_steps: u32,
        safety: f32,
        dense: bool,
        threads: Option<usize>,
    ) -> PyResult<
        Vec<(
            usize,
            Bound<'py, PyArray2<f32>>,
            Bound<'py, PyArray2<i64>>,
            Bound<'py, PyArray2<f32>>,
            Bound<'py, PyArray1<f32>>,
        )>,
    > {
        let model = &self.model();
        let channels = resolve_classes(model, &classes).map_err(PyValueError::new_err)?;
        let t = self.model_times(&[f64::from(t)], "meshing")?[0] as f32;
        let options = Options::of(resolution, dense, safety, non_overlapping, newton_steps);
        let bounds = model.domain().bounds();
        let extraction = detach_result(py, || {
            pool(threads)?.install(|| mesh::extract(model, bounds, t, &channels, &options))
        })?;
        Ok(extraction
            .meshes
            .into_iter()
            .zip(channels)
            .map(|(m, k)| {
                let (v, f) = (m.positions.len(), m.triangles.len());
                let faces: Vec<i64> = m.triangles.into_iter().flatten().map(i64::from).collect();
                (
                    k + 1,
                    Array2::from_shape_vec((v, 3), m.positions.into_flattened())
                        .expect("V × 3")
                        .into_pyarray(py),
                    Array2::from_shape_vec((f, 3), faces)
                        .expect("F × 3")
                        .into_pyarray(py),
                    Array2::from_shape_vec((v, 3), m.normals.into_flattened())
                        .expect("V × 3")
                        .into_pyarray(py),
                    Array1::from_vec(m.normal_velocity).into_pyarray(py),
                )
            })
            .collect())
    }

    /// The Eq. 11 label volume (source label values, int32), x fastest then y, z, frame, on
    /// the grid of the NIfTI file `like` (its frames' times unless `times` is given), as
    /// `dynaslice labels --like` computes it. With `output` (.nii / .nii.gz) the volume is
    /// also written there, the file `dynaslice labels` writes. Returns (values, dims, frames).
    #[pyo3(signature = (like, times = None, output = None, threads = None))]
    fn label_volume_like<'py>(
        &self,
        py: Python<'py>,
        like: PathBuf,
        times: Option<Vec<f64>>,
        output: Option<PathBuf>,
        threads: Option<usize>,
    ) -> PyResult<(Bound<'py, PyArray1<i32>>, [usize; 3], usize)> {
        let grid = detach_result(py, || VoxelGrid::like_file(&like, times))?;
        self.volume(py, grid, output, threads)
    }

    /// As `label_volume_like`, on a grid given by its dimensions, affine rows (voxel index →
    /// world, 3 × 4, the NIfTI sform) and frame times.
    #[pyo3(signature = (dims, affine, times, output = None, threads = None))]
    fn label_volume_grid<'py>(
        &self,
        py: Python<'py>,
        dims: [usize; 3],
        affine: [[f64; 4]; 3],
        times: Vec<f64>,
        output: Option<PathBuf>,
        threads: Option<usize>,
    ) -> PyResult<(Bound<'py, PyArray1<i32>>, [usize; 3], usize)> {
        let grid = VoxelGrid {
            dims,
            affine,
            times,
        };
        self.volume(py, grid, output, threads)
    }

    fn __repr__(&self) -> String {
        let m = self.model();
        let names: Vec<&str> = m.classes().map(|c| c.name).collect();
        match self.static_time() {
            Some(t) => format!("<dynaslice.Model classes={names:?} static (time {t})>"),
            None => {
                let (t0, t1) = m.domain().time_range();
                format!("<dynaslice.Model classes={names:?} time_range=({t0}, {t1})>")
            }
        }
    }
}

/// The note that a static model did its work once, at its time `t0`, not at `asked`.
fn static_note(t0: f32, asked: &str, what: &str) {
    log::info!(
        "a static model (trained on one timestep, ω_t^max = 0) is the same at every time; \
         {what} at its time {t0}, not at {asked}"
    );
}

/// The error of a time outside the model's range: the words of `dynaslice` (the model
/// service's [`dynaslice_model::ModelFile::check_time`]), as a ValueError.
fn outside(model: &Model, t: f32, at: &str) -> PyErr {
    let (t0, t1) = model.domain().time_range();
    PyValueError::new_err(format!(
        "time {t}{at} is outside the model's time range [{t0}, {t1}]"
    ))
}

impl PyModel {
    fn volume<'py>(
        &self,
        py: Python<'py>,
        grid: VoxelGrid,
        output: Option<PathBuf>,
        threads: Option<usize>,
    ) -> PyResult<(Bound<'py, PyArray1<i32>>, [usize; 3], usize)> {
        let mut grid = grid;
        grid.times = self.model_times(&grid.times, "one frame")?;
        let model = &self.model();
        let frames = grid.times.len();
        let values = detach_result(py, || {
            anyhow::ensure!(frames > 0, "no frame times");
            let voxels = checked_voxels(&grid)?;
            pool(threads)?.install(|| match &output {
                Some(path) => write_and_read_back(model, &grid, path),
                None => labels_in_memory(model, &grid, voxels),
            })
        })?;
        Ok((Array1::from_vec(values).into_pyarray(py), grid.dims, frames))
    }
}

/// Voxels of all frames, refusing grids whose labels would not fit in memory.
fn checked_voxels(grid: &VoxelGrid) -> anyhow::Result<usize> {
    // 2^31 int32 labels (8 GiB): far beyond any scanner volume, and a bound on what one call
    // may allocate.
    const MAX_VOXELS: usize = 1 << 31;
    let total = grid
        .dims
        .iter()
        .chain(std::iter::once(&grid.times.len()))
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .filter(|&n| n <= MAX_VOXELS);
    total.ok_or_else(|| {
        anyhow::anyhow!(
            "a grid of {:?} voxels × {} frames is larger than the {MAX_VOXELS} labels one \
             call may hold",
            grid.dims,
            grid.times.len()
        )
    })
}

/// Every frame's source label values, computed as `dynaslice labels` does.
fn labels_in_memory(model: &Model, grid: &VoxelGrid, voxels: usize) -> anyhow::Result<Vec<i32>> {
    let values = source_labels(model)?;
    let per_frame = grid.voxels_per_frame();
    let mut indices = vec![0u32; per_frame];
    let mut out = Vec::with_capacity(voxels);
    for &t in &grid.times {
        label_indices(model, grid, t, &mut indices)?;
        out.extend(indices.iter().map(|&i| values[i as usize]));
    }
    Ok(out)
}

/// Writes the volume with `dynaslice labels`' writer, then returns the file's voxels, so the
/// array is exactly what the file holds.
fn write_and_read_back(model: &Model, grid: &VoxelGrid, path: &Path) -> anyhow::Result<Vec<i32>> {
    let name = path.to_string_lossy().to_ascii_lowercase();
    anyhow::ensure!(
        name.ends_with(".nii") || name.ends_with(".nii.gz"),
        "{}: the output must be a .nii or .nii.gz file",
        path.display()
    );
    write_model_labels(model, grid, path, |_| {})?;
    Ok(read_volume(path)?.labels)
}
