//! One table of the training options, as ripgrep keeps one `Flag` per option: each option's
//! name, help, default and allowed values, in the order `dynaslice train --help` lists them.
//! `TrainSpec` takes its defaults (`options`, `counts`) and limits (`validate`) from here, with
//! the limits' type [`Limit`] (dynaslice-data's, which the input options share) and the option
//! error [`SpecError`]; the command line builds its training flags from it (dynaslice-cli's
//! `options.rs`, `flag_args!`) and Python reads its keywords through it
//! (`dynaslice_train::job::set`, `TrainSpec::set`).
//!
//! The input options (`--frames`, `--planes`, …) are not here: every command that reads
//! cross-sections shares them (dynaslice-data's `input_flags` table and `InputSpec`).

use crate::temporal_bound::DEFAULT_TEMPORAL_FACTOR;
use dynaslice_core::format::{MAX_CLASSES, MAX_WIDTH};
pub use dynaslice_data::limit::Limit;
use std::fmt;

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

/// A bad option: its name (as in `TrainSpec`) and what is wrong.
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

/// What an option takes, and the type `TrainSpec` holds it in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Values {
    /// Nothing: given or not (`--resume`, `resume=True`).
    Switch,
    /// A whole number.
    Whole,
    /// A real number held as f32 (a value that rounds to 0 or infinity there is out of range).
    Real32,
    /// A real number held as f64.
    Real64,
    /// Comma-separated whole numbers (Python: a list, or the same text).
    Wholes,
    /// Comma-separated reals held as f32 (Python: a list, or the same text).
    Reals32,
}

/// An option's default, as the spec applies it and the help shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DefaultValue {
    /// None: the option's help says what happens without it.
    Unset,
    /// A switch's: off.
    Off,
    /// A whole number.
    Whole(u64),
    /// A real number (f32 options: exactly the f32 the spec uses).
    Real(f64),
    /// A list of whole numbers.
    Wholes(&'static [u32]),
    /// One per core of the machine.
    Cores,
}

impl DefaultValue {
    /// A whole-number default (0 where the table gives none: a table error the tests catch).
    pub fn whole(&self) -> u64 {
        match *self {
            DefaultValue::Whole(v) => v,
            DefaultValue::Cores => {
                std::thread::available_parallelism().map_or(1, |n| n.get() as u64)
            }
            _ => 0,
        }
    }

    /// A real default.
    pub fn real(&self) -> f64 {
        match *self {
            DefaultValue::Real(v) => v,
            _ => f64::NAN,
        }
    }
}

impl fmt::Display for DefaultValue {
    /// As the help shows it: `0.001`, `256,256,256,256`, the machine's core count.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DefaultValue::Unset | DefaultValue::Off => Ok(()),
            DefaultValue::Whole(_) | DefaultValue::Cores => write!(f, "{}", self.whole()),
            // f32 options' defaults are f32s: shown as the f32 they are (0.001, not 0.0010000…).
            DefaultValue::Real(v) if v as f32 as f64 == v => write!(f, "{}", v as f32),
            DefaultValue::Real(v) => write!(f, "{v}"),
            DefaultValue::Wholes(w) => {
                let items: Vec<String> = w.iter().map(u32::to_string).collect();
                write!(f, "{}", items.join(","))
            }
        }
    }
}

/// One training option.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flag {
    /// The name: `TrainSpec`'s field and Python's keyword; the command line's flag is `--`
    /// with `-` for `_`.
    pub name: &'static str,
    /// The summary the short help (`-h`) shows, without a final period.
    pub help: &'static str,
    /// The paragraphs the long help (`--help`) adds, where there are any.
    pub more: Option<&'static str>,
    /// The placeholder of the value in the help, where not the name in capitals.
    pub value_name: Option<&'static str>,
    /// What it takes.
    pub values: Values,
    /// The allowed values (of each item, for lists); none for switches.
    pub limit: Option<Limit>,
    /// Its default.
    pub default: DefaultValue,
}

