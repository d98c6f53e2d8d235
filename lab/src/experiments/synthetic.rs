//! Table 3 on the synthetic benchmark: each shape sliced at every 4th of 37 frames, every
//! variant trained for the same steps, then scored at all 37 frames by 3D IoU of the Eq. 11
//! labels and by Chamfer distance against the exact analytic shapes
//! ([`dynaslice_metrics::benchmark`]), split into annotated (trained) and unannotated frames.

use super::{cell, fit, Fitted, Protocol};
use anyhow::{anyhow, Result};
use dynaslice_data::Sequence;
use dynaslice_metrics::benchmark::{Resolution, Scores, Truth};
use dynaslice_metrics::Frames;
use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};
use dynaslice_train::fit::Quiet;
use dynaslice_train::spec::TrainSpec;
use std::fmt::Write as _;

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

    /// Short name for files and the command line.
    pub fn key(self) -> &'static str {
        match self {
            Variant::Siren4d => "siren",
            Variant::Orientation => "orientation",
            Variant::Full => "full",
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
pub struct Run {
    /// The shape.
    pub shape: Shape,
    /// The ablation.
    pub variant: Variant,
    /// Seed of initialisation and sampling.
    pub seed: u64,
    /// The trained model.
    pub fitted: Fitted,
    /// Its scores at every frame.
    pub scores: Scores,
}

/// One benchmark shape, sliced by the paper's protocol, with its exact surfaces sampled.
pub struct Scene {
    shape: Shape,
    seq: Sequence,
    truth: Truth,
}

impl Scene {
    /// Slices `shape` (every 4th of 37 frames) and samples its exact surfaces.
    pub fn new(shape: Shape, resolution: Resolution) -> Result<Scene> {
        let bench = BenchmarkOptions::default();
        let seq =
            slice_sequence(shape, &bench).map_err(|e| anyhow!("slicing {}: {e}", shape.name()))?;
        let annotated: Vec<usize> = (0..bench.timesteps).step_by(bench.train_every).collect();
        let truth = Truth::new(shape, &annotated, resolution)?;
        Ok(Scene { shape, seq, truth })
    }

    /// The annotated cross-sections the models of this scene train on.
    pub fn sequence(&self) -> &Sequence {
        &self.seq
    }

    /// `model`'s scores against the exact shapes at every benchmark frame.
    pub fn score(&self, model: &dynaslice_core::Model) -> Result<Scores> {
        self.truth.score(model)
    }

    /// Steps that take `p.minutes` for the full method on this scene (every variant costs the
    /// same per step).
    pub fn calibrate(&self, p: &Protocol) -> Result<u64> {
        p.steps_for(&self.seq)
    }

    /// Trains `variant` for `steps` from `seed` and scores it at every benchmark frame.
    pub fn run(&self, variant: Variant, seed: u64, p: &Protocol, steps: u64) -> Result<Run> {
        let spec = TrainSpec {
            seed: Some(seed),
            ..p.spec(steps, variant.temporal_control(), variant.orientation())
        };
        let input = format!(
            "dynaslice synth --shape {}, its annotated frames",
            self.shape.name()
        );
        let fitted = fit(&self.seq, &spec, &input, &mut Quiet)?;
        let scores = self.truth.score(&fitted.model())?;
        Ok(Run {
            shape: self.shape,
            variant,
            seed,
            fitted,
            scores,
        })
    }
}

impl Run {
    /// A log line of the run's means.
    pub fn summary(&self) -> String {
        let (iou, cd) = (&self.scores.iou, &self.scores.cd);
        format!(
            "{} / {} / seed {}: IoU {} (annotated {}, unannotated {}), CD×10⁴ {} after {} steps in {:.0} s",
            self.shape.name(),
            self.variant.name(),
            self.seed,
            cell(iou.mean(Frames::All), 4),
            cell(iou.mean(Frames::Annotated), 4),
            cell(iou.mean(Frames::Unannotated), 4),
            cell(cd.mean(Frames::All), 3),
            self.fitted.steps,
            self.fitted.seconds
        )
    }
}

/// The Table 3 markdown of `runs` (any subset of shapes, variants and seeds; every figure of a
/// (shape, variant) is the mean over its seeds).
pub fn markdown(runs: &[Run], p: &Protocol, resolution: Resolution) -> String {
    let mut s = String::new();
    let (o, counts) = (p.options(), p.spec.counts());
    let mut seeds: Vec<u64> = runs.iter().map(|r| r.seed).collect();
    seeds.sort_unstable();
    seeds.dedup();
    let _ = writeln!(s, "## Table 3 layout: synthetic benchmark\n");
    let _ = writeln!(
        s,
        "Each shape of `dynaslice synth` sliced at every 4th of 37 frames (15 + 15 planes, \
         35 + 35 for the thin tube); every variant trained for the same number of steps, \
         {} per shape, on {} threads (network {:?}, {} contour + {} plane \
         samples per class and {} space-time samples per step; ω_t^max = {}·π/Δt with temporal \
         control). Scores at all 37 frames: 3D IoU \
         of the Eq. 11 labels against the exact shapes on a {}³ grid over [−1, 1]³, and CD×10⁴ \
         (docs/metrics.md) between {} area-uniform samples of the model's mesh ({} cells per \
         axis) and of the exact surface ({} cells), normalised by the domain diagonal; both \
         averaged over classes, then frames, then the {} seed(s) {:?} of initialisation and \
         sampling (ω₀ = {}, initial offset {}; λ_n = {} where the variant has orientation, \
         λ_d = {}, λ_r = {}, α = {}).\n",
        p.budget(),
        o.threads,
        o.widths,
        counts.contour_per_class,
        counts.plane_per_class,
        counts.space,
        p.spec.temporal_factor(),
        resolution.iou,
        resolution.samples,
        resolution.mesh,
        resolution.truth,
        seeds.len(),
        seeds,
        o.omega_0,
        o.offset,
        o.loss.orientation,
        o.loss.plane,
        o.loss.regulariser,
        o.loss.alpha,
    );
    let shapes: Vec<Shape> = Shape::ALL
        .iter()
        .copied()
        .filter(|s| runs.iter().any(|r| r.shape == *s))
        .collect();
    let mean = |rows: &[&Run], score: &dyn Fn(&Run) -> Option<f64>| {
        let v: Vec<f64> = rows.iter().filter_map(|r| score(r)).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    for (title, digits, table) in [
        ("3D IoU (higher is better), all 37 frames", 3, 0),
        ("CD×10⁴ (lower is better), all 37 frames", 2, 1),
    ] {
        let pick = |r: &Run, frames: Frames| match table {
            0 => r.scores.iou.mean(frames),
            _ => r.scores.cd.mean(frames),
        };
        let _ = writeln!(s, "{title}:\n");
        let _ = write!(s, "| variant |");
        for sh in &shapes {
            let _ = write!(s, " {} |", sh.name());
        }
        let _ = writeln!(s, " mean | annotated | unannotated | train time |");
        let _ = writeln!(s, "|---|{}---|---|---|---|", "---|".repeat(shapes.len()));
        for v in Variant::ALL {
            let rows: Vec<&Run> = runs.iter().filter(|r| r.variant == v).collect();
            if rows.is_empty() {
                continue;
            }
            let _ = write!(s, "| {} |", v.name());
            for sh in &shapes {
                let of_shape: Vec<&Run> = rows.iter().copied().filter(|r| r.shape == *sh).collect();
                let _ = write!(
                    s,
                    " {} |",
                    cell(mean(&of_shape, &|r| pick(r, Frames::All)), digits)
                );
            }
            let secs = rows.iter().map(|r| r.fitted.seconds).sum::<f64>() / rows.len() as f64;
            let _ = writeln!(
                s,
                " {} | {} | {} | {secs:.0} s |",
                cell(mean(&rows, &|r| pick(r, Frames::All)), digits),
                cell(mean(&rows, &|r| pick(r, Frames::Annotated)), digits),
                cell(mean(&rows, &|r| pick(r, Frames::Unannotated)), digits),
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "Steps per shape: {}.\n",
        shapes
            .iter()
            .filter_map(|sh| runs.iter().find(|r| r.shape == *sh))
            .map(|r| format!("{} {}", r.shape.name(), r.fitted.steps))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let groups: Vec<(Shape, Variant, Vec<&Run>)> = shapes
        .iter()
        .flat_map(|&sh| Variant::ALL.map(|v| (sh, v)))
        .map(|(sh, v)| {
            let of: Vec<&Run> = runs
                .iter()
                .filter(|r| r.shape == sh && r.variant == v)
                .collect();
            (sh, v, of)
        })
        .filter(|(_, _, of)| !of.is_empty())
        .collect();
    if seeds.len() > 1 {
        let _ = writeln!(s, "Per seed (3D IoU, all frames; seeds {seeds:?}):\n");
        for (sh, v, of) in &groups {
            let ious: Vec<String> = of
                .iter()
                .map(|r| cell(r.scores.iou.mean(Frames::All), 3))
                .collect();
            let _ = writeln!(s, "- {} / {}: {}", sh.name(), v.name(), ious.join(", "));
        }
        let _ = writeln!(s);
    }
    if groups.iter().any(|(sh, _, _)| sh.class_names().len() > 1) {
        let _ = writeln!(s, "Per class (IoU / CD×10⁴ over the 37 frames):\n");
        for (sh, v, of) in groups
            .iter()
            .filter(|(sh, _, _)| sh.class_names().len() > 1)
        {
            let classes: Vec<String> = sh
                .class_names()
                .iter()
                .enumerate()
                .map(|(c, n)| {
                    format!(
                        "{n} {} / {}",
                        cell(mean(of, &|r| r.scores.iou.class_mean(c, Frames::All)), 3),
                        cell(mean(of, &|r| r.scores.cd.class_mean(c, Frames::All)), 2)
                    )
                })
                .collect();
            let _ = writeln!(s, "- {} / {}: {}", sh.name(), v.name(), classes.join(", "));
        }
        let _ = writeln!(s);
    }
    s
}
