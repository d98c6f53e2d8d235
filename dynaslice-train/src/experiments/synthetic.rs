//! Table 3 on the synthetic benchmark: each shape sliced at every 4th of 37 frames, trained for
//! a fixed wall time per variant, then scored at all 37 frames by 3D IoU of the Eq. 11 labels
//! against the exact analytic shapes, split into annotated (trained) and unannotated frames.

use crate::data::Sequence;
use crate::metrics::iou::label_overlap;
use crate::synth::{slice_sequence, BenchmarkOptions, Shape};
use crate::train::data_sampler::{domain_for, temporal_bound, DataSampler, SampleCounts};
use crate::train::trainer::{train, Sampler, TrainOptions};
use anyhow::{anyhow, Result};
use dynaslice_core::Model;
use std::fmt::Write as _;
use std::ops::ControlFlow;
use std::time::Instant;

/// The ablations of Table 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// No temporal control, no orientation loss.
    Siren4d,
    /// Orientation loss, no temporal control.
    Orientation,
    /// Everything (DynaSlice).
    Full,
}

impl Variant {
    /// Every variant, in table order.
    pub const ALL: [Variant; 3] = [Variant::Siren4d, Variant::Orientation, Variant::Full];

    /// Row label.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Siren4d => "4D SIREN",
            Variant::Orientation => "+ orientation",
            Variant::Full => "DynaSlice (full)",
        }
    }

    fn orientation(self) -> bool {
        self != Variant::Siren4d
    }

    fn temporal_control(self) -> bool {
        self == Variant::Full
    }
}

/// One trained and scored (shape, variant).
#[derive(Clone, Debug)]
pub struct Run {
    /// The shape.
    pub shape: Shape,
    /// The ablation.
    pub variant: Variant,
    /// Optimisation steps completed.
    pub steps: u64,
    /// Training wall time.
    pub train_seconds: f64,
    /// Per frame (all 37): the mean IoU over the classes present.
    pub frame_iou: Vec<f64>,
    /// Per frame and class: the IoU (`None` where neither partition has the class).
    pub frame_class_iou: Vec<Vec<Option<f64>>>,
    /// The trained model file.
    pub model: Vec<u8>,
    /// Per class: the IoU averaged over all frames.
    pub class_iou: Vec<f64>,
    /// Which frames were annotated (trained on).
    pub annotated: Vec<bool>,
}

impl Run {
    fn mean(&self, keep: impl Fn(bool) -> bool) -> f64 {
        let v: Vec<f64> = self
            .frame_iou
            .iter()
            .zip(&self.annotated)
            .filter(|(_, &a)| keep(a))
            .map(|(v, _)| *v)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    }

    /// Mean IoU over all frames.
    pub fn mean_all(&self) -> f64 {
        self.mean(|_| true)
    }

    /// Mean IoU over annotated frames.
    pub fn mean_annotated(&self) -> f64 {
        self.mean(|a| a)
    }

    /// Mean IoU over unannotated frames.
    pub fn mean_unannotated(&self) -> f64 {
        self.mean(|a| !a)
    }
}

/// What every run shares.
#[derive(Clone, Debug)]
pub struct Protocol {
    /// Training wall time per run.
    pub minutes: f64,
    /// IoU grid resolution (cells per axis over [−1, 1]³).
    pub resolution: usize,
    /// Base training options (time limit and temporal settings are set per run).
    pub options: TrainOptions,
    /// Samples per step.
    pub counts: SampleCounts,
    /// c of ω_t^max = c·π/Δt.
    pub temporal_factor: f32,
}

/// Seconds per step of `options` on `sampler`'s data, from a short timed run (the first step,
/// which warms caches and allocators, is not counted).
fn seconds_per_step(options: &TrainOptions, k: usize, sampler: &mut dyn Sampler) -> Result<f64> {
    let mut probe = options.clone();
    probe.steps = 6;
    probe.time_limit = None;
    probe.checkpoint = None;
    let start = Instant::now();
    let mut first = None;
    train(&probe, k, sampler, |p| {
        if p.step == 1 {
            first = Some(start.elapsed());
        }
        ControlFlow::Continue(())
    })?;
    let warm = start.elapsed() - first.unwrap_or_default();
    Ok(warm.as_secs_f64() / 5.0)
}