impl Flag {
    /// The command line's flag: `init-offset` (without the `--`).
    pub fn long(&self) -> String {
        self.name.replace('_', "-")
    }
}

/// The flag named `name` in [`FLAGS`].
pub fn find(name: &str) -> Option<&'static Flag> {
    FLAGS.iter().find(|f| f.name == name).copied()
}

const fn flag(
    name: &'static str,
    help: &'static str,
    values: Values,
    limit: Option<Limit>,
    default: DefaultValue,
) -> Flag {
    Flag {
        name,
        help,
        more: None,
        value_name: None,
        values,
        limit,
        default,
    }
}

const fn switch(name: &'static str, help: &'static str) -> Flag {
    flag(name, help, Values::Switch, None, DefaultValue::Off)
}

/// `steps`.
pub const STEPS: Flag = flag(
    "steps",
    "Optimisation steps (the learning-rate schedule spans them). Default: 3000, or with \
     --minutes as many as fit in the time (at most this many when given)",
    Values::Whole,
    Some(Limit::count(1, MAX_STEPS)),
    DefaultValue::Unset,
);
/// `minutes`.
pub const MINUTES: Flag = flag(
    "minutes",
    "Train for this many minutes: the step time is measured on the first steps and the \
     learning-rate schedule planned to end, at its lowest rate, when the time is up; as the \
     machine's speed changes the rest of the schedule is re-planned (the plan is recorded in \
     the checkpoint, which a resumed run follows, and the model's metadata)",
    Values::Real64,
    Some(Limit::positive(MAX_MINUTES)),
    DefaultValue::Unset,
);
/// `seed`.
pub const SEED: Flag = flag(
    "seed",
    "Seed of initialisation and sampling",
    Values::Whole,
    Some(Limit::count(0, u64::MAX)),
    DefaultValue::Whole(0),
);
/// `threads`.
pub const THREADS: Flag = flag(
    "threads",
    "Worker threads (results are reproducible for a given count)",
    Values::Whole,
    Some(Limit::count(1, MAX_THREADS as u64)),
    DefaultValue::Cores,
);
/// `resume`.
pub const RESUME: Flag = switch(
    "resume",
    "Continue from the checkpoint beside the output, if there is one",
);
/// `force`.
pub const FORCE: Flag = switch(
    "force",
    "Replace an existing model file, and without --resume discard an existing checkpoint",
);
/// `no_temporal_control`.
pub const NO_TEMPORAL_CONTROL: Flag = switch(
    "no_temporal_control",
    "Ablation: no temporal band limit (ω_t unclamped, initialised like ω_x)",
);
/// `no_plane_band`.
pub const NO_PLANE_BAND: Flag = switch(
    "no_plane_band",
    "Ablation: no band limit across parallel planes (ω_x unbounded along their normal)",
);
/// `motion`.
pub const MOTION: Flag = switch(
    "motion",
    "For a moving input, carry each structure's shape by a motion network: \
     f = g(x + u(x, t), t) (docs/training.md, \"Moving inputs\")",
);
/// `no_orientation`.
pub const NO_ORIENTATION: Flag =
    switch("no_orientation", "Ablation: no orientation loss (λ_n = 0)");
