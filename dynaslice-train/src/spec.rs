//! What a training run is asked to do: every option of `dynaslice train` and of Python's
//! `dynaslice.train`, under the same names, with `None` meaning the default. [`TrainSpec`] owns
//! every default and every rule (the step cap of a timed run, the checkpoint interval, the
//! sample budget, the allowed ranges), so that the front ends cannot drift: they map their flags
//! and keywords onto it and [`crate::fit::fit`] does the rest.
//!
//! The defaults and ranges are the table of options' ([`crate::flags`]), which the command
//! line's value parsers check at parse time ([`Limit::check`] gives both the same "out of
//! range; allowed: …" text).

use crate::data_sampler::SampleCounts;
use crate::flags::*;
// The limits and the option errors are the table's; their old paths stay.
pub use crate::flags::{
    Limit, SpecError, DEFAULT_CHECKPOINT_MINUTES, DEFAULT_OMEGA_0, DEFAULT_STEPS, MAX_LR,
    MAX_MINUTES, MAX_OFFSET, MAX_OMEGA_0, MAX_SAMPLES_PER_STEP, MAX_STEPS, MAX_TEMPORAL_FACTOR,
    MAX_THREADS, MAX_WEIGHT,
};
use crate::loss::LossWeights;
use crate::trainer::TrainOptions;
use dynaslice_core::format::MAX_SINE_LAYERS;
use std::time::Duration;

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
    /// Ablation: no band limit across parallel planes ([`crate::spatial_bound`]).
    pub no_plane_band: bool,
    /// For a moving input, a motion model ([`crate::warp`]).
    pub motion: bool,
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

impl TrainSpec {
    /// Every option against its limit, and the counts that depend on nothing else (the number
    /// of `widths`); what depends on the data ([`TrainSpec::check_classes`]) is checked by
    /// [`crate::fit::fit`] once the input is read, still before any training.
    pub fn validate(&self) -> Result<(), SpecError> {
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
        }
        for flag in FLAGS {
            let Some(limit) = flag.limit else { continue };
            for v in self.numbers(flag.name) {
                limit.check(v).map_err(|m| SpecError {
                    option: flag.name,
                    // As given: an f32 option's value as the f32 it is (0.1, not 0.100000001…).
                    message: match flag.values {
                        Values::Real32 | Values::Reals32 => format!("{}: {m}", v as f32),
                        _ => format!("{v}: {m}"),
                    },
                })?;
            }
        }
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
        self.lr.unwrap_or(LR.default.real() as f32)
    }

    /// c of Eq. 4.
    pub fn temporal_factor(&self) -> f32 {
        self.temporal_factor
            .unwrap_or(TEMPORAL_FACTOR.default.real() as f32)
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
            omega_0: self.omega0.unwrap_or(d.omega_0),
            offset: self.init_offset.unwrap_or(d.offset),
            seed: self.seed.unwrap_or(d.seed),
            threads: self.threads.unwrap_or(d.threads).max(1),
            lr,
            lr_final: lr / 10.0,
            warmup_steps: self.warmup_steps.unwrap_or(d.warmup_steps),
            loss: self.loss(),
            omega_t_max,
            // From the data's planes and times: set by `fit` (`spatial_bound::plane_band`,
            // `warp::motion_options`).
            plane_band: None,
            motion: None,
            checkpoint,
            checkpoint_every: Duration::from_secs_f64(
                self.checkpoint_minutes
                    .unwrap_or(CHECKPOINT_MINUTES.default.real())
                    * 60.0,
            ),
            resume: self.resume,
        }
    }
}

