//! Scores of a model against the synthetic benchmark's exact shapes at every frame: 3D IoU of
//! the Eq. 11 labels on a grid and the Chamfer distance of each class's surface (definitions in
//! docs/metrics.md), split into annotated and unannotated frames by [`FrameTable`].
//!
//! The exact surfaces do not depend on the model, so [`Truth`] samples them once per shape and
//! every model scored against that shape reuses the samples.

use super::chamfer::{self, truth_meshes};
use super::iou::label_overlap;
use super::FrameTable;
use anyhow::{bail, Result};
use dynaslice_core::Model;
use dynaslice_mesh::{self as mesh, Surfaces};
use dynaslice_synth::{BenchmarkOptions, Shape};
use std::fmt::Write as _;

/// The benchmark's reference box is the domain [−1, 1]³ at every frame: CD is normalised by its
/// diagonal 2√3, so values compare across frames and shapes.
const DIAGONAL: f64 = 2.0 * 1.732_050_807_568_877_2;

/// How finely to score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resolution {
    /// Cells per axis of the IoU grid over [−1, 1]³.
    pub iou: usize,
    /// Lattice cells along the longest axis for the model's meshes.
    pub mesh: u32,
    /// Lattice cells per axis for the exact shapes' meshes.
    pub truth: u32,
    /// Area-uniform samples per surface for the Chamfer distance.
    pub samples: usize,
}

impl Default for Resolution {
    fn default() -> Self {
        Resolution {
            iou: 64,
            mesh: 128,
            truth: 256,
            samples: chamfer::DEFAULT_SAMPLES,
        }
    }
}

impl Resolution {
    /// About how many bytes [`Truth`] holds for `frames` frames of `classes` classes: the
    /// exact surfaces' samples (3 f64 each) of every frame and class, held throughout, and one
    /// truth meshing lattice at a time (an f64 per vertex and class, and a hash-map entry).
    pub fn truth_bytes(&self, frames: usize, classes: usize) -> f64 {
        let classes = classes as f64;
        let samples = frames as f64 * classes * self.samples as f64 * 24.0;
        let lattice = (f64::from(self.truth) + 1.0).powi(3) * (8.0 * classes + 48.0);
        samples + lattice
    }
}

/// Area-uniform samples of the exact surfaces of one shape at every benchmark frame.
pub struct Truth {
    shape: Shape,
    times: Vec<f64>,
    annotated: Vec<bool>,
    /// `samples[frame][class]`.
    samples: Vec<Vec<Vec<[f64; 3]>>>,
    resolution: Resolution,
}

impl Truth {
    /// Meshes and samples `shape` at the benchmark's frames; `annotated` marks the frames
    /// models are trained on.
    pub fn new(shape: Shape, annotated: &[usize], resolution: Resolution) -> Result<Truth> {
        Truth::new_with(shape, annotated, resolution, |_| {})
    }

    /// [`Truth::new`], calling `progress` with the number of frames done after each (the
    /// meshing at the truth resolution is the slow part: minutes at 192³).
    pub fn new_with(
        shape: Shape,
        annotated: &[usize],
        resolution: Resolution,
        mut progress: impl FnMut(usize),
    ) -> Result<Truth> {
        anyhow::ensure!(
            resolution.iou >= 1 && resolution.samples >= 1,
            "the IoU grid needs at least 1 cell per axis and the Chamfer distance at least 1 \
             sample per surface (got {} and {})",
            resolution.iou,
            resolution.samples
        );
        let bench = BenchmarkOptions::default();
        let times: Vec<f64> = (0..bench.timesteps).map(|i| bench.time(i)).collect();
        let k = shape.class_names().len();
        let samples = times
            .iter()
            .enumerate()
            .map(|(f, &t)| {
                let meshes = truth_meshes(shape, t, resolution.truth)?;
                let samples = meshes
                    .iter()
                    .enumerate()
                    .map(|(c, m)| chamfer::samples(m, resolution.samples, seed(f, c, k, 1)))
                    .collect();
                progress(f + 1);
                Ok(samples)
            })
            .collect::<Result<_>>()?;
        Ok(Truth {
            shape,
            annotated: (0..times.len()).map(|i| annotated.contains(&i)).collect(),
            times,
            samples,
            resolution,
        })
    }

    /// The shape.
    pub fn shape(&self) -> Shape {
        self.shape
    }

    /// IoU and CD×10⁴ of `model` at every frame and class.
    pub fn score(&self, model: &Model) -> Result<Scores> {
        self.score_with(model, |_| {})
    }

