//! Held-out slices, the paper's protocol for real data: withhold some planes and some frames
//! from the input, train on the rest, then score the model's Eq. 11 labels on the withheld
//! planes by 2D IoU against their annotations, in three categories:
//!
//! - spatial: annotated (seen) frames, withheld planes;
//! - temporal: withheld frames, planes at the seen positions;
//! - spatio-temporal: withheld frames, withheld planes.
//!
//! A plane is identified by its index within its frame, so "the same position" in another frame
//! is the plane with the same index, as in cine acquisitions and in every reader of this project
//! (each frame lists its planes in acquisition order).
//!
//! On a plane, both label maps are rasterised on its region of interest at pixel centres: the
//! ground truth by the inside test of the class's polygons (sign of the exact polygon distance,
//! [`dynaslice_geometry::PolygonSdf`], holes respected), the prediction by the model at the pixel's
//! world position and the frame's time. Classes a plane does not annotate are not scored there.
//! Intersections and unions are summed over all planes of a category, then divided per class.

use super::iou::Overlap;
use anyhow::{bail, ensure, Result};
use dynaslice_core::{Model, Scratch};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::{Plane, Sequence};
use dynaslice_geometry::PolygonSdf;
use rayon::prelude::*;

/// Default pixels along the longer side of a plane's region of interest.
pub const DEFAULT_PIXELS: usize = 256;

/// Which frames and planes are withheld from training.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Split {
    /// Withheld frame indices (of the full sequence), or none.
    pub frames: Option<FrameRange>,
    /// Withheld plane indices (within each frame), or none.
    pub planes: Option<FrameRange>,
}

/// What a plane is for under a [`Split`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// Training data.
    Seen,
    /// Seen frame, withheld plane.
    Spatial,
    /// Withheld frame, plane at a seen position.
    Temporal,
    /// Withheld frame and plane.
    SpatioTemporal,
}

fn selects(range: Option<FrameRange>, index: usize, count: usize) -> bool {
    range.is_some_and(|r| r.contains(index, count))
}

impl Split {
    /// The category of plane `plane` (of `planes`) in frame `frame` (of `frames`).
    pub fn category(&self, frame: usize, frames: usize, plane: usize, planes: usize) -> Category {
        match (
            selects(self.frames, frame, frames),
            selects(self.planes, plane, planes),
        ) {
            (false, false) => Category::Seen,
            (false, true) => Category::Spatial,
            (true, false) => Category::Temporal,
            (true, true) => Category::SpatioTemporal,
        }
    }

    /// The training input: `seq` without the withheld frames and planes. An error when nothing
    /// is left, or nothing is withheld.
    pub fn training(&self, seq: &Sequence) -> Result<Sequence> {
        let n = seq.frames().len();
        // A range past the input's end selects nothing: say so rather than withhold less than
        // asked (issue 37: `--holdout-frames 100:` on 20 frames matched nothing, silently).
        if let Some(r) = self.frames {
            ensure!(
                (0..n).any(|f| r.contains(f, n)),
                "the held-out frames {r} select none of the input's {n} frames (indices 0 to {})",
                n.saturating_sub(1)
            );
        }
        if let Some(r) = self.planes {
            let most = seq
                .frames()
                .iter()
                .map(|f| f.planes.len())
                .max()
                .unwrap_or(0);
            ensure!(
                seq.frames()
                    .iter()
                    .any(|f| (0..f.planes.len()).any(|p| r.contains(p, f.planes.len()))),
                "the held-out planes {r} select no plane of any frame (frames have at most {most} \
                 planes, indices from 0)"
            );
        }
        let (classes, frames) = seq.clone().into_parts();
        let mut withheld = 0;
        let kept: Vec<_> = frames
            .into_iter()
            .enumerate()
            .filter(|(f, _)| !selects(self.frames, *f, n))
            .map(|(_, mut frame)| {
                let count = frame.planes.len();
                frame.planes = std::mem::take(&mut frame.planes)
                    .into_iter()
                    .enumerate()
                    .filter(|(p, _)| !selects(self.planes, *p, count))
                    .map(|(_, plane)| plane)
                    .collect();
                withheld += count - frame.planes.len();
                frame
            })
            .filter(|frame| !frame.planes.is_empty())
            .collect();
        withheld += n - kept.len();
        ensure!(withheld > 0, "the split withholds nothing");
        ensure!(
            !kept.is_empty(),
            "the split withholds every plane of every frame"
        );
        Ok(Sequence::new(classes, kept)?)
    }
}