impl TrainSpec {
    /// Sets option `name` (a [`FLAGS`] name) to `value`, converted to the option's type as the
    /// command line's parser converts it. The value is checked by [`TrainSpec::validate`]; an
    /// unknown name or a value of the wrong kind is an error naming the option.
    pub fn set(&mut self, name: &str, value: Value) -> Result<(), SpecError> {
        let flag = find(name).ok_or_else(|| SpecError {
            option: "option",
            message: format!("{name:?} is not a training option"),
        })?;
        let wrong = || SpecError {
            option: flag.name,
            message: format!("{value:?} is not {:?}", flag.values),
        };
        let whole = |v: &Value| match *v {
            Value::Whole(v) => Some(v),
            _ => None,
        };
        let real = |v: &Value| match *v {
            Value::Real(v) => Some(v),
            _ => None,
        };
        let switch = |v: &Value| match *v {
            Value::Switch(v) => Some(v),
            _ => None,
        };
        // Counts beyond the field's type saturate: the limit check then refuses them.
        let size = |v: u64| usize::try_from(v).unwrap_or(usize::MAX);
        match name {
            "steps" => self.steps = Some(whole(&value).ok_or_else(wrong)?),
            "minutes" => self.minutes = Some(real(&value).ok_or_else(wrong)?),
            "seed" => self.seed = Some(whole(&value).ok_or_else(wrong)?),
            "threads" => self.threads = Some(size(whole(&value).ok_or_else(wrong)?)),
            "resume" => self.resume = switch(&value).ok_or_else(wrong)?,
            "force" => self.force = switch(&value).ok_or_else(wrong)?,
            "no_temporal_control" => self.no_temporal_control = switch(&value).ok_or_else(wrong)?,
            "no_plane_band" => self.no_plane_band = switch(&value).ok_or_else(wrong)?,
            "motion" => self.motion = switch(&value).ok_or_else(wrong)?,
            "no_orientation" => self.no_orientation = switch(&value).ok_or_else(wrong)?,
            "widths" => match &value {
                Value::Wholes(w) => {
                    self.widths = Some(
                        w.iter()
                            .map(|&v| u32::try_from(v).unwrap_or(u32::MAX))
                            .collect(),
                    )
                }
                _ => return Err(wrong()),
            },
            "omega0" => self.omega0 = Some(real(&value).ok_or_else(wrong)? as f32),
            "init_offset" => self.init_offset = Some(real(&value).ok_or_else(wrong)? as f32),
            "temporal_factor" => {
                self.temporal_factor = Some(real(&value).ok_or_else(wrong)? as f32)
            }
            "lr" => self.lr = Some(real(&value).ok_or_else(wrong)? as f32),
            "warmup_steps" => self.warmup_steps = Some(whole(&value).ok_or_else(wrong)?),
            "lambda_orientation" => {
                self.lambda_orientation = Some(real(&value).ok_or_else(wrong)? as f32)
            }
            "lambda_plane" => self.lambda_plane = Some(real(&value).ok_or_else(wrong)? as f32),
            "lambda_regulariser" => {
                self.lambda_regulariser = Some(real(&value).ok_or_else(wrong)? as f32)
            }
            "alpha" => self.alpha = Some(real(&value).ok_or_else(wrong)? as f32),
            "contour_samples" => {
                self.contour_samples = Some(size(whole(&value).ok_or_else(wrong)?))
            }
            "plane_samples" => self.plane_samples = Some(size(whole(&value).ok_or_else(wrong)?)),
            "budget_classes" => self.budget_classes = Some(size(whole(&value).ok_or_else(wrong)?)),
            "min_class_samples" => {
                self.min_class_samples = Some(size(whole(&value).ok_or_else(wrong)?))
            }
            "space_samples" => self.space_samples = Some(size(whole(&value).ok_or_else(wrong)?)),
            "class_weights" => match &value {
                Value::Reals(w) => self.class_weights = Some(w.iter().map(|&v| v as f32).collect()),
                _ => return Err(wrong()),
            },
            "checkpoint_minutes" => self.checkpoint_minutes = Some(real(&value).ok_or_else(wrong)?),
            _ => unreachable!("every flag of the table is set above (test: every_flag_sets)"),
        }
        Ok(())
    }

