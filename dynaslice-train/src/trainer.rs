//! The optimisation loop: sample, loss and exact gradient, Adam, clamp ω_t, log, checkpoint.
//!
//! Determinism: the samples of step s depend only on (seed, s) (see [`Sampler`]), the gradient
//! only on the thread count (see [`super::objective`]), so a run resumed from a checkpoint ends
//! with the same model, bit for bit, as an uninterrupted one with the same seed and threads.

use super::loss::{LossTerms, LossWeights};
use super::network::Network;
use super::objective::{Batch, Objective};
use super::sampling::Sampler;
use super::spatial_bound::PlaneBand;
use super::warp::MotionOptions;
use anyhow::{Context, Result};
use dynaslice_core::Layout;
use dynaslice_optim::adam::{Adam, AdamConfig};
use dynaslice_optim::checkpoint::Checkpoint;
use dynaslice_optim::schedule_plan::{SchedulePlan, CALIBRATION_STEPS};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Options of one training run (recorded in the model's metadata).
#[derive(Clone, Debug, PartialEq)]
pub struct TrainOptions {
    /// Widths of the sine layers.
    pub widths: Vec<u32>,
    /// Steps of the full schedule; the run stops here at the latest (with a `time_limit`, the
    /// most the plan may choose).
    pub steps: u64,
    /// Wall-clock budget. The run is planned to fit it: the step time is measured over the first
    /// [`CALIBRATION_STEPS`] and the learning-rate schedule set to end, at `lr_final`, when the
    /// budget is spent (at most `steps`; [`Outcome::planned_steps`]). The step time is then
    /// measured again at every step (the median of the last [`REPLAN_WINDOW`]) and the rest of
    /// the schedule re-planned when it moves, so the run ends annealed within the last few
    /// percent of the budget however the machine's speed changes ([`SchedulePlan`]). The run
    /// also stops when the budget is spent, whatever the plan. A run resumed from a checkpoint
    /// keeps the checkpoint's plan.
    pub time_limit: Option<Duration>,
    /// SIREN's ω₀: the first layer's spatial frequency scale over the normalised cube.
    pub omega_0: f32,
    /// Initial value of every channel, normalised units (see [`Network::siren`]).
    pub offset: f32,
    /// Seed of initialisation and sampling.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Initial learning rate.
    pub lr: f32,
    /// Final learning rate of the cosine schedule.
    pub lr_final: f32,
    /// Steps over which the learning rate ramps up linearly before following the cosine
    /// (0: none). At ω₀ = 30 the first steps' full-size updates can flip large regions of a
    /// channel inside; a short ramp prevents that (lab/notes/training.md, "Learning-rate warm-up").
    pub warmup_steps: u64,
    /// Loss weights.
    pub loss: LossWeights,
    /// ω_t^max in normalised time (Eq. 4); `f32::INFINITY` turns temporal control off.
    pub omega_t_max: f32,
    /// The bound on ω_x across the data's parallel planes, where they are
    /// ([`crate::spatial_bound`]).
    pub plane_band: Option<PlaneBand>,
    /// The motion network of a motion model ([`crate::warp`]); `None` trains the shape network
    /// alone, as for a static input.
    pub motion: Option<MotionOptions>,
    /// Where to keep the checkpoint (none: no checkpoints).
    pub checkpoint: Option<PathBuf>,
    /// Wall time between checkpoints.
    pub checkpoint_every: Duration,
    /// Continue from the checkpoint if it exists.
    pub resume: bool,
}

/// What the loop reports after each step.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Steps completed.
    pub step: u64,
    /// Steps of the schedule.
    pub steps: u64,
    /// Loss terms of this step.
    pub terms: LossTerms,
    /// Weighted total.
    pub loss: f64,
    /// Learning rate used.
    pub lr: f32,
    /// Seconds since this process started training.
    pub elapsed: f64,
}

