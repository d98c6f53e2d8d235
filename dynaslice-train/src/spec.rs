//! What a training run is asked to do: every option of `dynaslice train` and of Python's
//! `dynaslice.train`, under the same names, with `None` meaning the default. [`TrainSpec`] owns
//! every default and every rule (the step cap of a timed run, the checkpoint interval, the
//! sample budget, the allowed ranges), so that the front ends cannot drift: they map their flags
//! and keywords onto it and [`crate::fit::fit`] does the rest.
//!
//! The ranges are also what the command line's value parsers check at parse time
//! ([`Limit::check`] gives both the same "out of range; allowed: …" text).

use crate::data_sampler::SampleCounts;
use crate::loss::LossWeights;
use crate::temporal_bound::DEFAULT_TEMPORAL_FACTOR;
use crate::trainer::TrainOptions;
use dynaslice_core::format::{MAX_CLASSES, MAX_SINE_LAYERS, MAX_WIDTH};
use std::time::Duration;

/// Optimisation steps at most (a run's loss history holds one row per step).
pub const MAX_STEPS: u64 = 10_000_000;
/// Minutes of `minutes` and `checkpoint_minutes`: a year, and within `Duration`'s range.
pub const MAX_MINUTES: f64 = 525_600.0;
/// Worker threads: far above any machine this runs on, small enough that a typo cannot spawn a
/// process-choking number of threads.
pub const MAX_THREADS: usize = 1024;
/// Samples per class (contour, plane) or per step (space-time).
pub const MAX_SAMPLES_PER_STEP: usize = 1 << 20;
/// ω₀: two orders of magnitude above the documented useful range (10–30).
pub const MAX_OMEGA_0: f32 = 10_000.0;
/// c of ω_t^max = c·π/Δt (Eq. 4).
pub const MAX_TEMPORAL_FACTOR: f32 = 1000.0;
/// The initial learning rate (Adam; useful values are around 1e-4 to 1e-2).
pub const MAX_LR: f32 = 10.0;
/// Loss weights λ, α and per-class weights.
pub const MAX_WEIGHT: f32 = 1e6;
/// |`init_offset`| at most, in normalised units (the domain's half-width is 1).
pub const MAX_OFFSET: f32 = 100.0;
/// Steps of an untimed run without `steps`.
pub const DEFAULT_STEPS: u64 = 3000;
/// Minutes between checkpoints without `checkpoint_minutes`.
pub const DEFAULT_CHECKPOINT_MINUTES: f64 = 2.0;
/// ω₀ without `omega0`. 20 rather than 10: at 10 a 17 mm tumour beside the lungs is missed, a
/// kidney of the TotalSegmentator map grows 10× past the image at 300 steps and a hand's thin
/// fingers are lost; at 20 all three come out, the thin tube gains 0.03 IoU, and OReX's smooth
/// `.csl` shapes move by −0.010 to +0.008 (lab/notes/2026-12-04-omega.md).
pub const DEFAULT_OMEGA_0: f32 = 20.0;

/// An option's allowed values: a closed or half-open interval of reals, or whole numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    lo: f64,
    /// `lo` itself excluded.
    open: bool,
    hi: f64,
    whole: bool,
}

impl Limit {
    /// Reals in (0, `hi`].
    pub const fn positive(hi: f64) -> Limit {
        Limit {
            lo: 0.0,
            open: true,
            hi,
            whole: false,
        }
    }

    /// Reals in [0, `hi`].
    pub const fn non_negative(hi: f64) -> Limit {
        Limit {
            lo: 0.0,
            open: false,
            hi,
            whole: false,
        }
    }

    /// Reals in [`lo`, `hi`].
    pub const fn between(lo: f64, hi: f64) -> Limit {
        Limit {
            lo,
            open: false,
            hi,
            whole: false,
        }
    }

    /// Whole numbers in [`lo`, `hi`].
    pub const fn count(lo: u64, hi: u64) -> Limit {
        Limit {
            lo: lo as f64,
            open: false,
            hi: hi as f64,
            whole: true,
        }
    }