    /// [`Truth::score`], calling `progress` with the number of frames scored after each.
    pub fn score_with(&self, model: &Model, mut progress: impl FnMut(usize)) -> Result<Scores> {
        let shape = self.shape;
        let k = shape.class_names().len();
        if model.num_classes() != k {
            bail!(
                "the model has {} classes, but {} has {k}",
                model.num_classes(),
                shape.name()
            );
        }
        let r = self.resolution;
        let truth = |c: usize, x: [f64; 3], t: f64| shape.sdf(c, x, t);
        let classes: Vec<usize> = (0..k).collect();
        let options = mesh::Options {
            resolution: r.mesh,
            surfaces: Surfaces::Partition,
            ..mesh::Options::default()
        };
        let (mut iou, mut cd) = (Vec::new(), Vec::new());
        for (f, &t) in self.times.iter().enumerate() {
            iou.push(label_overlap(model, &truth, ([-1.0; 3], [1.0; 3]), r.iou, t).iou());
            let x = mesh::extract(model, model.domain().bounds(), t as f32, &classes, &options)?;
            cd.push(
                classes
                    .iter()
                    .map(|&c| {
                        let p = chamfer::samples(&x.meshes[c], r.samples, seed(f, c, k, 0));
                        chamfer::chamfer(&p, &self.samples[f][c], DIAGONAL).map(|d| d.scaled())
                    })
                    .collect(),
            );
            progress(f + 1);
        }
        let table = |values| FrameTable {
            times: self.times.clone(),
            annotated: self.annotated.clone(),
            values,
        };
        Ok(Scores {
            iou: table(iou),
            cd: table(cd),
        })
    }
}

/// Sampling seed of frame `f`, class `c` of `k`, for the prediction (0) or the truth (1).
fn seed(f: usize, c: usize, k: usize, side: u64) -> u64 {
    2 * (f * k + c) as u64 + side
}

/// A model's scores at every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Scores {
    /// 3D IoU per frame and class.
    pub iou: FrameTable,
    /// CD×10⁴ per frame and class (`None` where the model has no surface of the class).
    pub cd: FrameTable,
}

impl Scores {
    /// One row per frame: frame, time, annotated, then IoU and CD×10⁴ of each class (named by
    /// `classes`; `n/a` where undefined).
    pub fn to_csv(&self, classes: &[&str]) -> String {
        let mut s = String::from("frame,time,annotated");
        for n in classes {
            let _ = write!(s, ",iou {n},cd1e4 {n}");
        }
        s.push('\n');
        let cell = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.6}"));
        for f in 0..self.iou.times.len() {
            let _ = write!(s, "{f},{},{}", self.iou.times[f], self.iou.annotated[f]);
            for c in 0..classes.len() {
                let _ = write!(
                    s,
                    ",{},{}",
                    cell(self.iou.values[f][c]),
                    cell(self.cd.values[f][c])
                );
            }
            s.push('\n');
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Frames;

    /// A model that is not a benchmark shape's is refused by class count, and the truth samples
    /// cover every frame and class.
    #[test]
    fn truth_samples_and_class_check() {
        let r = Resolution {
            iou: 8,
            mesh: 16,
            truth: 24,
            samples: 500,
        };
        let truth = Truth::new(Shape::Chambers, &[0, 4, 8], r).unwrap();
        assert_eq!(truth.samples.len(), 37);
        assert!(truth.samples.iter().all(|f| f.len() == 3));
        assert!(truth.samples[5].iter().all(|s| s.len() == 500));
        assert_eq!(truth.annotated.iter().filter(|&&a| a).count(), 3);
        let s = dynaslice_test_support::spheres::Sphere::new([0.0; 3], 0.5, 0.0);
        let bytes = dynaslice_test_support::spheres::model(&[s], &[("ball", 1)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let e = truth.score(&model).unwrap_err().to_string();
        assert!(e.contains("1 classes, but chambers has 3"), "{e}");
    }

    /// The chambers at frame 0, written as a model of three static spheres in world
    /// coordinates, score IoU ≈ 1 and CD near the sampling floor there; spheres of 0.7 times
    /// the radii score IoU ≈ 0.7³.
    #[test]
    fn sphere_models_against_the_chambers() {
        use dynaslice_test_support::spheres::chambers_model;
        let r = Resolution {
            iou: 48,
            mesh: 64,
            truth: 64,
            samples: 4000,
        };
        let truth = Truth::new(Shape::Chambers, &[0], r).unwrap();
        let exact = chambers_model(dynaslice_synth::shapes::chambers(0.0), 1.0);
        let scores = truth.score(&Model::from_bytes(&exact).unwrap()).unwrap();
        for c in 0..3 {
            let (iou, cd) = (
                scores.iou.values[0][c].unwrap(),
                scores.cd.values[0][c].unwrap(),
            );
            assert!(iou > 0.95, "class {c}: IoU {iou}");
            assert!(cd < 0.5, "class {c}: CD×10⁴ {cd}");
        }
        let small = chambers_model(dynaslice_synth::shapes::chambers(0.0), 0.7);
        let worse = truth.score(&Model::from_bytes(&small).unwrap()).unwrap();
        for c in 0..3 {
            let iou = worse.iou.values[0][c].unwrap();
            assert!((iou - 0.343).abs() < 0.05, "class {c}: IoU {iou}");
            assert!(worse.cd.values[0][c].unwrap() > 10.0 * scores.cd.values[0][c].unwrap());
        }
        assert!(worse.iou.mean(Frames::All).unwrap() < scores.iou.mean(Frames::All).unwrap());
    }
}