/// `widths`: the paper's network size.
pub const WIDTHS: Flag = flag(
    "widths",
    "Widths of the sine layers",
    Values::Wholes,
    Some(Limit::count(1, MAX_WIDTH as u64)),
    DefaultValue::Wholes(&[256; 4]),
);
/// `omega0` ([`DEFAULT_OMEGA_0`]).
pub const OMEGA0: Flag = Flag {
    more: Some(
        "The default suits sparse planes, moving structures, small structures beside large \
         ones (a 17 mm tumour beside the lungs, missed at 10) and thin parts (fingers); smooth \
         shapes cut by 15 planes may fit 0.01 IoU better at 10. Densely sliced static anatomy \
         (many planes, several orientations) fits finer at 30: held-out 2D IoU 0.94 against \
         0.87–0.91 on the TotalSegmentator CT. At 30 add `--warmup-steps 100`: without it, \
         models measured there collapsed into spurious insides in some seeds. 15-plane `.csl` \
         inputs and the moving synthetic chambers lose at 30 (docs/training.md, \"When to \
         change ω₀\").",
    ),
    ..flag(
        "omega0",
        "ω₀: the first layer's spatial frequency scale over the normalised cube",
        Values::Real32,
        Some(Limit::positive(MAX_OMEGA_0 as f64)),
        DefaultValue::Real(DEFAULT_OMEGA_0 as f64),
    )
};
/// `init_offset`.
pub const INIT_OFFSET: Flag = flag(
    "init_offset",
    "Initial value of every channel in normalised units (the domain's half-width is 1): the \
     network starts \"outside\" everywhere, so regions no data reaches stay background",
    Values::Real32,
    Some(Limit::between(-(MAX_OFFSET as f64), MAX_OFFSET as f64)),
    DefaultValue::Real(0.2f32 as f64),
);
/// `temporal_factor` ([`DEFAULT_TEMPORAL_FACTOR`]).
pub const TEMPORAL_FACTOR: Flag = flag(
    "temporal_factor",
    "c in ω_t^max = c·π/Δt (Eq. 4), Δt the annotated frames' spacing in normalised time",
    Values::Real32,
    Some(Limit::positive(MAX_TEMPORAL_FACTOR as f64)),
    DefaultValue::Real(DEFAULT_TEMPORAL_FACTOR as f64),
);
/// `lr`.
pub const LR: Flag = flag(
    "lr",
    "Initial learning rate (cosine decay to a tenth)",
    Values::Real32,
    Some(Limit::positive(MAX_LR as f64)),
    DefaultValue::Real(1e-3f32 as f64),
);
/// `warmup_steps`.
pub const WARMUP_STEPS: Flag = Flag {
    more: Some(
        "Worth it where the first full-size steps can turn large regions of a channel inside: \
         at `--omega0 30` (with 100 steps every model measured there was stable), and at the \
         default ω₀ on a resliced 4D label map whose planes leave the domain's corners empty, \
         where 20 steps rescued every seed that collapsed (docs/training.md, \"When to change \
         ω₀, and the learning-rate warm-up\").",
    ),
    ..flag(
        "warmup_steps",
        "Steps over which the learning rate ramps up linearly from lr / N to lr (0: none)",
        Values::Whole,
        Some(Limit::count(0, MAX_STEPS)),
        DefaultValue::Whole(0),
    )
};
/// The loss weights' limit.
const LOSS_WEIGHT: Option<Limit> = Some(Limit::non_negative(MAX_WEIGHT as f64));
/// `lambda_orientation`.
pub const LAMBDA_ORIENTATION: Flag = flag(
    "lambda_orientation",
    "λ_n, orientation weight (Eq. 6)",
    Values::Real32,
    LOSS_WEIGHT,
    DefaultValue::Real(0.1f32 as f64),
);
/// `lambda_plane`.
pub const LAMBDA_PLANE: Flag = flag(
    "lambda_plane",
    "λ_d, in-plane SDF weight (Eq. 7)",
    Values::Real32,
    LOSS_WEIGHT,
    DefaultValue::Real(0.1f32 as f64),
);
/// `lambda_regulariser`: measured (lab/notes/training.md), 0.05 let real data and the thin
/// tube overfit between planes; 0.2 is better on both.
pub const LAMBDA_REGULARISER: Flag = flag(
    "lambda_regulariser",
    "λ_r, space-time regulariser weight (Eq. 8)",
    Values::Real32,
    LOSS_WEIGHT,
    DefaultValue::Real(0.2f32 as f64),
);
/// `alpha`.
pub const ALPHA: Flag = flag(
    "alpha",
    "α of exp(−α|f|) (Eq. 8), in normalised units",
    Values::Real32,
    LOSS_WEIGHT,
    DefaultValue::Real(50.0),
);
/// The per-step sample counts' limit.
const SAMPLES: Option<Limit> = Some(Limit::count(1, MAX_SAMPLES_PER_STEP as u64));
/// `contour_samples`. The sample defaults: in the measured sweep of lab/notes/training.md,
/// four times the steps of the 4096-sample batch beat its larger batches at equal wall time
/// (chambers IoU 0.975 against 0.866 in 1.5 min).
pub const CONTOUR_SAMPLES: Flag = flag(
    "contour_samples",
    "Contour points per class per step (up to --budget-classes classes)",
    Values::Whole,
    SAMPLES,
    DefaultValue::Whole(1024),
);
/// `plane_samples`.
pub const PLANE_SAMPLES: Flag = flag(
    "plane_samples",
    "Plane samples per class per step (up to --budget-classes classes)",
    Values::Whole,
    SAMPLES,
    DefaultValue::Whole(1024),
);
/// `budget_classes`.
pub const BUDGET_CLASSES: Flag = flag(
    "budget_classes",
    "With more classes than this, the classes share the contour and plane samples of this \
     many, split by contour length with at least --min-class-samples each, so a step of 41 \
     classes costs about what a step of 3 does (`dynaslice bench`). 64 gives every class its \
     full count",
    Values::Whole,
    Some(Limit::count(1, MAX_CLASSES as u64)),
    DefaultValue::Whole(3),
);
/// `min_class_samples`.
pub const MIN_CLASS_SAMPLES: Flag = flag(
    "min_class_samples",
    "The fewest contour and plane samples of a class when classes share the budget",
    Values::Whole,
    SAMPLES,
    DefaultValue::Whole(64),
);
/// `space_samples`.
pub const SPACE_SAMPLES: Flag = flag(
    "space_samples",
    "Space-time samples per step",
    Values::Whole,
    SAMPLES,
    DefaultValue::Whole(1024),
);
/// `class_weights`.
pub const CLASS_WEIGHTS: Flag = Flag {
    value_name: Some("W1,W2,…"),
    ..flag(
        "class_weights",
        "Per-class weights of the contour and plane terms, one per class in class order (e.g. \
         1,1,4 to favour a small third structure); default all 1",
        Values::Reals32,
        Some(Limit::positive(MAX_WEIGHT as f64)),
        DefaultValue::Unset,
    )
};
/// `checkpoint_minutes` ([`DEFAULT_CHECKPOINT_MINUTES`]).
pub const CHECKPOINT_MINUTES: Flag = flag(
    "checkpoint_minutes",
    "Minutes between checkpoints (0: after every step)",
    Values::Real64,
    Some(Limit::non_negative(MAX_MINUTES)),
    DefaultValue::Real(DEFAULT_CHECKPOINT_MINUTES),
);

