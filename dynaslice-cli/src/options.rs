//! Value parsers for the command-line options, so that every number is checked when the command
//! line is parsed, before any file is read: a bad value ends the run at once (exit 2) with clap's
//! `invalid value 'V' for '--option <X>'` followed by the allowed range. The limits are the
//! `MAX_*` constants below and, for training, `dynaslice_train::spec`'s; docs/robustness.md lists which option has which.
//!
//! Use: `#[arg(long, value_parser = count(1usize, MAX_THREADS))]`,
//! `#[arg(long, value_parser = f32_in(-1.0, 1.0))]`.
//!
//! The training options are not written here one by one: [`flag_args!`] makes clap arguments of
//! the rows of `dynaslice_train::flags` (name, help, default, limit), as ripgrep keeps one
//! `Flag` per option.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::{Arg, ArgAction, ArgMatches, Command};
use dynaslice_data::TimeSeries;
use dynaslice_train::flags::{Flag, Value, Values};
use dynaslice_train::spec::{Limit, TrainSpec};
pub use dynaslice_train::spec::{MAX_MINUTES, MAX_STEPS, MAX_THREADS};
use std::fmt::Display;
use std::str::FromStr;

/// Lattice cells along the longest axis of a meshing grid (`mesh`, `eval`).
pub const MAX_MESH_RESOLUTION: u32 = 2048;
/// Cells per axis of the 3D IoU grid of `eval synthetic`.
pub const MAX_IOU_RESOLUTION: usize = 1024;
/// Area-uniform samples per surface for the Chamfer distance.
pub const MAX_CHAMFER_SAMPLES: usize = 10_000_000;
/// Times of an `A:B:N` series (`mesh --times`, `labels --times`, `eval volume --times`).
pub const MAX_TIMES: usize = 10_000;
/// Newton steps per mesh vertex.
pub const MAX_NEWTON_STEPS: u32 = 100;
/// Pixels along the longer side of a plane in `eval heldout`.
pub const MAX_PIXELS: usize = 16_384;
/// Timesteps of the synthetic benchmark.
pub const MAX_SYNTH_TIMESTEPS: usize = 1000;
/// Rotated or parallel planes per training timestep of the synthetic benchmark.
pub const MAX_SYNTH_PLANES: usize = 1000;
/// Grid points per axis contouring a synthetic plane.
pub const MAX_PLANE_RESOLUTION: usize = 4096;
/// Voxels per axis of the synthetic ground-truth volume.
pub const MAX_VOLUME_RESOLUTION: usize = 1024;
/// The safety factor of the mesher's distance bound.
pub const MAX_SAFETY: f32 = 1000.0;
/// Timed repetitions of `bench`.
pub const MAX_REPEATS: usize = 1000;

/// The error text of a value outside its range: clap prefixes it with the option and the value.
fn outside(what: &str, range: &str) -> String {
    format!("{what}; allowed: {range}")
}

/// A finite number in `lo..=hi` (`lo` excluded where `open`), parsed as f64; the range and its
/// words are [`Limit`]'s, which the training options' checks in Python share.
fn real(s: &str, lo: f64, open: bool, hi: f64) -> Result<f64, String> {
    let limit = match (open, lo) {
        (true, _) => Limit::positive(hi),
        (false, 0.0) => Limit::non_negative(hi),
        (false, _) => Limit::between(lo, hi),
    };
    debug_assert!(!open || lo == 0.0, "open ranges start at 0");
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| outside("not a number", &limit.allowed()))?;
    limit.check(v)
}

/// The same as an f32: a value that rounds to infinity or (for `open` at 0) to zero is refused.
fn real_f32(s: &str, lo: f64, open: bool, hi: f64) -> Result<f32, String> {
    let v = real(s, lo, open, hi)? as f32;
    if !v.is_finite() || (open && v as f64 <= lo) {
        return Err(format!(
            "{s} is not representable as a 32-bit float in range"
        ));
    }
    Ok(v)
}

/// Any finite f64.
pub fn finite_f64(s: &str) -> Result<f64, String> {
    real(s, f64::NEG_INFINITY, false, f64::INFINITY)
}

/// Any finite f32 (world coordinates and times of a model, which stores them as f32).
pub fn finite_f32(s: &str) -> Result<f32, String> {
    real_f32(s, f64::NEG_INFINITY, false, f64::INFINITY)
}

/// A finite f64 > 0 (voxel sizes).
pub fn positive_f64(s: &str) -> Result<f64, String> {
    real(s, 0.0, true, f64::INFINITY)
}

/// A finite f64 in (0, `hi`].
pub fn positive_f64_to(hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s| real(s, 0.0, true, hi)
}

/// A finite f64 in [0, `hi`].
pub fn non_negative_f64_to(hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s| real(s, 0.0, false, hi)
}