/// 2D IoU counts of the three held-out categories.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOut {
    /// Seen frames, withheld planes.
    pub spatial: Overlap,
    /// Withheld frames, seen positions.
    pub temporal: Overlap,
    /// Withheld frames and planes.
    pub spatio_temporal: Overlap,
    /// Planes scored per category, in the order above.
    pub planes: [usize; 3],
}

/// One held-out category's scores ([`HeldOut::rows`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The category: `spatial`, `temporal` or `spatio-temporal`.
    pub category: &'static str,
    /// Planes scored.
    pub planes: usize,
    /// The mean of the classes' IoUs that exist (`None`: none does).
    pub mean: Option<f64>,
    /// Each class's IoU (`None` where neither side has the class).
    pub iou: Vec<Option<f64>>,
}

impl HeldOut {
    /// The three categories' scores, in the order of the fields.
    pub fn rows(&self) -> [Row; 3] {
        let row = |category, o: &Overlap, planes| {
            let iou = o.iou();
            let present: Vec<f64> = iou.iter().flatten().copied().collect();
            let mean =
                (!present.is_empty()).then(|| present.iter().sum::<f64>() / present.len() as f64);
            Row {
                category,
                planes,
                mean,
                iou,
            }
        };
        [
            row("spatial", &self.spatial, self.planes[0]),
            row("temporal", &self.temporal, self.planes[1]),
            row("spatio-temporal", &self.spatio_temporal, self.planes[2]),
        ]
    }
}

/// Scores `model` on the planes of `seq` (the full input) that `split` withholds, rasterising
/// each plane's region of interest with `pixels` pixels along its longer side. The model's
/// classes must be the input's.
pub fn held_out(model: &Model, seq: &Sequence, split: &Split, pixels: usize) -> Result<HeldOut> {
    let k = seq.classes().len();
    if model.num_classes() != k {
        bail!(
            "the model has {} classes and the input {k}: it was not trained on this input",
            model.num_classes()
        );
    }
    let channels: Vec<usize> = (0..k).collect();
    score(model, seq, &channels, split, pixels)
}

/// [`held_out`] for a one-class model of class `class` of `seq` (an independent per-class
/// model, Table 2): its inside region (label 1) against that class's annotations.
pub fn held_out_class(
    model: &Model,
    seq: &Sequence,
    class: usize,
    split: &Split,
    pixels: usize,
) -> Result<HeldOut> {
    ensure!(
        model.num_classes() == 1,
        "a per-class model has one class, this one {}",
        model.num_classes()
    );
    ensure!(
        class < seq.classes().len(),
        "the input has no class {}",
        class + 1
    );
    score(model, seq, &[class], split, pixels)
}

/// Scores model channel i against class `channels[i]` of `seq`.
fn score(
    model: &Model,
    seq: &Sequence,
    channels: &[usize],
    split: &Split,
    pixels: usize,
) -> Result<HeldOut> {
    ensure!(
        pixels >= 2,
        "--pixels {pixels}: a plane needs at least 2 pixels along its longer side"
    );
    for (mine, &c) in model.classes().zip(channels) {
        let theirs = &seq.classes()[c];
        ensure!(
            mine.label == theirs.label,
            "class {} is label {} in the model but {} in the input",
            c + 1,
            mine.label,
            theirs.label
        );
    }
    let k = channels.len();
    let mut out = HeldOut {
        spatial: Overlap::zeros(k),
        temporal: Overlap::zeros(k),
        spatio_temporal: Overlap::zeros(k),
        planes: [0; 3],
    };
    let n = seq.frames().len();
    for (f, frame) in seq.frames().iter().enumerate() {
        for (p, plane) in frame.planes.iter().enumerate() {
            let (sum, i) = match split.category(f, n, p, frame.planes.len()) {
                Category::Seen => continue,
                Category::Spatial => (&mut out.spatial, 0),
                Category::Temporal => (&mut out.temporal, 1),
                Category::SpatioTemporal => (&mut out.spatio_temporal, 2),
            };
            *sum += plane_overlap(model, plane, frame.time, channels, pixels);
            out.planes[i] += 1;
        }
    }
    Ok(out)
}

