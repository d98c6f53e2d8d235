//! The examples each command's `--help` ends with, after what its own help says (`eval`, `man`
//! and `completions` keep theirs beside their own arguments). Every line that starts with `dynaslice` is parsed by the test below with the
//! real command line, so an example can never name a flag or a value the command refuses.

/// `dynaslice demo`.
pub const DEMO: &str = "\
Examples:
  dynaslice demo                          # everything into dynaslice-demo/
  dynaslice demo -o demo2 --minutes 5     # a fresh folder; training capped at 5 minutes";

/// `dynaslice bench`.
pub const BENCH: &str = "\
Examples:
  dynaslice bench                                   # the default network, both cores
  dynaslice bench --widths 128,128,128 --classes 8 --threads 1";

/// `dynaslice info`.
pub const INFO: &str = "\
Examples:
  dynaslice info heart.dsm                          # classes, bounds, time range, training
  dynaslice info heart.dsm labels.nii.gz            # and warnings against the input's contours";

/// `dynaslice train`.
pub const TRAIN: &str = "\
Examples:
  dynaslice train labels.nii.gz -o heart.dsm                  # a label map over time
  dynaslice train phases.seq -o ct.dsm --minutes 10           # RT Structure Sets per phase
  dynaslice train sa.nii.gz la2ch.nii.gz la4ch.nii.gz -o heart.dsm
  dynaslice train drawn.seg.nrrd --planes sparse -o m.dsm     # a few slices drawn in Slicer
  dynaslice train phases.seq -o ct.dsm --minutes 10 --resume  # go on after Ctrl-C";

/// `dynaslice labels`.
pub const LABELS: &str = "\
Examples:
  dynaslice labels heart.dsm --like labels.nii.gz -o heart.seg.nrrd
  dynaslice labels heart.dsm --spacing 1 --times 0:1:10 -o heart.nii.gz";

/// `dynaslice mesh`.
pub const MESH: &str = "\
Examples:
  dynaslice mesh heart.dsm --time 0.5 -o heart.vtp
  dynaslice mesh heart.dsm --times 0:1:10 --format vtp -o meshes   # open meshes/series.pvd
  dynaslice mesh ct.dsm --time 0 --class GTV -o gtv.stl";

/// `dynaslice measure`.
pub const MEASURE: &str = "\
Examples:
  dynaslice measure heart.dsm -o volumes.csv
  dynaslice measure ct.dsm --times 0:3.6:37 --json
  dynaslice measure ct.dsm --itv itv";

/// `dynaslice report`.
pub const REPORT: &str = "\
Examples:
  dynaslice report heart.dsm -o report.html
  dynaslice report ct.dsm --times 0,0.8,1.6 -o report.html";

/// `dynaslice picture`.
pub const PICTURE: &str = "\
Examples:
  dynaslice picture heart.dsm labels.nii.gz -o plane.png
  dynaslice picture --3d heart.dsm --times 0,0.5,1 -o surfaces.png";

/// `dynaslice rtstruct`.
pub const RTSTRUCT: &str = "\
Examples:
  dynaslice rtstruct ct.dsm --like phase0.dcm --ct ct -o rs
  dynaslice rtstruct ct.dsm --like phase0.dcm --like-grid ct.nii.gz --itv -o rs";

/// `dynaslice query`.
pub const QUERY: &str = "\
Examples:
  dynaslice query heart.dsm 10 -20 5 0.5            # RAS mm at t = 0.5";

/// `dynaslice synth`.
pub const SYNTH: &str = "\
Examples:
  dynaslice synth -o synth
  dynaslice synth --shape chambers --timesteps 9 -o chambers";

/// Appends the examples of `cmd` (by name) to what its own `after_help` says; applied to
/// every subcommand by the `Cli` in lib.rs.
pub fn append(cmd: clap::Command) -> clap::Command {
    let examples = match cmd.get_name() {
        "demo" => DEMO,
        "bench" => BENCH,
        "info" => INFO,
        "train" => TRAIN,
        "labels" => LABELS,
        "mesh" => MESH,
        "measure" => MEASURE,
        "report" => REPORT,
        "picture" => PICTURE,
        "rtstruct" => RTSTRUCT,
        "query" => QUERY,
        "synth" => SYNTH,
        // eval, man and completions keep the examples beside their own arguments.
        _ => return cmd,
    };
    let text = match cmd.get_after_help() {
        Some(own) => format!("{own}\n\n{examples}"),
        None => examples.to_string(),
    };
    cmd.after_help(text)
}

#[cfg(test)]
mod tests {
    use crate::Cli;
    use clap::{CommandFactory, Parser};

    /// Every subcommand's help ends with examples, after its own text where it has one, and
    /// every example parses.
    #[test]
    fn every_command_has_examples_that_parse() {
        let cli = Cli::command();
        let mut parsed = 0;
        for sub in cli.get_subcommands() {
            let help = sub
                .get_after_help()
                .map(|h| h.to_string())
                .unwrap_or_default();
            assert!(
                help.contains("Examples:") || help.contains("e.g.:"),
                "`dynaslice {}` has no examples",
                sub.get_name()
            );
            // The examples block (a command's own notes above it may quote command lines
            // with prose after them).
            let examples = help.rsplit("Examples:").next().unwrap_or_default();
            for line in examples.lines().map(str::trim) {
                if !line.starts_with("dynaslice ") {
                    continue;
                }
                // Drop the comment and a shell redirection.
                let line = line.split("  #").next().unwrap();
                let line = line.split(" >").next().unwrap();
                let line = line.split(" |").next().unwrap();
                let words: Vec<&str> = line.split_whitespace().collect();
                if let Err(e) = Cli::try_parse_from(&words) {
                    panic!("example {line:?} does not parse:\n{e}");
                }
                parsed += 1;
            }
        }
        assert!(parsed >= 30, "{parsed} examples");
        // The command's own notes are kept before the examples.
        let mesh = cli.find_subcommand("mesh").unwrap();
        let help = mesh.get_after_help().unwrap().to_string();
        assert!(
            help.starts_with("File names:") && help.contains("Examples:"),
            "{help}"
        );
    }
}