/// A finite f64 in [`lo`, `hi`].
pub fn f64_in(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync {
    move |s| real(s, lo, false, hi)
}

/// A finite f32 in [`lo`, `hi`].
pub fn f32_in(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    move |s| real_f32(s, f64::from(lo), false, f64::from(hi))
}

/// A whole number in `lo..=hi` (counts, sizes, indices).
pub fn count<T>(lo: T, hi: T) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync
where
    T: FromStr + PartialOrd + Display + Copy + Send + Sync,
{
    move |s| {
        let range = format!("a whole number from {lo} to {hi}");
        let v: T = s.trim().parse().map_err(|_| {
            // `-1` or `99999999999999999999` is a whole number, only outside what `T` holds.
            let digits = s.trim();
            let digits = digits.strip_prefix(['-', '+']).unwrap_or(digits);
            let whole = !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit());
            outside(
                if whole {
                    "out of range"
                } else {
                    "not a whole number"
                },
                &range,
            )
        })?;
        if v < lo || v > hi {
            return Err(outside("out of range", &range));
        }
        Ok(v)
    }
}

/// Lets the values of every option and positional argument of `cmd` and of its subcommands, at
/// every level, be negative numbers: without it clap takes `--threads -1` for the unknown flag
/// `-1` ("unexpected argument '-1' found"), so the value parser, which names the option and the
/// allowed range, never sees it (and `--x -5` needed `--x=-5`). Other values starting with `-`
/// are still options. Applied once, to the whole command line, by the `Cli` in lib.rs
/// (`#[command(mut_subcommands(options::negative_numbers))]`).
pub fn negative_numbers(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|arg| {
        if arg.get_action().takes_values() {
            arg.allow_negative_numbers(true)
        } else {
            arg
        }
    })
    .mut_subcommands(negative_numbers)
}

/// One of a library enum's values (`all`), by the name and help the library gives each, so the
/// command line keeps no copy of the enum: `value_parser = choice(&Side::ALL, Side::name,
/// Side::help)`. `--help` lists the names with their help, as for a `ValueEnum`.
pub fn choice<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
    help: fn(T) -> &'static str,
) -> impl TypedValueParser<Value = T> {
    let values = all
        .iter()
        .map(move |&v| PossibleValue::new(name(v)).help(help(v)));
    PossibleValuesParser::new(values).try_map(move |text| {
        all.iter()
            .copied()
            .find(|&v| name(v) == text)
            .ok_or_else(|| format!("{text}: not one of the possible values"))
    })
}

/// A [`TimeSeries`] (a list `0,0.5,1` or `A:B:N`) of at most `max` times.
pub fn time_series(
    max: usize,
) -> impl Fn(&str) -> Result<TimeSeries, String> + Clone + Send + Sync {
    move |s| {
        let series: TimeSeries = s.parse()?;
        if series.len() > max {
            return Err(outside(
                &format!("{} times", series.len()),
                &format!("at most {max}"),
            ));
        }
        Ok(series)
    }
}

/// The clap argument of the training option `flag`: its flag, value name, help (with the
/// default, as clap shows one) and a parser checking its limit. The default is shown, not
/// filled in: an option not given stays `None` and `TrainSpec` applies its default.
fn flag_arg(flag: &'static Flag) -> Arg {
    // clap keeps `&'static str` names (without its `string` feature): the few made from the
    // table live as long as the process, as the command does.
    let leak = |s: String| -> &'static str { Box::leak(s.into_boxed_str()) };
    let arg = Arg::new(flag.name).long(leak(flag.long()));
    let default = flag.default.to_string();
    let with_default = |text: String| match default.as_str() {
        "" => text,
        d => format!("{text} [default: {d}]"),
    };
    let mut long = flag.help.to_string();
    if let Some(more) = flag.more {
        long = format!("{long}.\n\n{more}");
    }
    if !default.is_empty() {
        long = format!("{long}\n\n[default: {default}]");
    }
    let arg = arg
        .help(with_default(flag.help.to_string()))
        .long_help(long);
    match flag.values {
        Values::Switch => arg.action(ArgAction::SetTrue),
        values => {
            let name = flag
                .value_name
                .unwrap_or_else(|| leak(flag.name.to_uppercase()));
            let arg = arg
                .value_name(name)
                .value_parser(move |s: &str| flag.parse_item(s));
            match values {
                Values::Wholes | Values::Reals32 => {
                    arg.action(ArgAction::Append).value_delimiter(',')
                }
                _ => arg.action(ArgAction::Set),
            }
        }
    }
}

/// The training options given on a command line, by name, as typed values.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Given(Vec<(&'static str, Value)>);