    /// The values the spec gives option `name` (empty where it gives none), as numbers for the
    /// limit check: what [`TrainSpec::validate`] checks against [`FLAGS`].
    pub(crate) fn numbers(&self, name: &str) -> Vec<f64> {
        let one = |v: Option<f64>| v.into_iter().collect::<Vec<f64>>();
        match name {
            "steps" => one(self.steps.map(|v| v as f64)),
            "minutes" => one(self.minutes),
            "seed" => one(self.seed.map(|v| v as f64)),
            "threads" => one(self.threads.map(|v| v as f64)),
            "widths" => self.widths.iter().flatten().map(|&v| v.into()).collect(),
            "omega0" => one(self.omega0.map(f64::from)),
            "init_offset" => one(self.init_offset.map(f64::from)),
            "temporal_factor" => one(self.temporal_factor.map(f64::from)),
            "lr" => one(self.lr.map(f64::from)),
            "warmup_steps" => one(self.warmup_steps.map(|v| v as f64)),
            "lambda_orientation" => one(self.lambda_orientation.map(f64::from)),
            "lambda_plane" => one(self.lambda_plane.map(f64::from)),
            "lambda_regulariser" => one(self.lambda_regulariser.map(f64::from)),
            "alpha" => one(self.alpha.map(f64::from)),
            "contour_samples" => one(self.contour_samples.map(|v| v as f64)),
            "plane_samples" => one(self.plane_samples.map(|v| v as f64)),
            "budget_classes" => one(self.budget_classes.map(|v| v as f64)),
            "min_class_samples" => one(self.min_class_samples.map(|v| v as f64)),
            "space_samples" => one(self.space_samples.map(|v| v as f64)),
            "class_weights" => self
                .class_weights
                .iter()
                .flatten()
                .map(|&v| v.into())
                .collect(),
            "checkpoint_minutes" => one(self.checkpoint_minutes),
            // Switches: nothing to check.
            _ => Vec::new(),
        }
    }
}