impl Progress {
    /// The step's figures by name (besides `step` and `steps`): what Python's progress callback
    /// gets.
    pub fn figures(&self) -> [(&'static str, f64); 11] {
        let mut out = [("", 0.0); 11];
        out[..3].copy_from_slice(&[
            ("loss", self.loss),
            ("lr", self.lr.into()),
            ("elapsed", self.elapsed),
        ]);
        out[3..].copy_from_slice(&self.terms.named());
        out
    }
}

impl std::fmt::Display for Progress {
    /// The step's losses for the user: `loss 2.4e-1 (surface …, between …) lr 1.0e-4`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "loss {:.4e} (", self.loss)?;
        for (i, (name, value)) in self.terms.named().iter().enumerate() {
            let comma = if i > 0 { ", " } else { "" };
            write!(f, "{comma}{name} {value:.3e}")?;
        }
        write!(f, ") lr {:.2e}", self.lr)
    }
}

/// Share of the time budget a plan fills: the rest absorbs step-time noise and the final
/// checkpoint, so the schedule ends before the hard stop. Re-planning keeps the plan true as
/// the run goes, so little margin is needed.
const PLAN_SHARE: f64 = 0.985;

/// Steps whose median time a re-plan uses: long enough to ignore a stray slow step, short
/// enough to follow a machine that slows down within seconds.
pub const REPLAN_WINDOW: usize = 16;

/// A re-plan changes the schedule only when the new length differs from the current one by
/// more than this share of the steps left (or 2 steps), so step-time noise does not move it.
const REPLAN_TOLERANCE: f64 = 0.02;

/// The trained network and how its last step ended.
pub struct Outcome {
    /// The network.
    pub network: Network,
    /// Steps completed (may be fewer than `steps` when the time limit hit).
    pub steps_done: u64,
    /// (step, loss terms, total) of the last step run by this process, none where it ran none.
    /// Every step's are `on_step`'s, for the caller to keep (the run's journal keeps them):
    /// held here too, they were a second copy of up to `MAX_STEPS` rows.
    pub last: Option<(u64, LossTerms, f64)>,
    /// Wall time of this process's training.
    pub elapsed: Duration,
    /// Length of the learning-rate schedule a timed run planned last (recorded in its
    /// checkpoint and reused on resume); `None` when the schedule was `steps` (no time limit,
    /// or the budget ran out before the plan).
    pub planned_steps: Option<u64>,
    /// The median wall time of this process's steps after its first (`None` with fewer than
    /// two): what a plan is made from.
    pub median_step_seconds: Option<f64>,
}

/// Learning rate at `step` (0-based) of a schedule `o.steps` long ([`schedule_rate`]).
pub fn learning_rate(o: &TrainOptions, step: u64) -> f32 {
    schedule_rate(o, &SchedulePlan::plain(o.steps), step)
}

/// Learning rate at `step` (0-based) of `plan`: `lr` for the first [`CALIBRATION_STEPS`],
/// then a cosine to `lr_final` at the plan's end ([`SchedulePlan::phase`]); scaled by
/// (step + 1) / `warmup_steps` during the warm-up.
pub fn schedule_rate(o: &TrainOptions, plan: &SchedulePlan, step: u64) -> f32 {
    let c = 0.5 * (1.0 + (std::f64::consts::PI * plan.phase(step)).cos());
    let warmup = if step < o.warmup_steps {
        (step + 1) as f64 / o.warmup_steps as f64
    } else {
        1.0
    };
    (warmup * (o.lr_final as f64 + (o.lr - o.lr_final) as f64 * c)) as f32
}

/// The schedule length that ends a run, now at `step` after `elapsed`, when `limit` is spent
/// (a share [`PLAN_SHARE`] of it), at `per_step` seconds a step; between `step` and `cap`.
fn plan_length(step: u64, cap: u64, elapsed: Duration, limit: Duration, per_step: f64) -> u64 {
    let left = (limit.as_secs_f64() * PLAN_SHARE - elapsed.as_secs_f64()).max(0.0);
    let more = if per_step > 0.0 {
        (left / per_step).floor().min(u64::MAX as f64 / 2.0) as u64
    } else {
        cap
    };
    step.saturating_add(more).clamp(step, cap.max(step))
}