/// The loss weights (`dynaslice train`'s and the lab's `results`).
pub const LOSS: [&Flag; 4] = [
    &LAMBDA_ORIENTATION,
    &LAMBDA_PLANE,
    &LAMBDA_REGULARISER,
    &ALPHA,
];
/// The samples each step draws (`dynaslice train`'s and `bench`'s).
pub const SAMPLE_COUNTS: [&Flag; 5] = [
    &CONTOUR_SAMPLES,
    &PLANE_SAMPLES,
    &BUDGET_CLASSES,
    &MIN_CLASS_SAMPLES,
    &SPACE_SAMPLES,
];

/// Every training option, in the help's order.
pub const FLAGS: [&Flag; 27] = [
    &STEPS,
    &MINUTES,
    &SEED,
    &THREADS,
    &RESUME,
    &FORCE,
    &NO_TEMPORAL_CONTROL,
    &NO_PLANE_BAND,
    &MOTION,
    &NO_ORIENTATION,
    &WIDTHS,
    &OMEGA0,
    &INIT_OFFSET,
    &TEMPORAL_FACTOR,
    &LR,
    &WARMUP_STEPS,
    &LAMBDA_ORIENTATION,
    &LAMBDA_PLANE,
    &LAMBDA_REGULARISER,
    &ALPHA,
    &CONTOUR_SAMPLES,
    &PLANE_SAMPLES,
    &BUDGET_CLASSES,
    &MIN_CLASS_SAMPLES,
    &SPACE_SAMPLES,
    &CLASS_WEIGHTS,
    &CHECKPOINT_MINUTES,
];

