//! Writing the synthetic benchmark: slices of the analytic shapes at the training timesteps
//! (native JSON) and the ground truth as a 4D NIfTI label volume of every timestep.
//!
//! Protocol (paper Sec. 4): 37 uniform timesteps in [0, 1], training on every 4th (10 frames),
//! evaluation at all 37. At each training timestep, planes rotated uniformly about the z axis
//! (through the domain centre) and parallel planes uniformly spaced along z: 15 + 15, or 35 + 35
//! for thin structures.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::shapes::Shape;
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::write_volume;
use dynaslice_data::LabelTable;
use dynaslice_geometry::marching_squares::contours;
use dynaslice_sequence::{
    native, Annotation, ClassInfo, DataError, Frame, Plane, Rect, Result, Sequence,
};

/// Benchmark parameters; [`Default`] is the paper's protocol.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchmarkOptions {
    /// Timesteps uniformly spaced over [0, 1] (paper: 37).
    pub timesteps: usize,
    /// Train on every `train_every`-th timestep, starting at 0 (paper: 4).
    pub train_every: usize,
    /// (rotated, parallel) planes per training timestep; `None`: 15 + 15, 35 + 35 for thin
    /// shapes.
    pub planes: Option<(usize, usize)>,
    /// Grid points per axis on which each plane samples the analytic SDF before contouring.
    pub plane_resolution: usize,
    /// Voxels per axis of the ground-truth volume.
    pub volume_resolution: usize,
}

/// Bytes per voxel and frame of the ground truth while it is written: the i32 labels of every
/// frame, held until written, and the writer's encoded copy.
pub const TRUTH_BYTES_PER_VOXEL_FRAME: f64 = 8.0;

impl BenchmarkOptions {
    /// About how many bytes writing one shape's ground truth holds
    /// ([`TRUTH_BYTES_PER_VOXEL_FRAME`] per voxel and timestep).
    pub fn truth_bytes(&self) -> f64 {
        (self.volume_resolution as f64).powi(3)
            * self.timesteps as f64
            * TRUTH_BYTES_PER_VOXEL_FRAME
    }
}

impl Default for BenchmarkOptions {
    fn default() -> Self {
        BenchmarkOptions {
            timesteps: 37,
            train_every: 4,
            planes: None,
            plane_resolution: 256,
            volume_resolution: 64,
        }
    }
}

impl BenchmarkOptions {
    /// Time of timestep `i`.
    pub fn time(&self, i: usize) -> f64 {
        i as f64 / (self.timesteps.max(2) - 1) as f64
    }

    fn planes_for(&self, shape: Shape) -> (usize, usize) {
        self.planes
            .unwrap_or(if shape.is_thin() { (35, 35) } else { (15, 15) })
    }
}

/// Half-width of the domain [−1, 1]³.
const HALF: f64 = 1.0;