/// FNV-1a over the options and the data digest: what a checkpoint must match.
fn fingerprint(o: &TrainOptions, num_classes: usize, data: u64) -> u64 {
    let text = format!(
        "{:?}|{:?}|{}|{}|{}|{}|{}|{}|{}|{}|{num_classes}|{data}",
        o.widths,
        o.loss,
        o.omega_0,
        o.offset,
        o.seed,
        o.threads,
        o.lr,
        o.lr_final,
        o.warmup_steps,
        o.omega_t_max
    );
    // Appended only where it binds, so a run without parallel planes keeps its fingerprint.
    let text = match &o.plane_band {
        Some(band) => format!("{text}|{band:?}"),
        None => text,
    };
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// Mixed into the seed of the motion network's initialisation.
const MOTION_SEED: u64 = 0x6d6f_7469_6f6e;

/// Trains a network with K = `num_classes` channels on `sampler`'s data. `on_step` sees every
/// step and may stop the run early (e.g. on Ctrl-C); the state is checkpointed either way.
pub fn train(
    o: &TrainOptions,
    num_classes: usize,
    sampler: &mut dyn Sampler,
    mut on_step: impl FnMut(&Progress) -> ControlFlow<()>,
) -> Result<Outcome> {
    let layout =
        Layout::new(&o.widths, num_classes as u32).map_err(|e| anyhow::anyhow!("network: {e}"))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(o.threads.max(1))
        .build()
        .context("thread pool")?;
    let motion = o.motion.as_ref().map(|m| {
        // Its own seed stream, so adding motion leaves the shape network's start unchanged.
        Network::motion_siren(&m.widths, m.omega_0, m.omega_t_max, o.seed ^ MOTION_SEED)
    });
    let mut net = Network::siren(layout, o.omega_0, o.offset, o.omega_t_max, o.seed)
        .with_plane_band(o.plane_band)
        .with_motion(motion);
    // Adam and the checkpoint hold every trained parameter: the shape network's, then the
    // motion network's (`Network::all_params`).
    let mut params = net.all_params();
    let mut adam = Adam::new(params.len(), AdamConfig::default());
    let print = fingerprint(o, num_classes, sampler.fingerprint());
    let mut step = 0;
    let mut plan: Option<SchedulePlan> = None;
    if let (true, Some(path)) = (o.resume, &o.checkpoint) {
        if path.exists() {
            let c = Checkpoint::load(path, print, params.len(), &adam)?;
            params = c.params;
            net.set_all_params(&params);
            adam = c.adam;
            step = c.step;
            plan = c.plan;
        }
    }
    // A resumed run follows the schedule its checkpoint recorded, so that it ends where the
    // interrupted run would have (its own budget counts only its own steps).
    let replan = o.time_limit.filter(|_| plan.is_none());
    let mut objective = Objective::new(&net, o.threads.max(1), sampler.max_set_len());
    let mut batch = Batch::default();
    let mut grad = vec![0.0; params.len()];
    let mut last = None;
    // The last steps' wall times, the process's first step left out (threads, caches).
    let mut recent = StepTimes::default();
    let start = Instant::now();
    let mut last_checkpoint = start;
    let save = |params: &[f32], adam: &Adam, step: u64, plan| -> Result<()> {
        match &o.checkpoint {
            Some(path) => Checkpoint {
                fingerprint: print,
                step,
                params: params.to_vec(),
                adam: adam.clone(),
                plan,
            }
            .save(path),
            None => Ok(()),
        }
    };
    let mut first_of_process = true;
    loop {
        let current = plan.unwrap_or_else(|| SchedulePlan::plain(o.steps));
        if step >= current.length || o.time_limit.is_some_and(|limit| start.elapsed() >= limit) {
            break;
        }
        let began = Instant::now();
        sampler.sample(o.seed, step, &mut batch);
        let terms = pool.install(|| objective.evaluate(&net, &batch, &o.loss, &mut grad));
        let lr = schedule_rate(o, &current, step);
        adam.step(&mut params, &grad, lr);
        net.set_all_params(&params);
        net.project_band_limits();
        // The projection moved some parameters: Adam's next step starts from where it put them.
        net.all_params_into(&mut params);
        step += 1;
        let seconds = began.elapsed().as_secs_f64();
        recent.push(seconds, first_of_process);
        first_of_process = false;
        // Planned as soon as the calibration steps are done and re-planned after every later
        // step, before this step's checkpoint or an early stop, so every checkpoint after them
        // holds the plan its steps followed.
        if let Some(limit) = replan {
            if step >= CALIBRATION_STEPS.min(o.steps) {
                let per_step = recent.median().unwrap_or(seconds);
                let length = plan_length(step, o.steps, start.elapsed(), limit, per_step);
                plan = Some(match plan {
                    None => SchedulePlan::plain(length),
                    Some(p) if moved(p.length, length, step) => p.replanned(step, length),
                    Some(p) => p,
                });
            }
        }
        let loss = terms.total(&o.loss);
        last = Some((step, terms, loss));
        let flow = on_step(&Progress {
            step,
            steps: current.length,
            terms,
            loss,
            lr,
            elapsed: start.elapsed().as_secs_f64(),
        });
        if flow.is_break() {
            break;
        }
        if last_checkpoint.elapsed() >= o.checkpoint_every {
            save(&params, &adam, step, plan)?;
            last_checkpoint = Instant::now();
        }
    }
    save(&params, &adam, step, plan)?;
    Ok(Outcome {
        network: net,
        steps_done: step,
        last,
        elapsed: start.elapsed(),
        planned_steps: plan.map(|p| p.length),
        median_step_seconds: recent.median(),
    })
}

/// The wall times of the last [`REPLAN_WINDOW`] steps.
#[derive(Default)]
struct StepTimes {
    last: std::collections::VecDeque<f64>,
    /// The process's first step, used only while no other was measured.
    first: Option<f64>,
}

impl StepTimes {
    fn push(&mut self, seconds: f64, first_of_process: bool) {
        if first_of_process {
            self.first = Some(seconds);
            return;
        }
        if self.last.len() == REPLAN_WINDOW {
            self.last.pop_front();
        }
        self.last.push_back(seconds);
    }

    /// The median of the window (the first step's time while it is the only one).
    fn median(&self) -> Option<f64> {
        if self.last.is_empty() {
            return self.first;
        }
        let mut v: Vec<f64> = self.last.iter().copied().collect();
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    }
}

/// Whether a re-plan to `new` steps, made at `step`, moves the schedule of `old` steps: by more
/// than [`REPLAN_TOLERANCE`] of the steps left, or 2 steps.
fn moved(old: u64, new: u64, step: u64) -> bool {
    let left = old.saturating_sub(step) as f64;
    (new as f64 - old as f64).abs() > (REPLAN_TOLERANCE * left).max(2.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::loss::{ContourSample, PlaneKind, PlaneSample};

    /// The progress line, Python's figures and the loss log's row name and order the terms
    /// alike, from the one list (`LossTerms::named`).
    #[test]
    fn progress_line_figures_and_log_row_agree() {
        let terms = LossTerms {
            surface: 1.0,
            orientation: 2.0,
            plane: 3.0,
            eikonal: 4.0,
            spurious: 5.0,
            outside: 6.0,
            motion: 7.0,
            between: 8.0,
        };
        let p = Progress {
            step: 3,
            steps: 10,
            terms,
            loss: 0.25,
            lr: 1e-3,
            elapsed: 1.5,
        };
        assert_eq!(
            p.to_string(),
            "loss 2.5000e-1 (surface 1.000e0, orientation 2.000e0, plane 3.000e0, eikonal \
             4.000e0, spurious 5.000e0, outside 6.000e0, motion 7.000e0, between 8.000e0) lr \
             1.00e-3"
        );
        let figures = p.figures();
        assert_eq!(
            figures[..3],
            [("loss", 0.25), ("lr", 1e-3f32 as f64), ("elapsed", 1.5)]
        );
        assert_eq!(figures[10], ("between", 8.0));
        let row = crate::journal::LossRow::of(3, &terms, 0.25);
        assert_eq!(row.1, [0.25, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let header: Vec<&str> = crate::journal::CSV_HEADER.split(',').skip(2).collect();
        let names: Vec<&str> = terms.named().iter().map(|(n, _)| *n).collect();
        assert_eq!(header, names, "the log's columns after step and total");
    }
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A pulsating sphere, r(t) = 0.45 + 0.1·sin(2πt) ([`Ball::Pulsating`]), or a ball of radius
    /// 0.2 swaying along x, c(t) = 0.4·sin(2πt) ([`Ball::Swaying`]: it moves its diameter between
    /// two annotated times), cut by z-planes at 5 times.
    #[derive(Clone, Copy)]
    enum Ball {
        Pulsating,
        Swaying,
    }
    use Ball::*;

    fn radius(t: f32) -> f32 {
        0.45 + 0.1 * (2.0 * std::f32::consts::PI * t).sin()
    }

    impl Ball {
        /// Centre (x) and radius at time t.
        fn at(self, t: f32) -> (f32, f32) {
            match self {
                Pulsating => (0.0, radius(t)),
                Swaying => (0.4 * (2.0 * std::f32::consts::PI * t).sin(), 0.2),
            }
        }
    }

    impl Sampler for Ball {
        fn sample(&mut self, seed: u64, step: u64, b: &mut Batch) {
            let mut rng = Pcg64Mcg::seed_from_u64(seed ^ step.wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let n = 256;
            b.contour_x.clear();
            b.contour_normal.clear();
            b.contour.clear();
            b.plane_x.clear();
            b.plane.clear();
            b.space_x.clear();
            for _ in 0..n {
                let t = rng.random_range(0..5) as f32 / 4.0;
                let (c, r) = self.at(t);
                let z = rng.random_range(-4i32..=4) as f32 * r / 4.0;
                let rc = (r * r - z * z).max(0.0).sqrt();
                let a = rng.random_range(0.0..std::f32::consts::TAU);
                b.contour_x.push([c + rc * a.cos(), rc * a.sin(), z, t]);
                b.contour_normal.push([a.cos(), a.sin(), 0.0]);
                b.contour.push(ContourSample {
                    class: 0,
                    weight: 1.0 / n as f32,
                });
                let (px, py) = (
                    rng.random_range(-1.0..1.0f32),
                    rng.random_range(-1.0..1.0f32),
                );
                b.plane_x.push([px, py, z, t]);
                let sdf2d = ((px - c) * (px - c) + py * py).sqrt() - rc;
                b.plane.push(PlaneSample {
                    class: 0,
                    target: sdf2d,
                    kind: PlaneKind::Sdf,
                    weight: 1.0 / n as f32,
                });
                b.space_x.push([
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(0.0..1.0),
                ]);
            }
        }
        fn max_set_len(&self) -> usize {
            256
        }
        fn fingerprint(&self) -> u64 {
            1
        }
    }

    fn options(steps: u64, checkpoint: Option<PathBuf>) -> TrainOptions {
        TrainOptions {
            widths: vec![48, 48],
            steps,
            time_limit: None,
            omega_0: 10.0,
            offset: 0.2,
            seed: 3,
            threads: 2,
            lr: 3e-4,
            lr_final: 3e-5,
            warmup_steps: 0,
            loss: LossWeights {
                orientation: 0.1,
                plane: 0.1,
                regulariser: 0.05,
                alpha: 50.0,
            },
            omega_t_max: 10.0,
            plane_band: None,
            motion: None,
            checkpoint,
            checkpoint_every: Duration::from_secs(3600),
            resume: true,
        }
    }

    #[test]
    fn learns_a_pulsating_sphere() {
        let mut first = None;
        let out = train(&options(1500, None), 1, &mut Pulsating, |p| {
            first = first.or(Some(p.loss));
            ControlFlow::Continue(())
        })
        .unwrap();
        let first = first.unwrap();
        let last = out.last.unwrap().2;
        assert!(last < 0.2 * first, "loss {first} -> {last}");
        let bytes = out
            .network
            .to_writer(
                dynaslice_core::Domain::IDENTITY,
                vec![("ball".into(), 1)],
                String::new(),
            )
            .to_bytes();
        let model = dynaslice_core::Model::from_bytes(&bytes).unwrap();
        for t in [0.0, 0.25, 0.5, 0.125] {
            let mut f = [0.0];
            model.eval([0.0, 0.0, 0.0], t, &mut f).unwrap();
            assert!(f[0] < -0.1, "centre at t={t}: {}", f[0]);
            model.eval([radius(t), 0.0, 0.05], t, &mut f).unwrap();
            assert!(f[0].abs() < 0.05, "surface at t={t}: {}", f[0]);
            model.eval([0.9, 0.9, 0.0], t, &mut f).unwrap();
            assert!(f[0] > 0.3, "outside at t={t}: {}", f[0]);
        }
    }

    /// The warm-up scales the first steps by (step + 1) / N, reaches the plain schedule at
    /// step N − 1 and leaves every later step unchanged.
    /// A motion model carries a ball that moves its diameter between annotated times: at the
    /// times between them it is where it should be, inside at its centre and outside behind it,
    /// deeper inside at its centre than the same shape network without motion puts it (a
    /// per-point field blends the two annotated positions, whose signed distances cancel at
    /// the true centre half-way), and the exported model (file version 2) says so through the
    /// core.
    #[test]
    fn a_motion_model_carries_a_swaying_ball() {
        let motion = MotionOptions {
            widths: vec![16, 16],
            omega_0: 5.0,
            omega_t_max: 2.0 * std::f32::consts::PI,
        };
        let model_file = |motion: Option<MotionOptions>| {
            let options = TrainOptions {
                motion,
                ..options(1500, None)
            };
            let out = train(&options, 1, &mut Swaying, |_| ControlFlow::Continue(())).unwrap();
            out.network
                .to_writer(
                    dynaslice_core::Domain::IDENTITY,
                    vec![("ball".into(), 1)],
                    String::new(),
                )
                .to_bytes()
        };
        let (carried, blended) = (model_file(Some(motion)), model_file(None));
        let carried = dynaslice_core::Model::from_bytes(&carried).unwrap();
        let blended = dynaslice_core::Model::from_bytes(&blended).unwrap();
        assert!(carried.motion().is_some() && blended.motion().is_none());
        let between = [0.125, 0.375, 0.625, 0.875];
        let centre = |model: &dynaslice_core::Model, t: f32| {
            let mut f = [0.0];
            model.eval([Swaying.at(t).0, 0.0, 0.0], t, &mut f).unwrap();
            f[0]
        };
        for t in between.into_iter().chain([0.25]) {
            let (c, r) = Swaying.at(t);
            let mut f = [0.0];
            assert!(
                centre(&carried, t) < 0.0,
                "centre at t={t}: {}",
                centre(&carried, t)
            );
            carried.eval([c + r, 0.0, 0.0], t, &mut f).unwrap();
            assert!(f[0].abs() < 0.05, "surface at t={t}: {}", f[0]);
            carried.eval([c - 2.0 * r, 0.0, 0.0], t, &mut f).unwrap();
            assert!(f[0] > 0.02, "outside, behind the ball, at t={t}: {}", f[0]);
        }
        let mean = |model| between.iter().map(|&t| centre(model, t)).sum::<f32>() / 4.0;
        let (with, without) = (mean(&carried), mean(&blended));
        assert!(
            with < without,
            "centre between annotated times: {with} with motion, {without} without"
        );
    }

    #[test]
    fn warmup_ramps_then_follows_the_cosine() {
        let plain = options(100, None);
        let warm = TrainOptions {
            warmup_steps: 10,
            ..options(100, None)
        };
        let (lr, lr_warm) = (|s| learning_rate(&plain, s), |s| learning_rate(&warm, s));
        // Within f32 rounding of the f64 schedule.
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-6 * b.abs();
        assert_eq!(lr(0), plain.lr);
        assert!(close(lr_warm(0), lr(0) / 10.0), "{}", lr_warm(0));
        assert!(close(lr_warm(4), lr(4) * 0.5), "{}", lr_warm(4));
        for s in 1..10 {
            assert!(lr_warm(s) > lr_warm(s - 1), "ramp rises at step {s}");
        }
        for s in 9..=100 {
            assert_eq!(lr_warm(s), lr(s), "step {s}");
        }
        assert!(close(lr(100), plain.lr_final));
    }

    #[test]
    fn resumed_run_ends_bit_identical() {
        let dir = tempfile::tempdir().unwrap();
        let ckpt = dir.path().join("run.ckpt");
        let straight = train(&options(30, None), 1, &mut Pulsating, |_| {
            ControlFlow::Continue(())
        })
        .unwrap();
        let stopped = train(&options(30, Some(ckpt.clone())), 1, &mut Pulsating, |p| {
            if p.step == 13 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
        assert_eq!(stopped.steps_done, 13);
        let mut first_step = None;
        let resumed = train(&options(30, Some(ckpt)), 1, &mut Pulsating, |p| {
            first_step = first_step.or(Some(p.step));
            ControlFlow::Continue(())
        })
        .unwrap();
        assert_eq!(resumed.steps_done, 30);
        assert_eq!(first_step, Some(14));
        assert!(resumed
            .network
            .params
            .iter()
            .zip(&straight.network.params)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    /// A timed run plans its schedule after the calibration steps and records the plan in its
    /// checkpoint: interrupted and resumed (with another budget), it follows the recorded plan
    /// to its end, bit for bit as a second resume from the same checkpoint does, with the
    /// cosine completed.
    #[test]
    fn timed_run_plans_its_schedule_and_a_resumed_run_keeps_it() {
        let dir = tempfile::tempdir().unwrap();
        let ckpt = dir.path().join("timed.ckpt");
        let timed = |limit: f64| TrainOptions {
            time_limit: Some(Duration::from_secs_f64(limit)),
            ..options(1_000_000, Some(ckpt.clone()))
        };
        let stopped = train(&timed(3.0), 1, &mut Pulsating, |p| {
            if p.step == CALIBRATION_STEPS + 3 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
        let planned = stopped
            .planned_steps
            .expect("planned after the calibration steps");
        assert!(
            planned < 1_000_000,
            "the budget, not the cap, sets the plan"
        );
        assert!(planned >= CALIBRATION_STEPS);
        let copy = dir.path().join("copy.ckpt");
        std::fs::copy(&ckpt, &copy).unwrap();
        let o = timed(3600.0);
        let resume = |path: &PathBuf| {
            let mut rates = Vec::new();
            let out = train(
                &TrainOptions {
                    checkpoint: Some(path.clone()),
                    ..o.clone()
                },
                1,
                &mut Pulsating,
                |p| {
                    assert_eq!(p.steps, planned);
                    rates.push(p.lr);
                    ControlFlow::Continue(())
                },
            )
            .unwrap();
            (out, rates)
        };
        let (resumed, rates) = resume(&ckpt);
        assert_eq!(resumed.steps_done, planned);
        assert_eq!(resumed.planned_steps, Some(planned));
        let (again, _) = resume(&copy);
        let bits = |o: &Outcome| {
            o.network
                .params
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&resumed), bits(&again));
        let last_lr = *rates.last().unwrap();
        if planned > CALIBRATION_STEPS + 1 {
            assert!(last_lr < 0.01 * o.lr + o.lr_final, "{last_lr}");
        }
        assert!(
            rates.windows(2).all(|w| w[1] <= w[0]),
            "the rate only decays"
        );
    }

    /// The sphere, with steps that take `fast` seconds until `switch` into the run, then `slow`:
    /// a machine that gets busy part way through.
    struct Slowing {
        start: Instant,
        switch: Duration,
        fast: Duration,
        slow: Duration,
    }

    impl Sampler for Slowing {
        fn sample(&mut self, seed: u64, step: u64, b: &mut Batch) {
            let pause = if self.start.elapsed() < self.switch {
                self.fast
            } else {
                self.slow
            };
            std::thread::sleep(pause);
            Pulsating.sample(seed, step, b);
        }
        fn max_set_len(&self) -> usize {
            Pulsating.max_set_len()
        }
        fn fingerprint(&self) -> u64 {
            Pulsating.fingerprint()
        }
    }

    /// A timed run whose steps become four times slower part way through re-plans: it uses at
    /// least 97% of its budget and its last step runs at (nearly) the final learning rate.
    #[test]
    fn a_timed_run_replans_when_the_machine_slows_down() {
        let limit = Duration::from_secs(4);
        let o = TrainOptions {
            time_limit: Some(limit),
            ..options(1_000_000, None)
        };
        let mut sampler = Slowing {
            start: Instant::now(),
            switch: Duration::from_millis(1500),
            fast: Duration::from_millis(5),
            slow: Duration::from_millis(20),
        };
        let mut lengths = Vec::new();
        let mut last_lr = f32::INFINITY;
        let out = train(&o, 1, &mut sampler, |p| {
            lengths.push(p.steps);
            last_lr = p.lr;
            ControlFlow::Continue(())
        })
        .unwrap();
        let planned = out.planned_steps.expect("planned");
        assert_eq!(
            out.steps_done, planned,
            "the plan, not the hard stop, ended it"
        );
        let used = out.elapsed.as_secs_f64() / limit.as_secs_f64();
        assert!((0.97..=1.0).contains(&used), "used {used:.3} of the budget");
        assert!(last_lr < 0.01 * o.lr + o.lr_final, "last rate {last_lr}");
        // The first plan assumed fast steps: the slowdown shortened it.
        let first_plan = lengths[CALIBRATION_STEPS as usize];
        assert!(planned < first_plan, "plan {first_plan} -> {planned}");
    }

    #[test]
    fn plans_fill_the_budget_within_the_cap() {
        let secs = Duration::from_secs_f64;
        // 100 s budget, 5 s spent at step 10, 0.5 s a step: (98.5 − 5) / 0.5 = 187 more.
        assert_eq!(plan_length(10, 10_000, secs(5.0), secs(100.0), 0.5), 197);
        assert_eq!(plan_length(10, 50, secs(5.0), secs(100.0), 0.5), 50);
        // Budget already spent: no more steps; a zero step time: the cap.
        assert_eq!(plan_length(10, 50, secs(200.0), secs(100.0), 0.5), 10);
        assert_eq!(plan_length(10, 50, secs(1.0), secs(100.0), 0.0), 50);
        // The schedule holds lr through the calibration steps, then the cosine ends at lr_final.
        let o = options(100, None);
        let (short, long) = (SchedulePlan::plain(40), SchedulePlan::plain(4000));
        for s in 0..CALIBRATION_STEPS {
            assert_eq!(schedule_rate(&o, &short, s), o.lr);
            assert_eq!(schedule_rate(&o, &long, s), o.lr);
        }
        assert!(schedule_rate(&o, &short, 11) < o.lr);
        assert!((schedule_rate(&o, &short, 40) - o.lr_final).abs() < 1e-9);
        // A re-plan continues the phase where it was: no jump, and the end at lr_final.
        let longer = short.replanned(20, 100);
        assert_eq!(longer.phase(20), short.phase(20));
        assert!(longer.phase(21) < short.phase(21));
        assert!((schedule_rate(&o, &longer, 100) - o.lr_final).abs() < 1e-9);
        assert!(!moved(1000, 1010, 500) && moved(1000, 1011, 500) && moved(20, 23, 19));
    }
}