/// An option's value as a front end hands it over (parsed, not yet checked against its limit).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A switch, on or off.
    Switch(bool),
    /// A whole number.
    Whole(u64),
    /// A real number.
    Real(f64),
    /// Whole numbers.
    Wholes(Vec<u64>),
    /// Real numbers.
    Reals(Vec<f64>),
}

impl Flag {
    /// One value of this option (an item, for lists) parsed from the command line's text and
    /// checked against its limit, with [`Limit::check`]'s words: "out of range; allowed: …".
    pub fn parse_item(&self, text: &str) -> Result<Value, String> {
        let limit = self.limit.unwrap_or(Limit::between(f64::MIN, f64::MAX));
        let text = text.trim();
        match self.values {
            Values::Switch => Err(format!("--{} takes no value", self.long())),
            Values::Whole | Values::Wholes => limit.whole(text).map(Value::Whole),
            Values::Real32 | Values::Real64 | Values::Reals32 => {
                let v = limit.real(text)?;
                if self.values != Values::Real64 {
                    limit.check(v as f32 as f64).map_err(|_| {
                        format!("{text} is not representable as a 32-bit float in range")
                    })?;
                }
                Ok(Value::Real(v))
            }
        }
    }
}

impl Flag {
    /// The option's value from the command line's text: one item, or for lists the
    /// comma-separated items, each parsed and checked by [`Flag::parse_item`]; a switch from
    /// `true` or `false`.
    pub fn parse(&self, text: &str) -> Result<Value, String> {
        let items = || text.split(',').map(|i| self.parse_item(i));
        Ok(match self.values {
            Values::Switch => Value::Switch(
                text.trim()
                    .to_ascii_lowercase()
                    .parse()
                    .map_err(|_| "not true or false".to_string())?,
            ),
            Values::Wholes => Value::Wholes(
                items()
                    .map(|v| match v? {
                        Value::Whole(v) => Ok(v),
                        other => Err(format!("{other:?}")),
                    })
                    .collect::<Result<_, String>>()?,
            ),
            Values::Reals32 => Value::Reals(
                items()
                    .map(|v| match v? {
                        Value::Real(v) => Ok(v),
                        other => Err(format!("{other:?}")),
                    })
                    .collect::<Result<_, String>>()?,
            ),
            _ => self.parse_item(text)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_parse_as_the_command_line_did() {
        assert_eq!(LR.parse_item("0.002"), Ok(Value::Real(0.002)));
        assert_eq!(
            LR.parse_item("-1").unwrap_err(),
            "out of range; allowed: a number > 0 and ≤ 10"
        );
        assert!(LR.parse_item("1e-50").unwrap_err().contains("32-bit"));
        assert!(LR
            .parse_item("NaN")
            .unwrap_err()
            .starts_with("not a finite"));
        assert_eq!(STEPS.parse_item("7"), Ok(Value::Whole(7)));
        let e = STEPS.parse_item("-1").unwrap_err();
        assert!(
            e.starts_with("out of range") && e.contains("from 1 to 10000000"),
            "{e}"
        );
        assert!(STEPS
            .parse_item("1.5")
            .unwrap_err()
            .starts_with("not a whole"));
        assert_eq!(
            SEED.parse_item("18446744073709551615"),
            Ok(Value::Whole(u64::MAX))
        );
        assert_eq!(WIDTHS.parse_item("64"), Ok(Value::Whole(64)));
        assert!(STEPS.help.contains(&format!("Default: {DEFAULT_STEPS}")));
        assert_eq!(WIDTHS.parse("64, 32"), Ok(Value::Wholes(vec![64, 32])));
        assert!(WIDTHS.parse("64,0").unwrap_err().contains("from 1 to"));
        assert_eq!(
            CLASS_WEIGHTS.parse("1.0, 2.5"),
            Ok(Value::Reals(vec![1.0, 2.5]))
        );
        assert_eq!(RESUME.parse("true"), Ok(Value::Switch(true)));
    }
}