/// The planes of one training timestep (without annotations).
fn protocol_planes(rotated: usize, parallel: usize, roi: Rect) -> Vec<Plane> {
    let rot = (0..rotated).map(|j| {
        let a = std::f64::consts::PI * j as f64 / rotated as f64;
        ([0.0; 3], [a.cos(), a.sin(), 0.0], [0.0, 0.0, 1.0])
    });
    let par = (0..parallel).map(|m| {
        let z = -HALF + 2.0 * HALF * (m as f64 + 0.5) / parallel as f64;
        ([0.0, 0.0, z], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    });
    rot.chain(par)
        .map(|(origin, u, v)| Plane {
            origin,
            u,
            v,
            roi,
            annotations: Vec::new(),
        })
        .collect()
}

/// The training slices of `shape`: contours of the exact SDF on each plane at each training
/// timestep (marching squares on a `plane_resolution`² sampling, linear sub-sample placement).
pub fn slice_sequence(shape: Shape, options: &BenchmarkOptions) -> Result<Sequence> {
    let n = options.plane_resolution.max(2);
    let h = 2.0 * HALF / (n - 1) as f64;
    // Marching squares may close a contour up to one grid step beyond the grid.
    let roi = Rect {
        min: [-HALF - h, -HALF - h],
        max: [HALF + h, HALF + h],
    };
    let (rotated, parallel) = options.planes_for(shape);
    let classes: Vec<ClassInfo> = shape
        .class_names()
        .iter()
        .enumerate()
        .map(|(k, name)| ClassInfo {
            name: name.to_string(),
            label: k as i32 + 1,
            color: None,
        })
        .collect();
    let frames = (0..options.timesteps)
        .step_by(options.train_every.max(1))
        .map(|i| {
            let t = options.time(i);
            let planes = protocol_planes(rotated, parallel, roi)
                .into_par_iter()
                .map(|mut plane| {
                    plane.annotations = (0..classes.len())
                        .map(|k| {
                            let field: Vec<f64> = (0..n * n)
                                .map(|g| {
                                    let p =
                                        [-HALF + (g % n) as f64 * h, -HALF + (g / n) as f64 * h];
                                    shape.sdf(k, plane.to_world(p), t)
                                })
                                .collect();
                            let polygons = contours(&field, n, n)
                                .into_iter()
                                .map(|poly| {
                                    poly.into_iter()
                                        .map(|q| [-HALF + q[0] * h, -HALF + q[1] * h])
                                        .collect()
                                })
                                .collect();
                            Annotation { class: k, polygons }
                        })
                        .collect();
                    plane
                })
                .collect();
            Frame { time: t, planes }
        })
        .collect();
    Sequence::new(classes, frames)
}

/// The ground truth of `shape` at every timestep as a label volume over [−1, 1]³: each voxel
/// centre gets the class with the most negative SDF (0 outside every class; the multi-class
/// shapes never overlap, so this is plain inside/outside per class).
pub fn label_volume(shape: Shape, options: &BenchmarkOptions) -> LabelVolume {
    let r = options.volume_resolution.max(1);
    let s = 2.0 * HALF / r as f64;
    let classes = shape.class_names().len();
    let voxels = r * r * r;
    let labels: Vec<i32> = (0..voxels * options.timesteps)
        .into_par_iter()
        .map(|n| {
            let (v, f) = (n % voxels, n / voxels);
            let x = [v % r, v / r % r, v / (r * r)].map(|i| -HALF + (i as f64 + 0.5) * s);
            let t = options.time(f);
            (0..classes)
                .map(|k| (shape.sdf(k, x, t), k))
                .filter(|(d, _)| *d < 0.0)
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map_or(0, |(_, k)| k as i32 + 1)
        })
        .collect();
    LabelVolume {
        dims: [r; 3],
        frames: options.timesteps,
        affine: [
            [s, 0.0, 0.0, -HALF + 0.5 * s],
            [0.0, s, 0.0, -HALF + 0.5 * s],
            [0.0, 0.0, s, -HALF + 0.5 * s],
        ],
        frame_interval: options.time(1),
        labels,
    }
}

/// Files written for one shape by [`write_benchmark`].
#[derive(Debug, Clone, PartialEq)]
pub struct BenchmarkFiles {
    /// The shape.
    pub shape: Shape,
    /// Training slices, native JSON (`<dir>/<shape>/slices.json`).
    pub slices: PathBuf,
    /// Ground-truth label volume, all timesteps (`<dir>/<shape>/truth.nii.gz`).
    pub truth: PathBuf,
    /// Label-name table for the volume (`<dir>/<shape>/labels.txt`).
    pub labels: PathBuf,
}

/// Writes the benchmark of each shape under `dir/<shape name>/`.
pub fn write_benchmark(
    dir: &Path,
    shapes: &[Shape],
    options: &BenchmarkOptions,
) -> Result<Vec<BenchmarkFiles>> {
    shapes
        .iter()
        .map(|&shape| {
            let sub = dir.join(shape.name());
            std::fs::create_dir_all(&sub).map_err(|e| DataError::new(e.into()).in_file(&sub))?;
            let files = BenchmarkFiles {
                shape,
                slices: sub.join("slices.json"),
                truth: sub.join("truth.nii.gz"),
                labels: sub.join("labels.txt"),
            };
            native::write(&slice_sequence(shape, options)?, &files.slices)?;
            write_volume(&label_volume(shape, options), &files.truth)?;
            let mut names = LabelTable::default();
            for (k, name) in shape.class_names().iter().enumerate() {
                names.insert(k as i32 + 1, *name);
            }
            std::fs::write(&files.labels, names.to_text())
                .map_err(|e| DataError::new(e.into()).in_file(&files.labels))?;
            Ok(files)
        })
        .collect()
}

/// Writes each shape's data set ([`write_benchmark`]) as `dir/<shape name>/` (`dir` created
/// where missing), each put in place whole: written into a temporary folder inside `dir` and
/// renamed into place once complete, so a failed run leaves no partial data set; an existing
/// data set is removed only then. `written` gets each data set's files at their final paths.
pub fn write_data_sets(
    dir: &Path,
    shapes: &[Shape],
    options: &BenchmarkOptions,
    mut written: impl FnMut(&[BenchmarkFiles]),
) -> anyhow::Result<()> {
    use anyhow::Context;
    if !dir.exists() {
        std::fs::create_dir(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    for &shape in shapes {
        // Deleted with its contents unless renamed away (any error, or a panic).
        let mut builder = tempfile::Builder::new();
        builder.prefix(".synth-");
        // Renamed into place as the data set's folder: the mode `mkdir` gives (0777 & ~umask),
        // not tempfile's private 0700.
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o777));
        let tmp = builder
            .tempdir_in(dir)
            .with_context(|| format!("cannot create a temporary folder in {}", dir.display()))?;
        let files = write_benchmark(tmp.path(), &[shape], options)?;
        let target = dir.join(shape.name());
        if target.exists() {
            std::fs::remove_dir_all(&target)
                .with_context(|| format!("cannot remove {}", target.display()))?;
        }
        std::fs::rename(tmp.path().join(shape.name()), &target)
            .with_context(|| format!("cannot rename the data set to {}", target.display()))?;
        let moved = |p: &Path| target.join(p.file_name().unwrap_or_default());
        let files: Vec<BenchmarkFiles> = files
            .iter()
            .map(|f| BenchmarkFiles {
                shape: f.shape,
                slices: moved(&f.slices),
                truth: moved(&f.truth),
                labels: moved(&f.labels),
            })
            .collect();
        written(&files);
    }
    Ok(())
}