/// 2D IoU counts of one plane at time `t`: model class i+1 against the annotations of class
/// `channels[i]` where the plane annotates it, at the centres of a pixel grid over the region
/// of interest.
pub fn plane_overlap(
    model: &Model,
    plane: &Plane,
    t: f64,
    channels: &[usize],
    pixels: usize,
) -> Overlap {
    let k = channels.len();
    let roi = plane.roi;
    let size = [roi.max[0] - roi.min[0], roi.max[1] - roi.min[1]];
    let pixel = size[0].max(size[1]) / pixels.max(1) as f64;
    let [nx, ny] = size.map(|s| ((s / pixel).round() as usize).max(1));
    let centre = |i: usize, j: usize| {
        [
            roi.min[0] + (i as f64 + 0.5) * size[0] / nx as f64,
            roi.min[1] + (j as f64 + 0.5) * size[1] / ny as f64,
        ]
    };
    // Per channel: None where the plane does not annotate its class, else the class's inside
    // test (an absent class, with no polygons, is outside everywhere).
    let truth: Vec<Option<Option<PolygonSdf>>> = channels
        .iter()
        .map(|&c| {
            plane
                .annotation(c)
                .map(|a| PolygonSdf::new(&a.polygons, Some((roi.min, roi.max))))
        })
        .collect();
    (0..ny)
        .into_par_iter()
        .map_init(Scratch::boxed, |scratch, j| {
            let points: Vec<[f32; 3]> = (0..nx)
                .map(|i| plane.to_world(centre(i, j)).map(|v| v as f32))
                .collect();
            let times = vec![t as f32; nx];
            let mut labels = vec![0u32; nx];
            model
                .label_batch(scratch, &points, &times, &mut labels)
                .expect("buffers are sized to the row");
            let mut o = Overlap::zeros(k);
            for (i, &predicted) in labels.iter().enumerate() {
                let p = centre(i, j);
                for (c, sdf) in truth.iter().enumerate() {
                    let Some(sdf) = sdf else { continue };
                    let (a, b) = (
                        predicted == c as u32 + 1,
                        sdf.as_ref().is_some_and(|s| s.distance(p) < 0.0),
                    );
                    o.intersection[c] += (a && b) as u64;
                    o.union[c] += (a || b) as u64;
                }
            }
            o
        })
        .reduce(|| Overlap::zeros(k), |a, b| a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each category's mean is over the classes that exist in it; none existing is no mean.
    #[test]
    fn rows_average_the_classes_present() {
        let overlap = |intersection: Vec<u64>, union: Vec<u64>| Overlap {
            intersection,
            union,
        };
        let scores = HeldOut {
            spatial: overlap(vec![1, 0], vec![2, 0]),
            temporal: overlap(vec![1, 3], vec![4, 4]),
            spatio_temporal: overlap(vec![0, 0], vec![0, 0]),
            planes: [3, 4, 0],
        };
        let rows = scores.rows();
        assert_eq!(rows[0].category, "spatial");
        assert_eq!((rows[0].planes, rows[0].mean), (3, Some(0.5)));
        assert_eq!(rows[0].iou, [Some(0.5), None]);
        assert_eq!(rows[1].mean, Some(0.5));
        assert_eq!((rows[2].category, rows[2].mean), ("spatio-temporal", None));
    }
    use dynaslice_data::{Annotation, ClassInfo, Frame, Rect};
    use dynaslice_test_support::spheres::{self, Sphere, SPHERES_DOMAIN};
    use std::f64::consts::{PI, TAU};

    /// z-planes through a growing sphere at several times, each annotated with the exact circle
    /// of radius `scale`·r(t) (polygon of 256 vertices).
    fn sequence(sphere: &Sphere, scale: f64) -> Sequence {
        let c = sphere.world_centre();
        let frames = (0..5)
            .map(|f| {
                let t = 0.5 * f as f64;
                let r = sphere.world_radius(t);
                let planes = (0..4)
                    .map(|p| {
                        let z = c[2] - 0.6 * r + 0.4 * r * p as f64;
                        let rc = scale * (r * r - (z - c[2]).powi(2)).sqrt();
                        Plane {
                            origin: [c[0], c[1], z],
                            u: [1.0, 0.0, 0.0],
                            v: [0.0, 1.0, 0.0],
                            roi: Rect {
                                min: [-15.0, -15.0],
                                max: [15.0, 15.0],
                            },
                            annotations: vec![Annotation {
                                class: 0,
                                polygons: vec![(0..256)
                                    .map(|i| {
                                        let a = TAU * i as f64 / 256.0;
                                        [rc * a.cos(), rc * a.sin()]
                                    })
                                    .collect()],
                            }],
                        }
                    })
                    .collect();
                Frame { time: t, planes }
            })
            .collect();
        let classes = vec![ClassInfo {
            name: "ball".into(),
            label: 1,
            color: None,
        }];
        Sequence::new(classes, frames).unwrap()
    }

    #[test]
    fn categories_and_the_training_input() {
        let s = Split {
            frames: Some("1::2".parse().unwrap()),
            planes: Some("0::3".parse().unwrap()),
        };
        assert_eq!(s.category(0, 5, 1, 4), Category::Seen);
        assert_eq!(s.category(0, 5, 3, 4), Category::Spatial);
        assert_eq!(s.category(3, 5, 1, 4), Category::Temporal);
        assert_eq!(s.category(1, 5, 0, 4), Category::SpatioTemporal);
        let sphere = Sphere::new([0.0; 3], 0.5, 0.1);
        let seq = sequence(&sphere, 1.0);
        let train = s.training(&seq).unwrap();
        assert_eq!(train.frames().len(), 3);
        assert!(train.frames().iter().all(|f| f.planes.len() == 2));
        let none = Split {
            frames: None,
            planes: None,
        };
        assert!(none
            .training(&seq)
            .unwrap_err()
            .to_string()
            .contains("withholds nothing"));
        // A range past the input's end is refused, not an empty selection (issue 37).
        let past = Split {
            frames: Some("100:".parse().unwrap()),
            planes: Some("0::3".parse().unwrap()),
        };
        let e = past.training(&seq).unwrap_err().to_string();
        assert!(e.contains("select none of the input's 5 frames"), "{e}");
    }

    /// The model is the sphere the annotations trace: IoU ≈ 1 in every category. Annotations
    /// shrunk by a factor s give IoU = s² (discs of radii s·ρ and ρ).
    #[test]
    fn exact_and_shrunken_annotations() {
        let sphere = Sphere::new([0.05, -0.1, 0.0], 0.5, 0.1);
        let bytes = spheres::model(&[sphere], &[("ball", 1)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let split = Split {
            frames: Some("1::2".parse().unwrap()),
            planes: Some("1::2".parse().unwrap()),
        };
        let exact = held_out(&model, &sequence(&sphere, 1.0), &split, 400).unwrap();
        assert_eq!(exact.planes, [6, 4, 4]);
        for o in [&exact.spatial, &exact.temporal, &exact.spatio_temporal] {
            let iou = o.iou()[0].unwrap();
            assert!(iou > 0.99, "{iou}");
        }
        let shrunk = held_out(&model, &sequence(&sphere, 0.8), &split, 400).unwrap();
        let iou = shrunk.temporal.iou()[0].unwrap();
        assert!((iou - 0.64).abs() < 0.01, "{iou}");
        // The pixel grid covers the ROI: 30 mm at 400 px.
        let seq = sequence(&sphere, 1.0);
        let plane = &seq.frames()[0].planes[1];
        let o = plane_overlap(&model, plane, 0.0, &[0], 400);
        let r = sphere.world_radius(0.0);
        let z = plane.origin[2] - sphere.world_centre()[2];
        let disc = PI * (r * r - z * z) / (30.0 / 400.0f64).powi(2);
        assert!(
            (o.union[0] as f64 - disc).abs() < 0.01 * disc,
            "{} vs {disc}",
            o.union[0]
        );
        assert_eq!(SPHERES_DOMAIN.scale[0], 20.0);
    }

    #[test]
    fn a_model_of_another_input_is_refused() {
        let sphere = Sphere::new([0.0; 3], 0.5, 0.0);
        let bytes = spheres::model(&[sphere, sphere], &[("a", 1), ("b", 2)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let split = Split {
            frames: Some("1".parse().unwrap()),
            planes: None,
        };
        let e = held_out(&model, &sequence(&sphere, 1.0), &split, 16).unwrap_err();
        assert!(e.to_string().contains("2 classes and the input 1"), "{e}");
    }
}