    /// What the limit allows, in words.
    pub fn allowed(&self) -> String {
        match (self.whole, self.open, self.lo, self.hi) {
            (true, ..) => format!("a whole number from {} to {}", self.lo, self.hi),
            (_, _, f64::NEG_INFINITY, f64::INFINITY) => "any finite number".to_string(),
            (_, true, 0.0, f64::INFINITY) => "a finite number > 0".to_string(),
            (_, false, 0.0, f64::INFINITY) => "a finite number ≥ 0".to_string(),
            (_, true, lo, hi) => format!("a number > {lo} and ≤ {hi}"),
            (_, false, lo, hi) => format!("a number from {lo} to {hi}"),
        }
    }

    /// `v` if the limit allows it, else "out of range; allowed: …" (or "not a finite number;
    /// allowed: …"): the text the command line's parsers and Python's keyword checks share.
    pub fn check(&self, v: f64) -> Result<f64, String> {
        if !v.is_finite() {
            return Err(format!("not a finite number; allowed: {}", self.allowed()));
        }
        if v < self.lo
            || (self.open && v == self.lo)
            || v > self.hi
            || (self.whole && v.fract() != 0.0)
        {
            return Err(format!("out of range; allowed: {}", self.allowed()));
        }
        Ok(v)
    }
}

/// The limits of the training options, by the option's name (CLI `--steps` is `steps`).
pub mod limits {
    use super::*;
    /// `steps`.
    pub const STEPS: Limit = Limit::count(1, MAX_STEPS);
    /// `minutes`.
    pub const MINUTES: Limit = Limit::positive(MAX_MINUTES);
    /// `threads`.
    pub const THREADS: Limit = Limit::count(1, MAX_THREADS as u64);
    /// Each of `widths`.
    pub const WIDTH: Limit = Limit::count(1, MAX_WIDTH as u64);
    /// `omega0`.
    pub const OMEGA_0: Limit = Limit::positive(MAX_OMEGA_0 as f64);
    /// `init_offset`.
    pub const OFFSET: Limit = Limit::between(-(MAX_OFFSET as f64), MAX_OFFSET as f64);
    /// `temporal_factor`.
    pub const TEMPORAL_FACTOR: Limit = Limit::positive(MAX_TEMPORAL_FACTOR as f64);
    /// `lr`.
    pub const LR: Limit = Limit::positive(MAX_LR as f64);
    /// `warmup_steps`.
    pub const WARMUP_STEPS: Limit = Limit::count(0, MAX_STEPS);
    /// `lambda_orientation`, `lambda_plane`, `lambda_regulariser`, `alpha`.
    pub const LOSS_WEIGHT: Limit = Limit::non_negative(MAX_WEIGHT as f64);
    /// Each of `class_weights`.
    pub const CLASS_WEIGHT: Limit = Limit::positive(MAX_WEIGHT as f64);
    /// `contour_samples`, `plane_samples`, `space_samples`, `min_class_samples`.
    pub const SAMPLES: Limit = Limit::count(1, MAX_SAMPLES_PER_STEP as u64);
    /// `budget_classes`.
    pub const BUDGET_CLASSES: Limit = Limit::count(1, MAX_CLASSES as u64);
    /// `checkpoint_minutes` (0: after every step).
    pub const CHECKPOINT_MINUTES: Limit = Limit::non_negative(MAX_MINUTES);
}

