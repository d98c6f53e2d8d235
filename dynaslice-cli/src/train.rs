//! `dynaslice train INPUT -o MODEL.dsm`: fit a 4D multi-class SIREN to cross-sections.
//!
//! Flags and presentation over [`dynaslice_train::job`]: the training flags are made from the
//! table of options (`dynaslice_train::flags`) and map onto a [`TrainSpec`], the input flags
//! onto an `InputSpec` (Python's `dynaslice.train` maps its keywords onto the same two); the job
//! does the rest. Here the run is shown with a progress bar (or log lines off a terminal) and
//! stopped cleanly by Ctrl-C.

use super::console::errln;
use super::input::InputArgs;
use super::options::flag_args;
use super::progress::{Progress as Bar, QUIET};
use anyhow::{bail, Result};
use dynaslice_figures::plot::loss_curve;
use dynaslice_train::fit::Observer;
use dynaslice_train::flags::FLAGS;
use dynaslice_train::job::{self, Finished, Job, Words};
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::trainer::Progress;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `dynaslice train`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Beside MODEL.dsm the run writes MODEL.dsm.loss.csv (one row per step) and MODEL.dsm.loss.png.
While it goes it keeps a checkpoint MODEL.dsm.ckpt with its loss rows MODEL.dsm.ckpt.loss.csv;
a finished run removes both, an interrupted one keeps them. Ctrl-C (or SIGTERM, SIGHUP) stops
after the current step, saves the checkpoint and prints the command that continues the run
(--resume); before the first step (reading, tracing, indexing) it ends the run at once, with
nothing trained or written. A run that would replace an existing model or discard an existing checkpoint needs
--force; the loss rows of a run killed before its first checkpoint do not.")]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output model file (.dsm); the loss log (.loss.csv), loss curve (.loss.png) and checkpoint
    /// (.ckpt) are written beside it.
    #[arg(short, long, value_name = "MODEL.dsm")]
    output: PathBuf,
    #[command(flatten)]
    options: TrainArgs,
}

flag_args!(
    /// Every training option, made from the table of options (`dynaslice_train::flags`).
    TrainArgs,
    FLAGS
);

/// The command that continues this run: the process's own command line with `--resume`,
/// quoted for a POSIX shell.
fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    if args.get(1).map(String::as_str) != Some("train") {
        // Run from `dynaslice demo`: its own command line is not a train command.
        return "the same `dynaslice train` command with --resume".into();
    }
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    shlex::try_join(args.iter().map(String::as_str)).unwrap_or_else(|_| args.join(" "))
}

/// Runs `dynaslice train`: the job ([`job::run`]) with a progress bar (or log lines off a
/// terminal), stopped cleanly by Ctrl-C, SIGTERM or SIGHUP.
pub fn run(a: Args) -> Result<()> {
    let spec = a.options.apply(TrainSpec::default());
    let input = a.input.spec();
    let job = Job::new(&input, &spec, &a.output, Words::COMMAND_LINE, loss_curve);
    // SIGINT, SIGTERM and SIGHUP end the run at once until its first step (nothing to save),
    // then stop it after a step, with a checkpoint (`Console::training`).
    let before = super::signals::before_training();
    let mut console = Console::new();
    let finished = job::run(&job, &mut console);
    drop((console, before));
    let finished = finished?;
    if finished.trained.stopped {
        bail!(
            "{}",
            finished.interrupted(&format!("\n  {}", resume_command()))
        );
    }
    let Finished { files, trained, .. } = finished;
    errln!(
        "wrote {} after {} steps in {:.1} s ({} bytes); loss log {}, curve {}",
        files.model.display(),
        trained.steps_done,
        trained.elapsed.as_secs_f64(),
        trained.bytes.len(),
        files.csv.display(),
        files.png.display()
    );
    Ok(())
}

/// The run on the terminal: a progress bar there, a log line every [`QUIET`] elsewhere; Ctrl-C
/// stops it.
struct Console {
    bar: Option<ProgressBar>,
    /// From the first step on: a signal stops the run after a step, with a checkpoint.
    graceful: Option<super::signals::Graceful>,
    last_log: Instant,
    /// The index of exact in-plane distances, built before the first step.
    indexing: Option<Bar>,
    /// The check of the classes' extents after training.
    checking: Option<Bar>,
}

impl Console {
    fn new() -> Console {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(0);
            bar.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:30}] {pos}/{len} {per_sec} ETA {eta} {msg}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar
        });
        Console {
            bar,
            graceful: None,
            last_log: Instant::now(),
            indexing: None,
            checking: None,
        }
    }
}

impl Drop for Console {
    fn drop(&mut self) {
        if let Some(bar) = &self.bar {
            bar.finish();
        }
    }
}

impl Observer for Console {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        match &self.bar {
            Some(bar) => {
                // A timed run's length is known once planned, and moves when re-planned.
                bar.set_length(p.steps);
                bar.set_position(p.step);
                bar.set_message(p.to_string());
            }
            None if self.last_log.elapsed() >= QUIET || p.step == p.steps => {
                errln!("step {}/{} {:.1} s {p}", p.step, p.steps, p.elapsed);
                self.last_log = Instant::now();
            }
            None => {}
        }
        if super::signals::stop_requested() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn training(&mut self) {
        self.graceful = Some(super::signals::graceful());
    }

    fn note(&mut self, line: &str) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => errln!("{line}"),
        }
    }

    fn indexing(&mut self, done: usize, total: usize) {
        let bar = self.indexing.get_or_insert_with(|| {
            Bar::new("building the sampling index: annotation", total as u64)
        });
        bar.set_position(done as u64);
        if done == total {
            if let Some(bar) = self.indexing.take() {
                bar.finish();
            }
        }
    }

    fn checking(&mut self, done: usize, total: usize) {
        self.checking
            .get_or_insert_with(|| {
                Bar::new(
                    "checking the classes' extents against their contours: time",
                    total as u64,
                )
            })
            .set_position(done as u64)
    }

    fn warning(&mut self, line: &str) {
        // The check is over: its bar goes before the warnings are printed.
        if let Some(p) = self.checking.take() {
            p.finish();
        }
        log::warn!("{line}");
    }
}
