//! The `dynaslice` command line: one file per subcommand, each a thin layer over the libraries.
//! [`loss`] is the one flag group shared with the lab's `dynaslice-lab results`.

#![warn(missing_docs)]

mod bench;
mod completions;
mod console;
mod demo;
mod eval;
mod examples;
mod info;
mod input;
mod labels;
pub mod loss;
mod man;
mod measure;
mod memory;
mod mesh;
mod options;
mod picture;
mod pool;
mod progress;
mod query;
mod report;
mod rtstruct;
pub mod samples;
mod signals;
mod synth;
mod times;
mod train;
mod warnings;
pub mod widths;

use clap::{Parser, Subcommand};
use console::errln;
use std::process::ExitCode;

/// Reconstruct moving multi-structure 3D surfaces from sparse 2D cross-sections (DynaSlice).
#[derive(Parser, Debug)]
#[command(name = "dynaslice", version, arg_required_else_help = true)]
#[command(mut_subcommands(options::negative_numbers))]
#[command(mut_subcommands(examples::append))]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The main job on built-in data: slice a multi-class synthetic sequence, train, then write
    /// meshes for all 37 frames (ParaView series), a label-volume NIfTI and a figure.
    Demo(demo::Args),
    /// Measure the training step's speed against this machine's sgemm peak.
    Bench(bench::Args),
    /// Accuracy against ground truth or held-out slices, and class volumes over time.
    Eval(eval::Args),
    /// Print a model's dimensions, domain, time range, classes and metadata.
    Info(info::Args),
    /// Fit a 4D multi-class neural SDF to cross-sections and write the model.
    Train(train::Args),
    /// Write a model's Eq. 11 label volume (NIfTI with colour tables, or 3D Slicer .seg.nrrd) on a
    /// reference image's grid or a box.
    Labels(labels::Args),
    /// Extract the classes' surfaces at a time or a series of times as closed meshes.
    Mesh(mesh::Args),
    /// Motion and function per class over the cycle: volumes (mL), centroids, bounding boxes,
    /// stroke volume, ejection fraction, peak-to-peak amplitude (LR/AP/SI), and the ITV.
    Measure(measure::Args),
    /// Write one self-contained HTML report of a model: input, training, classes, motion and
    /// function figures and tables, and its surfaces in 3D.
    Report(report::Args),
    /// Draw a model's labels and the input contours on an input plane at several times, or with
    /// --3d its class surfaces, shaded, at several times (PNG).
    Picture(picture::Args),
    /// Write the model's structures as DICOM RT Structure Sets, one per time, on the planes of a
    /// planning CT or reference image, in an input RT Structure Set's patient and frame.
    Rtstruct(rtstruct::Args),
    /// Evaluate a model at one world point and time: f, ∇ₓf, ∂f/∂t and the Eq. 11 label.
    Query(query::Args),
    /// Write the synthetic 4D benchmark: training slices (native JSON) and ground-truth NIfTI.
    Synth(synth::Args),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions(completions::Args),
    /// Write the manual pages (roff): dynaslice.1 on standard output, or all pages into a folder.
    Man(man::Args),
}

/// Parses the process arguments and runs the chosen subcommand.
pub fn main() -> ExitCode {
    warnings::install();
    signals::install();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if e.use_stderr() => e.exit(),
        // --help and --version: written as any output is, so a full disk is an error and a
        // closed pipe ends quietly (clap's own printing succeeds on both).
        Err(help) => {
            return finish(
                console::out_bytes(help.render().to_string().as_bytes()).map_err(Into::into),
            )
        }
    };
    finish(run(cli.command))
}

/// The process's exit: success, a closed standard output (quietly, as ripgrep does), or the
/// error on one line.
fn finish(result: anyhow::Result<()>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if console::is_closed_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            errln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Runs one subcommand.
fn run(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Demo(args) => demo::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Eval(args) => eval::run(args),
        Command::Info(args) => info::run(args),
        Command::Labels(args) => labels::run(args),
        Command::Mesh(args) => mesh::run(args),
        Command::Measure(args) => measure::run(args),
        Command::Report(args) => report::run(args),
        Command::Picture(args) => picture::run(args),
        Command::Query(args) => query::run(args),
        Command::Rtstruct(args) => rtstruct::run(args),
        Command::Train(args) => train::run(args),
        Command::Synth(args) => synth::run(args),
        Command::Completions(args) => completions::run(args),
        Command::Man(args) => man::run(args),
    }
}

/// Runs the command line `args` (without the program name), echoing it first, as a user would
/// type it: the demo is a script of ordinary subcommands.
fn run_line(args: &[String]) -> anyhow::Result<()> {
    errln!("\n$ dynaslice {}", args.join(" "));
    run(parse_line(args)?.command)
}

/// Parses the command line `args` (without the program name) as `dynaslice` would.
fn parse_line(args: &[String]) -> anyhow::Result<Cli> {
    Cli::try_parse_from(std::iter::once("dynaslice".to_string()).chain(args.iter().cloned()))
        .map_err(|e| {
            // clap's message starts with its own "error: ", which main prints too.
            let message = e.to_string();
            let message = message.strip_prefix("error: ").unwrap_or(&message);
            anyhow::anyhow!("dynaslice {}: {}", args.join(" "), message.trim_end())
        })
}
