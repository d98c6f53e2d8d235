//! The input options every command that reads cross-sections shares, and reading them through
//! [`dynaslice_data::input`]. The options are not written here one by one: [`InputArgs`] makes
//! clap arguments of the rows of the library's table (`dynaslice_data::input_flags`), each
//! value checked by [`InputSpec::set`], as Python's keywords are, so both refuse the same
//! values in the same words.

use super::progress::Progress;
use super::times::note;
use anyhow::Result;
use clap::{Arg, ArgAction, ArgMatches, Command};
use dynaslice_data::input_flags::{InputFlag, INPUT_FLAGS};
use dynaslice_data::input_spec::InputSpec;
use dynaslice_data::Sequence;
use dynaslice_model::ModelFile;
use dynaslice_train::job::input_as_trained;
use std::path::PathBuf;

/// Options shared by every command that reads cross-sections: the inputs, and the options of
/// the library's table as given (an option not given is `None`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InputArgs {
    /// The inputs and the input options given.
    pub given: InputSpec,
}

/// The help of the positional inputs.
const INPUTS_HELP: &str = "Cross-sections: native JSON (.json), a .csl file, a DICOM RT \
    Structure Set, a sequence manifest (.seq, .cslseq: `<time> <path>` lines of single-timestep \
    inputs), or label maps (.nii, .nii.gz, .nrrd, .nhdr, .seg.nrrd). Several inputs are views \
    of one subject at the same times (e.g. a short-axis stack and long-axis views)";

/// The clap argument of the input option `flag`: its flag, value name, help (with the default
/// as the help shows it) and a parser that checks the value as the library does. The default
/// is shown, not filled in: an option not given stays `None` for the reader's default or the
/// model's record ([`InputArgs::spec_as_trained`]).
fn input_arg(flag: &'static InputFlag) -> Arg {
    let arg = Arg::new(flag.name)
        .long(flag.name)
        .value_name(flag.value_name)
        .help(flag.short_help())
        .value_parser(move |s: &str| {
            InputSpec::default()
                .set(flag.name, s)
                .map(|()| s.to_string())
        });
    let arg = match flag.long {
        Some(_) => arg.long_help(flag.long_help()),
        None => arg,
    };
    match flag.list {
        true => arg.action(ArgAction::Append).value_delimiter(','),
        false => arg.action(ArgAction::Set),
    }
}

