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
    Results(Box<results::Args>),
    /// Timed training at equal wall time on the synthetic benchmark: the schedule planned to end
    /// at the budget against a `--cap`-step cosine cut off there (markdown rows on stdout).
    Schedule(ScheduleArgs),
    /// One training step against the same step in PyTorch (lab/pytorch/step.py), same run,
    /// same sizes, after checking both compute the same loss and gradient (a markdown table).
    TorchStep(experiments::torch_step::Args),
}

/// Arguments of `dynaslice-lab schedule`.
#[derive(clap::Args, Debug)]
struct ScheduleArgs {
    /// Training wall time per run.
    #[arg(long, default_value_t = 1.0)]
    minutes: f64,
    /// Seeds 0..N.
    #[arg(long, default_value_t = 2)]
    seeds: u64,
    /// The cut-off runs' schedule length (`dynaslice train`'s default `--steps`).
    #[arg(long, default_value_t = 3000)]
    cap: u64,
    /// Shapes (blob, tube, torus, chambers).
    #[arg(long, value_delimiter = ',', default_value = "chambers")]
    shapes: Vec<String>,
    /// Worker threads.
    #[arg(long, default_value_t = std::thread::available_parallelism().map_or(1, |n| n.get()))]
    threads: usize,
}

fn schedule(a: ScheduleArgs) -> anyhow::Result<()> {
    let protocol = experiments::Protocol {
        minutes: a.minutes,
        steps: None,
        spec: dynaslice_train::spec::TrainSpec {
            threads: Some(a.threads.max(1)),
            ..Default::default()
        },
    };
    println!("| shape | schedule | seed | steps / schedule | s | IoU | CD×10⁴ |");
    println!("|---|---|---|---|---|---|---|");
    for name in &a.shapes {
        let shape = dynaslice_synth::Shape::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| anyhow::anyhow!("unknown shape {name:?}"))?;
        for r in experiments::schedule::compare(shape, &protocol, a.seeds, a.cap)? {
            println!("{}", experiments::schedule::row(shape, &r));
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let outcome = match Lab::parse().command {
        Command::Results(args) => results::run(*args),
        Command::Schedule(args) => schedule(args),
        Command::TorchStep(args) => experiments::torch_step::run(args),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
