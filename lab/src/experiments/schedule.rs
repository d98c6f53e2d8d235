//! Timed training at equal wall time: the schedule planned to end when the budget is spent (the
//! trainer's `time_limit`, `dynaslice_optim::schedule_plan::CALIBRATION_STEPS`) against the former
//! behaviour, a cosine `cap` steps long cut off when the budget is spent. Both runs of a seed
//! start from the same initialisation and samples; scored at all 37 frames against the exact
//! shapes (3D IoU, Chamfer distance ×10⁴).

use super::synthetic::Scene;
use super::{cell, fit, Protocol};
use anyhow::Result;
use dynaslice_metrics::benchmark::{Resolution, Scores};
use dynaslice_metrics::Frames;
use dynaslice_synth::Shape;
use dynaslice_train::fit::Observer;
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::trainer::Progress;
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
            let base = TrainSpec {
                seed: Some(seed),
                ..p.spec(cap, true, true)
            };
            // Planned: the trainer's own `--minutes` plan (re-planned as the run goes). Cut
            // off: the former behaviour, the `cap`-step cosine stopped when the budget is spent.
            let spec = if planned {
                TrainSpec {
                    steps: None,
                    minutes: Some(p.minutes),
                    ..base
                }
            } else {
                base
            };
            let mut watch = CutOff {
                start: Instant::now(),
                budget: (!planned).then_some(budget),
                length: 0,
            };
            let fitted = fit(seq, &spec, "dynaslice-lab schedule", &mut watch)?;
            let run = TimedRun {
                schedule: if planned { "planned" } else { "cut off" },
                seed,
                steps: (fitted.steps, watch.length),
                seconds: fitted.seconds,
                scores: scene.score(&fitted.model())?,
            };
            eprintln!("{}", row(shape, &run));
            runs.push(run);
        }
    }
    Ok(runs)
}

/// Stops a run when its budget is spent (none: never) and remembers the schedule's length.
struct CutOff {
    start: Instant,
    budget: Option<Duration>,
    length: u64,
}

impl Observer for CutOff {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        self.length = p.steps;
        match self.budget {
            Some(b) if self.start.elapsed() >= b => ControlFlow::Break(()),
            _ => ControlFlow::Continue(()),
        }
    }
    fn note(&mut self, _: &str) {}
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
