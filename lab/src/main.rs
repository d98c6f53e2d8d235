//! `dynaslice-lab`: the paper's tables and DynaSlice's experiments, reproduced through the
//! libraries' public API. Not part of the product: its results and notes live in `lab/`.

mod experiments;
mod results;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Reproduce the DynaSlice paper's tables on this machine.
#[derive(Parser, Debug)]
#[command(name = "dynaslice-lab", version, arg_required_else_help = true)]
struct Lab {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Reproduce the paper's tables (Table 3 on the synthetic benchmark, Table 2 on synthetic and
    /// real multi-organ data, static `.csl` reconstructions) as markdown.
    Results(results::Args),
}

fn main() -> ExitCode {
    let outcome = match Lab::parse().command {
        Command::Results(args) => results::run(args),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
