//! Timed training at equal wall time: the schedule planned to end when the budget is spent (the
//! trainer's `time_limit`, [`dynaslice_train::trainer::CALIBRATION_STEPS`]) against the former
//! behaviour, a cosine `cap` steps long cut off when the budget is spent. Both runs of a seed
//! start from the same initialisation and samples; scored at all 37 frames against the exact
//! shapes (3D IoU, Chamfer distance ×10⁴).

use super::synthetic::Scene;
use super::{cell, Protocol};
use anyhow::{anyhow, Result};
use dynaslice_data::synth::Shape;
use dynaslice_metrics::benchmark::{Resolution, Scores};
use dynaslice_metrics::Frames;
use dynaslice_train::data_sampler::{domain_for, DataSampler};
use dynaslice_train::model_file::TrainedModel;
use dynaslice_train::trainer::train;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// One timed run.
pub struct TimedRun {
    /// "planned" or "cut off".
    pub schedule: &'static str,
    /// Seed.
    pub seed: u64,
    /// Steps completed and the schedule's length.
    pub steps: (u64, u64),
    /// Training seconds.
    pub seconds: f64,
    /// Scores at every frame.
    pub scores: Scores,
}

/// Trains `shape` for `p.minutes` of wall time per run, both ways, for each seed.
pub fn compare(shape: Shape, p: &Protocol, seeds: u64, cap: u64) -> Result<Vec<TimedRun>> {
    let scene = Scene::new(shape, Resolution::default())?;
    let seq = scene.sequence();
    let budget = Duration::from_secs_f64(p.minutes * 60.0);
    let mut runs = Vec::new();
    for seed in 0..seeds {
        for planned in [true, false] {
            let mut o = p.options(seq, cap, true, true);
            o.seed = seed;
            if planned {
                o.steps = u64::MAX / 2;
                o.time_limit = Some(budget);
            }
            let domain = domain_for(seq);
            let mut sampler = DataSampler::new(seq, domain, p.counts);
            let start = Instant::now();
            let mut length = o.steps;
            let outcome = train(&o, seq.classes().len(), &mut sampler, |progress| {
                length = progress.steps;
                // The former behaviour: the `cap`-step cosine, stopped when the budget is spent.
                if !planned && start.elapsed() >= budget {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })?;
            let bytes = TrainedModel {
                outcome: &outcome,
                domain,
                classes: seq.classes(),
                options: &o,
                counts: p.counts,
                temporal_factor: p.temporal_factor,
                class_weights: None,
                input: "input = dynaslice-lab schedule",
            }
            .to_bytes()
            .map_err(|e| anyhow!("model: {e}"))?;
            let model = bytes.model().map_err(|e| anyhow!("model: {e}"))?;
            let run = TimedRun {
                schedule: if planned { "planned" } else { "cut off" },
                seed,
                steps: (outcome.steps_done, length),
                seconds: outcome.elapsed.as_secs_f64(),
                scores: scene.score(&model)?,
            };
            eprintln!("{}", row(shape, &run));
            runs.push(run);
        }
    }
    Ok(runs)
}

/// One markdown table row.
pub fn row(shape: Shape, r: &TimedRun) -> String {
    format!(
        "| {} | {} | {} | {} / {} | {:.0} | {} | {} |",
        shape.name(),
        r.schedule,
        r.seed,
        r.steps.0,
        r.steps.1,
        r.seconds,
        cell(r.scores.iou.mean(Frames::All), 4),
        cell(r.scores.cd.mean(Frames::All), 3)
    )
}