impl Default for TrainOptions {
    /// The defaults of `dynaslice train`, from the table of options ([`crate::flags`]): the
    /// paper's network size (4 sine layers of 256), [`DEFAULT_STEPS`] steps, ω₀ =
    /// [`DEFAULT_OMEGA_0`], initial offset 0.2, lr 1e-3 → 1e-4 (cosine), λ_n = λ_d = 0.1,
    /// λ_r = 0.2, α = 50, all threads, no checkpoint; `omega_t_max` must be set from the data
    /// ([`crate::temporal_bound::temporal_bound`]).
    fn default() -> Self {
        let real = |f: &Flag| f.default.real() as f32;
        let widths = match WIDTHS.default {
            DefaultValue::Wholes(w) => w.to_vec(),
            _ => unreachable!("widths default to a list"),
        };
        TrainOptions {
            widths,
            steps: DEFAULT_STEPS,
            time_limit: None,
            omega_0: real(&OMEGA0),
            offset: real(&INIT_OFFSET),
            seed: SEED.default.whole(),
            threads: THREADS.default.whole() as usize,
            lr: real(&LR),
            lr_final: 1e-4,
            warmup_steps: WARMUP_STEPS.default.whole(),
            loss: LossWeights {
                orientation: real(&LAMBDA_ORIENTATION),
                plane: real(&LAMBDA_PLANE),
                regulariser: real(&LAMBDA_REGULARISER),
                alpha: real(&ALPHA),
            },
            omega_t_max: f32::INFINITY,
            plane_band: None,
            motion: None,
            checkpoint: None,
            checkpoint_every: Duration::from_secs_f64(CHECKPOINT_MINUTES.default.real() * 60.0),
            resume: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_every_flag_sets() {
        for (i, f) in FLAGS.iter().enumerate() {
            assert!(FLAGS[..i].iter().all(|g| g.name != f.name), "{}", f.name);
            assert_eq!(f.limit.is_none(), f.values == Values::Switch, "{}", f.name);
            assert!(
                !f.help.ends_with('.'),
                "{}: the summary has no final period",
                f.name
            );
            let value = match f.values {
                Values::Switch => Value::Switch(true),
                Values::Whole => Value::Whole(2),
                Values::Real32 | Values::Real64 => Value::Real(2.0),
                Values::Wholes => Value::Wholes(vec![2, 3]),
                Values::Reals32 => Value::Reals(vec![2.0, 3.0]),
            };
            let mut spec = TrainSpec::default();
            spec.set(f.name, value).unwrap();
            assert_ne!(spec, TrainSpec::default(), "{} sets nothing", f.name);
            if f.values != Values::Switch {
                assert!(
                    !spec.numbers(f.name).is_empty(),
                    "{} is not checked",
                    f.name
                );
                // A value of the wrong kind is refused, naming the option.
                let e = TrainSpec::default()
                    .set(f.name, Value::Switch(true))
                    .unwrap_err();
                assert_eq!(e.option, f.name);
            }
        }
        assert!(TrainSpec::default().set("omega", Value::Real(1.0)).is_err());
    }

    #[test]
    fn the_spec_takes_its_defaults_from_the_table() {
        let spec = TrainSpec::default();
        let o = spec.options(1.0, None);
        let c = spec.counts();
        let l = spec.loss();
        let widths: Vec<u64> = o.widths.iter().map(|&w| w.into()).collect();
        assert_eq!(DefaultValue::Wholes(&[256; 4]), WIDTHS.default);
        assert_eq!(widths, [256; 4]);
        for (flag, used) in [
            (&SEED, o.seed as f64),
            (&THREADS, o.threads as f64),
            (&WARMUP_STEPS, o.warmup_steps as f64),
            (&OMEGA0, o.omega_0.into()),
            (&INIT_OFFSET, o.offset.into()),
            (&TEMPORAL_FACTOR, spec.temporal_factor().into()),
            (&LR, o.lr.into()),
            (&LAMBDA_ORIENTATION, l.orientation.into()),
            (&LAMBDA_PLANE, l.plane.into()),
            (&LAMBDA_REGULARISER, l.regulariser.into()),
            (&ALPHA, l.alpha.into()),
            (&CONTOUR_SAMPLES, c.contour_per_class as f64),
            (&PLANE_SAMPLES, c.plane_per_class as f64),
            (&BUDGET_CLASSES, c.budget_classes as f64),
            (&MIN_CLASS_SAMPLES, c.min_per_class as f64),
            (&SPACE_SAMPLES, c.space as f64),
            (&CHECKPOINT_MINUTES, o.checkpoint_every.as_secs_f64() / 60.0),
        ] {
            let table = match flag.default {
                DefaultValue::Real(v) => v,
                d => d.whole() as f64,
            };
            assert_eq!(table, used, "{}", flag.name);
            // Every default is allowed.
            assert!(flag.limit.unwrap().check(table).is_ok(), "{}", flag.name);
        }
        assert_eq!(LR.default.to_string(), "0.001");
        assert!(STEPS
            .help
            .contains(&format!("Default: {}", crate::spec::DEFAULT_STEPS)));
        assert_eq!(WIDTHS.default.to_string(), "256,256,256,256");
    }

    #[test]
    fn limits_name_the_range() {
        assert_eq!(LR.limit.unwrap().check(1.0), Ok(1.0));
        let e = LR.limit.unwrap().check(-1.0).unwrap_err();
        assert_eq!(e, "out of range; allowed: a number > 0 and ≤ 10");
        assert!(LR
            .limit
            .unwrap()
            .check(f64::NAN)
            .unwrap_err()
            .starts_with("not a finite"));
        assert!(STEPS
            .limit
            .unwrap()
            .check(0.0)
            .unwrap_err()
            .contains("from 1 to 10000000"));
        assert!(STEPS.limit.unwrap().check(1.5).is_err());
        assert_eq!(CHECKPOINT_MINUTES.limit.unwrap().check(0.0), Ok(0.0));
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