/// One benchmark shape, sliced by the paper's protocol.
pub struct Scene {
    shape: Shape,
    bench: BenchmarkOptions,
    seq: Sequence,
}

impl Scene {
    /// Slices `shape` (every 4th of 37 frames).
    pub fn new(shape: Shape) -> Result<Scene> {
        let bench = BenchmarkOptions::default();
        let seq =
            slice_sequence(shape, &bench).map_err(|e| anyhow!("slicing {}: {e}", shape.name()))?;
        Ok(Scene { shape, bench, seq })
    }

    /// Options of `variant` for this scene.
    fn options(&self, variant: Variant, p: &Protocol) -> TrainOptions {
        let mut options = p.options.clone();
        if !variant.orientation() {
            options.loss.orientation = 0.0;
        }
        options.omega_t_max = temporal_bound(
            &self.seq,
            &domain_for(&self.seq),
            p.temporal_factor,
            variant.temporal_control(),
        );
        options
    }

    /// Steps that take `p.minutes` on this machine now. Every variant then trains for exactly
    /// these steps: equal compute (the variants cost the same per step), and a comparison that a
    /// busy machine cannot tilt.
    pub fn calibrate(&self, p: &Protocol) -> Result<u64> {
        let mut sampler = DataSampler::new(&self.seq, domain_for(&self.seq), p.counts);
        let per_step = seconds_per_step(
            &self.options(Variant::Full, p),
            self.seq.classes().len(),
            &mut sampler,
        )?;
        Ok(((p.minutes * 60.0 / per_step) as u64).max(1))
    }

    /// Trains `variant` for `steps` and scores it at every benchmark frame.
    pub fn run(
        &self,
        variant: Variant,
        p: &Protocol,
        steps: u64,
        log: &mut dyn FnMut(&str),
    ) -> Result<Run> {
        let (shape, bench, seq) = (self.shape, &self.bench, &self.seq);
        let k = seq.classes().len();
        let domain = domain_for(seq);
        let mut options = self.options(variant, p);
        options.steps = steps;
        options.time_limit = None;
        let mut sampler = DataSampler::new(seq, domain, p.counts);
        log(&format!(
            "{} / {}: {} steps",
            shape.name(),
            variant.name(),
            steps
        ));
        let outcome = train(&options, k, &mut sampler, |_| ControlFlow::Continue(()))?;
        let classes = seq
            .classes()
            .iter()
            .map(|c| (c.name.clone(), c.label))
            .collect();
        let bytes = outcome
            .network
            .to_writer(domain, classes, options.describe())
            .try_to_bytes()
            .map_err(|e| anyhow!("model: {e}"))?;
        let aligned = crate::model_file::AlignedBytes::copy_from(&bytes);
        let model = Model::from_bytes(&aligned).map_err(|e| anyhow!("model: {e}"))?;
        let truth = |c: usize, x: [f64; 3], t: f64| shape.sdf(c, x, t);
        let mut frame_iou = Vec::with_capacity(bench.timesteps);
        let mut frame_class_iou = Vec::with_capacity(bench.timesteps);
        let mut class_sum = vec![0.0; k];
        let mut class_count = vec![0usize; k];
        for i in 0..bench.timesteps {
            let overlap = label_overlap(
                &model,
                &truth,
                ([-1.0; 3], [1.0; 3]),
                p.resolution,
                bench.time(i),
            );
            let iou = overlap.iou();
            let present: Vec<f64> = iou.iter().flatten().copied().collect();
            frame_iou.push(present.iter().sum::<f64>() / present.len().max(1) as f64);
            frame_class_iou.push(iou.clone());
            for (c, v) in iou.iter().enumerate() {
                if let Some(v) = v {
                    class_sum[c] += v;
                    class_count[c] += 1;
                }
            }
        }
        let run = Run {
            shape,
            variant,
            steps: outcome.steps_done,
            train_seconds: outcome.elapsed.as_secs_f64(),
            frame_iou,
            frame_class_iou,
            model: bytes,
            class_iou: class_sum
                .iter()
                .zip(&class_count)
                .map(|(s, &n)| s / n.max(1) as f64)
                .collect(),
            annotated: (0..bench.timesteps)
                .map(|i| i % bench.train_every == 0)
                .collect(),
        };
        log(&format!(
            "{} / {}: IoU {:.4} (annotated {:.4}, unannotated {:.4}) after {} steps in {:.0} s",
            shape.name(),
            variant.name(),
            run.mean_all(),
            run.mean_annotated(),
            run.mean_unannotated(),
            run.steps,
            run.train_seconds
        ));
        Ok(run)
    }
}