impl clap::FromArgMatches for InputArgs {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut given = InputSpec {
            inputs: m
                .get_many::<PathBuf>("inputs")
                .map(|p| p.cloned().collect())
                .unwrap_or_default(),
            ..InputSpec::default()
        };
        for flag in &INPUT_FLAGS {
            let Some(items) = m.get_many::<String>(flag.name) else {
                continue;
            };
            // Each item was checked as it was parsed; a list's items set together.
            let text = items.cloned().collect::<Vec<_>>().join(",");
            given.set(flag.name, &text).map_err(|e| {
                clap::Error::raw(
                    clap::error::ErrorKind::ValueValidation,
                    format!("--{} {text}: {e}", flag.name),
                )
            })?;
        }
        Ok(InputArgs { given })
    }

    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl clap::Args for InputArgs {
    fn augment_args(cmd: Command) -> Command {
        let inputs = Arg::new("inputs")
            .required(true)
            .value_name("INPUT")
            .action(ArgAction::Append)
            .value_parser(clap::value_parser!(PathBuf))
            .help(INPUTS_HELP);
        INPUT_FLAGS
            .iter()
            .fold(cmd.arg(inputs), |cmd, flag| cmd.arg(input_arg(flag)))
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl InputArgs {
    /// The inputs for messages: `a.nii.gz`, or `a.nii.gz + b.nii.gz`.
    pub fn describe(&self) -> String {
        self.given.describe()
    }

    /// These options as the one input specification the front ends share: an option not given
    /// is `None` (the reader's default, or the model's record: [`InputArgs::spec_as_trained`]).
    pub fn spec(&self) -> InputSpec {
        self.given.clone()
    }

    /// [`InputArgs::spec`] with every option not given taken from how `file`'s model read its
    /// input ([`input_as_trained`]); its note, where anything was taken, on standard error.
    pub fn spec_as_trained(&self, file: &ModelFile) -> Result<InputSpec> {
        let (spec, taken) = input_as_trained(self.spec(), file)?;
        if let Some(taken) = taken {
            note(&taken);
        }
        Ok(spec)
    }
}

/// Reads the inputs of `file`'s model as it was trained on them ([`InputArgs::spec_as_trained`]).
pub fn read_as_trained(args: &InputArgs, file: &ModelFile) -> Result<Sequence> {
    let spec = args.spec_as_trained(file)?;
    // Reading and reslicing a label map takes seconds (8 s for a 64³ × 9 map on a loaded
    // 2-core machine): a progress line every few seconds meanwhile, not silence (issue 39).
    let progress = Progress::new(&format!("reading {}: input", spec.describe()), 1);
    let seq = spec.read()?;
    progress.inc();
    progress.finish();
    Ok(seq)
}

#[cfg(test)]
mod tests {
    use crate::Cli;
    use clap::CommandFactory;
    use dynaslice_data::nesting::NestingMode;
    use dynaslice_data::reslice::ResliceOptions;

    /// The defaults the help states are the reader's.
    #[test]
    fn the_help_states_the_readers_defaults() {
        let cli = Cli::command();
        let train = cli.find_subcommand("train").unwrap();
        let help = |name: &str| {
            let arg = train.get_arguments().find(|a| a.get_id() == name).unwrap();
            let long = arg.get_long_help().unwrap_or(arg.get_help().unwrap());
            (arg.get_help().unwrap().to_string(), long.to_string())
        };
        let states = |name: &str, default: String| {
            let (short, long) = help(name);
            let shown = format!("[default: {default}]");
            assert!(short.ends_with(&shown) && long.ends_with(&shown), "{name}");
        };
        let d = ResliceOptions::default();
        states("rotated-planes", d.rotated.to_string());
        states("axial-step", d.axial_step.to_string());
        let options = dynaslice_data::input::InputOptions::default();
        states("planes", options.planes.to_string());
        states("drawn-axes", options.sparse_axes.to_string());
        states("roi-extent", options.roi_extent.to_string());
        states("header-spacing", options.header_spacing.to_string());
        states("nesting", NestingMode::default().to_string());
    }

    /// The options given become the spec, a list's occurrences joined; a value the library
    /// refuses is refused with the library's words.
    #[test]
    fn the_options_given_are_the_spec_and_refused_as_the_library_refuses() {
        use super::InputArgs;
        use clap::{Args, FromArgMatches};
        use dynaslice_data::input_spec::InputSpec;
        let cmd = || InputArgs::augment_args(clap::Command::new("t"));
        let m = cmd()
            .try_get_matches_from([
                "t", "a.nii.gz", "b.nii.gz", "--labels", "1", "--labels", "2,3", "--pixel", "0.5",
                "--planes", "sparse",
            ])
            .unwrap();
        let mut want = InputSpec {
            inputs: vec!["a.nii.gz".into(), "b.nii.gz".into()],
            ..InputSpec::default()
        };
        want.set("labels", "1,2,3").unwrap();
        want.set("pixel", "0.5").unwrap();
        want.set("planes", "sparse").unwrap();
        assert_eq!(InputArgs::from_arg_matches(&m).unwrap().spec(), want);
        for (flag, value) in [
            ("rotated-planes", "100000"),
            ("pixel", "-1"),
            ("axial-step", "1.5"),
            ("labels", "x"),
            ("planes", "flat"),
        ] {
            let library = InputSpec::default().set(flag, value).unwrap_err();
            let e = cmd()
                .try_get_matches_from(["t", "a.nii.gz", &format!("--{flag}={value}")])
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("'{value}'")) && e.contains(&library),
                "{e}"
            );
        }
    }
}