/// Every option of a training run; `None` (or `false`) is the default. Field names are the
/// command line's flags with `_` for `-`, and Python's keywords.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrainSpec {
    /// Optimisation steps (the learning-rate schedule spans them). Default: [`DEFAULT_STEPS`],
    /// or with `minutes` as many as fit in the time (at most `steps` when given).
    pub steps: Option<u64>,
    /// Wall-clock budget in minutes: the schedule is planned, and re-planned as the step rate
    /// changes, to end at its lowest rate when the time is up.
    pub minutes: Option<f64>,
    /// Seed of initialisation and sampling (default 0).
    pub seed: Option<u64>,
    /// Worker threads (default: one per core).
    pub threads: Option<usize>,
    /// Ablation: no temporal band limit (ω_t unclamped, initialised like ω_x).
    pub no_temporal_control: bool,
    /// Ablation: no orientation loss (λ_n = 0).
    pub no_orientation: bool,
    /// Widths of the sine layers (default 4 × 256).
    pub widths: Option<Vec<u32>>,
    /// ω₀, the first layer's spatial frequency scale (default [`DEFAULT_OMEGA_0`]).
    pub omega0: Option<f32>,
    /// Initial value of every channel, normalised units (default 0.2).
    pub init_offset: Option<f32>,
    /// c of ω_t^max = c·π/Δt (Eq. 4).
    pub temporal_factor: Option<f32>,
    /// Initial learning rate (cosine decay to a tenth).
    pub lr: Option<f32>,
    /// Steps of the linear learning-rate warm-up (default 0).
    pub warmup_steps: Option<u64>,
    /// λ_n (Eq. 6).
    pub lambda_orientation: Option<f32>,
    /// λ_d (Eq. 7).
    pub lambda_plane: Option<f32>,
    /// λ_r (Eq. 8).
    pub lambda_regulariser: Option<f32>,
    /// α of exp(−α|f|) (Eq. 8).
    pub alpha: Option<f32>,
    /// Contour points per class per step.
    pub contour_samples: Option<usize>,
    /// Plane samples per class per step.
    pub plane_samples: Option<usize>,
    /// Space-time samples per step.
    pub space_samples: Option<usize>,
    /// Classes whose full counts make the per-step budget ([`SampleCounts::budget_classes`]).
    pub budget_classes: Option<usize>,
    /// The fewest samples of a class when classes share the budget.
    pub min_class_samples: Option<usize>,
    /// Per-class weights of the contour and plane terms, one per class.
    pub class_weights: Option<Vec<f32>>,
    /// Minutes between checkpoints (0: after every step; default [`DEFAULT_CHECKPOINT_MINUTES`]).
    pub checkpoint_minutes: Option<f64>,
    /// Continue from the checkpoint beside the model, if there is one.
    pub resume: bool,
    /// Without `resume`, discard an existing checkpoint (and replace an existing model).
    pub force: bool,
}

/// A bad option: its name (as in [`TrainSpec`]) and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpecError {
    /// The option's name, e.g. `lr` (the command line's `--lr`).
    pub option: &'static str,
    /// What is wrong, e.g. "-1: out of range; allowed: a number > 0 and ≤ 10".
    pub message: String,
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "--{}: {}", self.option.replace('_', "-"), self.message)
    }
}

impl std::error::Error for SpecError {}

/// Checks `v` of option `option` against `limit`.
fn check<T: Copy + Into<f64> + std::fmt::Display>(
    option: &'static str,
    v: Option<T>,
    limit: Limit,
) -> Result<(), SpecError> {
    match v {
        Some(v) => limit.check(v.into()).map(drop).map_err(|m| SpecError {
            option,
            message: format!("{v}: {m}"),
        }),
        None => Ok(()),
    }
}

impl TrainSpec {
    /// Every option against its limit, and the counts that depend on nothing else (the number
    /// of `widths`); what depends on the data ([`TrainSpec::check_classes`]) is checked by
    /// [`crate::fit::fit`] once the input is read, still before any training.
    pub fn validate(&self) -> Result<(), SpecError> {
        use limits::*;
        check("steps", self.steps.map(|v| v as f64), STEPS)?;
        check("minutes", self.minutes, MINUTES)?;
        check("threads", self.threads.map(|v| v as f64), THREADS)?;
        if let Some(w) = &self.widths {
            if w.is_empty() || w.len() > MAX_SINE_LAYERS {
                return Err(SpecError {
                    option: "widths",
                    message: format!(
                        "{} layers; a model has 1 to {MAX_SINE_LAYERS} sine layers",
                        w.len()
                    ),
                });
            }
            for &v in w {
                check("widths", Some(v), WIDTH)?;
            }
        }
        check("omega0", self.omega0, OMEGA_0)?;
        check("init_offset", self.init_offset, OFFSET)?;
        check("temporal_factor", self.temporal_factor, TEMPORAL_FACTOR)?;
        check("lr", self.lr, LR)?;
        check(
            "warmup_steps",
            self.warmup_steps.map(|v| v as f64),
            WARMUP_STEPS,
        )?;
        check("lambda_orientation", self.lambda_orientation, LOSS_WEIGHT)?;
        check("lambda_plane", self.lambda_plane, LOSS_WEIGHT)?;
        check("lambda_regulariser", self.lambda_regulariser, LOSS_WEIGHT)?;
        check("alpha", self.alpha, LOSS_WEIGHT)?;
        let samples = |v: Option<usize>| v.map(|v| v as f64);
        check("contour_samples", samples(self.contour_samples), SAMPLES)?;
        check("plane_samples", samples(self.plane_samples), SAMPLES)?;
        check("space_samples", samples(self.space_samples), SAMPLES)?;
        check(
            "min_class_samples",
            samples(self.min_class_samples),
            SAMPLES,
        )?;
        check(
            "budget_classes",
            samples(self.budget_classes),
            BUDGET_CLASSES,
        )?;
        for &w in self.class_weights.iter().flatten() {
            check("class_weights", Some(w), CLASS_WEIGHT)?;
        }
        check(
            "checkpoint_minutes",
            self.checkpoint_minutes,
            CHECKPOINT_MINUTES,
        )?;
        Ok(())
    }