/// The Table 3 markdown of `runs`, with the protocol and the command that made it.
pub fn markdown(runs: &[Run], p: &Protocol, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "## Table 3 layout: synthetic benchmark\n");
    let _ = writeln!(s, "Command: `{command}`\n");
    let _ = writeln!(
        s,
        "Protocol: each shape of `dynaslice synth` sliced at every 4th of 37 frames (15 + 15 planes, \
         35 + 35 for the thin tube); every variant trained for the same number of steps, \
         calibrated per shape to take {} min on {} threads of this machine \
         (network {:?}, {} contour + {} plane samples per class and {} space-time samples per step); \
         3D IoU of the Eq. 11 labels against the exact shapes on a {}³ grid over [−1, 1]³ at all 37 \
         frames, averaged over classes present, then over frames.\n",
        p.minutes, p.options.threads, p.options.widths, p.counts.contour_per_class, p.counts.plane_per_class,
        p.counts.space, p.resolution
    );
    let shapes: Vec<Shape> = Shape::ALL
        .iter()
        .copied()
        .filter(|s| runs.iter().any(|r| r.shape == *s))
        .collect();
    let _ = write!(s, "| variant |");
    for sh in &shapes {
        let _ = write!(s, " {} |", sh.name());
    }
    let _ = writeln!(
        s,
        " mean | unannotated frames (mean) | steps | train time |"
    );
    let _ = writeln!(s, "|---|{}---|---|---|---|", "---|".repeat(shapes.len()));
    for v in Variant::ALL {
        let rows: Vec<&Run> = runs.iter().filter(|r| r.variant == v).collect();
        if rows.is_empty() {
            continue;
        }
        let _ = write!(s, "| {} |", v.name());
        for sh in &shapes {
            match rows.iter().find(|r| r.shape == *sh) {
                Some(r) => {
                    let _ = write!(s, " {:.3} |", r.mean_all());
                }
                None => {
                    let _ = write!(s, " – |");
                }
            }
        }
        let n = rows.len() as f64;
        let mean = rows.iter().map(|r| r.mean_all()).sum::<f64>() / n;
        let unannotated = rows.iter().map(|r| r.mean_unannotated()).sum::<f64>() / n;
        let steps = rows.iter().map(|r| r.steps).sum::<u64>() as f64 / n;
        let secs = rows.iter().map(|r| r.train_seconds).sum::<f64>() / n;
        let _ = writeln!(
            s,
            " {mean:.3} | {unannotated:.3} | {steps:.0} | {secs:.0} s |"
        );
    }
    let _ = writeln!(s, "\nPer class (IoU averaged over the 37 frames):\n");
    for r in runs.iter().filter(|r| r.class_iou.len() > 1) {
        let classes: Vec<String> = r
            .shape
            .class_names()
            .iter()
            .zip(&r.class_iou)
            .map(|(n, v)| format!("{n} {v:.3}"))
            .collect();
        let _ = writeln!(
            s,
            "- {} / {}: {}",
            r.shape.name(),
            r.variant.name(),
            classes.join(", ")
        );
    }
    s
}