impl Given {
    /// `cmd` with the arguments of `flags`.
    pub fn augment(cmd: Command, flags: &[&'static Flag]) -> Command {
        flags.iter().fold(cmd, |cmd, &f| cmd.arg(flag_arg(f)))
    }

    /// The options of `flags` that `m` holds.
    pub fn of(m: &ArgMatches, flags: &[&'static Flag]) -> Given {
        let mut given = Vec::new();
        for &f in flags {
            let value = match f.values {
                Values::Switch if m.get_flag(f.name) => Value::Switch(true),
                Values::Switch => continue,
                Values::Wholes | Values::Reals32 => {
                    let Some(items) = m.get_many::<Value>(f.name) else {
                        continue;
                    };
                    let items: Vec<Value> = items.cloned().collect();
                    if f.values == Values::Wholes {
                        Value::Wholes(items.iter().filter_map(whole_of).collect())
                    } else {
                        Value::Reals(items.iter().filter_map(real_of).collect())
                    }
                }
                _ => match m.get_one::<Value>(f.name) {
                    Some(v) => v.clone(),
                    None => continue,
                },
            };
            given.push((f.name, value));
        }
        Given(given)
    }

    /// `spec` with these options set.
    pub fn apply(&self, mut spec: TrainSpec) -> TrainSpec {
        for (name, value) in &self.0 {
            // The parser made each value of its flag's kind.
            spec.set(name, value.clone())
                .expect("a table flag takes its own kind of value");
        }
        spec
    }
}

fn whole_of(v: &Value) -> Option<u64> {
    match *v {
        Value::Whole(v) => Some(v),
        _ => None,
    }
}

fn real_of(v: &Value) -> Option<f64> {
    match *v {
        Value::Real(v) => Some(v),
        _ => None,
    }
}

/// A clap `Args` struct of some rows of the training options' table (`$flags`, an array of
/// `&'static Flag`), holding what the command line gave ([`Given`]); `apply` sets it on a
/// `TrainSpec`.
macro_rules! flag_args {
    ($(#[$doc:meta])* $name:ident, $flags:expr) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Default, PartialEq)]
        pub struct $name(pub $crate::options::Given);

        impl $name {
            /// `spec` with the options given set.
            pub fn apply(
                &self,
                spec: dynaslice_train::spec::TrainSpec,
            ) -> dynaslice_train::spec::TrainSpec {
                self.0.apply(spec)
            }
        }

        impl clap::FromArgMatches for $name {
            fn from_arg_matches(m: &clap::ArgMatches) -> Result<Self, clap::Error> {
                Ok($name($crate::options::Given::of(m, &$flags)))
            }
            fn update_from_arg_matches(&mut self, m: &clap::ArgMatches) -> Result<(), clap::Error> {
                *self = Self::from_arg_matches(m)?;
                Ok(())
            }
        }

        impl clap::Args for $name {
            fn augment_args(cmd: clap::Command) -> clap::Command {
                $crate::options::Given::augment(cmd, &$flags)
            }
            fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
                Self::augment_args(cmd)
            }
        }
    };
}
pub(crate) use flag_args;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_are_finite_and_in_range() {
        assert_eq!(finite_f64("-2.5"), Ok(-2.5));
        for bad in ["NaN", "nan", "inf", "-inf", "1e400", "x", ""] {
            assert!(finite_f64(bad).is_err(), "{bad}");
        }
        assert!(finite_f32("1e39").unwrap_err().contains("32-bit"));
        let p = |s| real_f32(s, 0.0, true, 10.0);
        assert_eq!(p("10"), Ok(10.0));
        for bad in ["0", "-1", "10.5", "1e-50", "NaN"] {
            assert!(p(bad).is_err(), "{bad}");
        }
        let e = p("0").unwrap_err();
        assert!(e.contains("> 0") && e.contains("10"), "{e}");
        assert_eq!(real_f32("0", 0.0, false, 1.0), Ok(0.0));
        assert!(real_f32("-0.1", 0.0, false, 1.0).is_err());
        assert!(positive_f64("0").is_err() && positive_f64("1e-300").is_ok());
    }

    #[test]
    fn counts_are_whole_and_bounded() {
        let c = count(1usize, 1024);
        assert_eq!(c("1024"), Ok(1024));
        for bad in ["0", "1025", "-1", "1.5", "4e9", "100000", "", "-", "x1"] {
            assert!(c(bad).is_err(), "{bad}");
        }
        assert!(c("0").unwrap_err().contains("from 1 to 1024"));
        // Whole numbers that the type cannot hold are out of range, not "not whole".
        for (s, what) in [
            ("-1", "out of range"),
            ("99999999999999999999999", "out of range"),
            ("1.5", "not a whole number"),
            ("-x", "not a whole number"),
            ("--5", "not a whole number"),
        ] {
            let e = c(s).unwrap_err();
            assert!(
                e.starts_with(what) && e.contains("from 1 to 1024"),
                "{s}: {e}"
            );
        }
    }

    #[test]
    fn time_series_count_is_bounded() {
        let t = time_series(100);
        assert!(t("0:1:100").is_ok());
        assert!(t("0:1:101").unwrap_err().contains("at most 100"));
        let list = (0..101)
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(",");
        assert!(t(&list).unwrap_err().contains("101 times"));
        assert!(t("0:NaN:3").is_err());
    }
}