    /// The checks that need the number of classes the input has.
    pub fn check_classes(&self, num_classes: usize) -> Result<(), SpecError> {
        match &self.class_weights {
            Some(w) if w.len() != num_classes => Err(SpecError {
                option: "class_weights",
                message: format!("{} class weights for {num_classes} classes", w.len()),
            }),
            _ => Ok(()),
        }
    }

    /// The learning rate (the default where not given).
    pub fn lr(&self) -> f32 {
        self.lr.unwrap_or(TrainOptions::default().lr)
    }

    /// c of Eq. 4.
    pub fn temporal_factor(&self) -> f32 {
        self.temporal_factor.unwrap_or(DEFAULT_TEMPORAL_FACTOR)
    }

    /// The samples each step draws.
    pub fn counts(&self) -> SampleCounts {
        let d = SampleCounts::default();
        SampleCounts {
            contour_per_class: self.contour_samples.unwrap_or(d.contour_per_class),
            plane_per_class: self.plane_samples.unwrap_or(d.plane_per_class),
            space: self.space_samples.unwrap_or(d.space),
            budget_classes: self.budget_classes.unwrap_or(d.budget_classes),
            min_per_class: self.min_class_samples.unwrap_or(d.min_per_class),
        }
    }

    /// The loss weights (λ_n = 0 under `no_orientation`).
    pub fn loss(&self) -> LossWeights {
        let d = TrainOptions::default().loss;
        LossWeights {
            orientation: if self.no_orientation {
                0.0
            } else {
                self.lambda_orientation.unwrap_or(d.orientation)
            },
            plane: self.lambda_plane.unwrap_or(d.plane),
            regulariser: self.lambda_regulariser.unwrap_or(d.regulariser),
            alpha: self.alpha.unwrap_or(d.alpha),
        }
    }

    /// The length of the schedule, or for a timed run without `steps` the cap its plan may
    /// reach: [`MAX_STEPS`] (the time sets the length, not a default step count).
    pub fn schedule_steps(&self) -> u64 {
        match (self.steps, self.minutes) {
            (Some(steps), _) => steps,
            (None, Some(_)) => MAX_STEPS,
            (None, None) => DEFAULT_STEPS,
        }
    }

    /// The trainer's options for a run with ω_t^max = `omega_t_max` (from the data, Eq. 4),
    /// checkpointing to `checkpoint` where given. Call [`TrainSpec::validate`] first: the values
    /// are taken as they are.
    pub fn options(
        &self,
        omega_t_max: f32,
        checkpoint: Option<std::path::PathBuf>,
    ) -> TrainOptions {
        let d = TrainOptions::default();
        let lr = self.lr();
        TrainOptions {
            widths: self.widths.clone().unwrap_or(d.widths),
            steps: self.schedule_steps(),
            time_limit: self.minutes.map(|m| Duration::from_secs_f64(m * 60.0)),
            omega_0: self.omega0.unwrap_or(DEFAULT_OMEGA_0),
            offset: self.init_offset.unwrap_or(d.offset),
            seed: self.seed.unwrap_or(d.seed),
            threads: self.threads.unwrap_or(d.threads).max(1),
            lr,
            lr_final: lr / 10.0,
            warmup_steps: self.warmup_steps.unwrap_or(d.warmup_steps),
            loss: self.loss(),
            omega_t_max,
            checkpoint,
            checkpoint_every: Duration::from_secs_f64(
                self.checkpoint_minutes
                    .unwrap_or(DEFAULT_CHECKPOINT_MINUTES)
                    * 60.0,
            ),
            resume: self.resume,
        }
    }
}

impl Default for TrainOptions {
    /// The defaults of `dynaslice train`: the paper's network size (4 sine layers of 256),
    /// 3000 steps, ω₀ = 20 ([`DEFAULT_OMEGA_0`]), initial offset 0.2, lr 1e-3 → 1e-4 (cosine), λ_n = λ_d = 0.1, λ_r = 0.2, α = 50, all threads,
    /// no checkpoint; `omega_t_max` must be set from the data ([`crate::temporal_bound::temporal_bound`]).
    fn default() -> Self {
        TrainOptions {
            widths: vec![256; 4],
            steps: DEFAULT_STEPS,
            time_limit: None,
            omega_0: DEFAULT_OMEGA_0,
            offset: 0.2,
            seed: 0,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            lr: 1e-3,
            lr_final: 1e-4,
            warmup_steps: 0,
            loss: LossWeights {
                orientation: 0.1,
                plane: 0.1,
                // Measured (lab/notes/training.md): 0.05 let real data and the thin tube overfit
                // between planes; 0.2 is better on both.
                regulariser: 0.2,
                alpha: 50.0,
            },
            omega_t_max: f32::INFINITY,
            checkpoint: None,
            checkpoint_every: Duration::from_secs_f64(DEFAULT_CHECKPOINT_MINUTES * 60.0),
            resume: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_name_the_range() {
        assert_eq!(limits::LR.check(1.0), Ok(1.0));
        let e = limits::LR.check(-1.0).unwrap_err();
        assert_eq!(e, "out of range; allowed: a number > 0 and ≤ 10");
        assert!(limits::LR
            .check(f64::NAN)
            .unwrap_err()
            .starts_with("not a finite"));
        assert!(limits::STEPS
            .check(0.0)
            .unwrap_err()
            .contains("from 1 to 10000000"));
        assert!(limits::STEPS.check(1.5).is_err());
        assert_eq!(limits::CHECKPOINT_MINUTES.check(0.0), Ok(0.0));
    }

    #[test]
    fn validate_names_the_option() {
        assert_eq!(TrainSpec::default().validate(), Ok(()));
        let bad = TrainSpec {
            lr: Some(-1.0),
            ..TrainSpec::default()
        };
        let e = bad.validate().unwrap_err();
        assert_eq!(e.option, "lr");
        assert_eq!(
            e.to_string(),
            "--lr: -1: out of range; allowed: a number > 0 and ≤ 10"
        );
        let widths = TrainSpec {
            widths: Some(vec![]),
            ..TrainSpec::default()
        };
        assert!(widths.validate().unwrap_err().message.contains("0 layers"));
        let weights = TrainSpec {
            class_weights: Some(vec![1.0, 2.0]),
            ..TrainSpec::default()
        };
        assert!(weights
            .check_classes(3)
            .unwrap_err()
            .message
            .contains("2 class weights for 3"));
    }

    #[test]
    /// An empty spec trains with the defaults docs/training.md documents ("Defaults, and
    /// why"), written out here rather than read from the constants they are made of.
    fn defaults_are_the_trainers() {
        let s = TrainSpec::default();
        let o = s.options(1.0, None);
        assert_eq!(o.widths, [256; 4]);
        assert_eq!(o.steps, 3000);
        assert_eq!(
            (o.lr, o.lr_final, o.omega_0, o.offset, o.warmup_steps),
            // The cosine ends at a tenth of the rate, computed in f32.
            (1e-3, 1e-3 / 10.0, 20.0, 0.2, 0)
        );
        let l = o.loss;
        assert_eq!(
            (l.orientation, l.plane, l.regulariser, l.alpha),
            (0.1, 0.1, 0.2, 50.0)
        );
        assert_eq!(s.temporal_factor(), 0.2);
        assert_eq!(o.checkpoint_every, Duration::from_secs(120));
        let c = s.counts();
        assert_eq!(
            (c.contour_per_class, c.plane_per_class, c.space),
            (1024, 1024, 1024)
        );
        assert_eq!((c.budget_classes, c.min_per_class), (3, 64));
        let timed = TrainSpec {
            minutes: Some(1.0),
            ..TrainSpec::default()
        };
        assert_eq!(timed.schedule_steps(), MAX_STEPS);
    }
}
