//! `dynaslice train INPUT -o MODEL.dsm`: fit a 4D multi-class SIREN to cross-sections.
//!
//! An adapter over [`dynaslice_train::fit`]: the flags map onto a [`TrainSpec`] and an
//! [`dynaslice_data::input_spec::InputSpec`] (the Python package's `dynaslice.train` maps its keywords onto the same two),
//! the outputs are checked ([`dynaslice_output::Plan`]) and the existing checkpoint's fate decided
//! ([`RunFiles::check_state`]) before the input is read, and the run is shown with a progress
//! bar (or log lines off a terminal) and stopped cleanly by Ctrl-C.

use super::console::errln;
use super::input::InputArgs;
use super::loss::LossArgs;
use super::options::{count, f32_in, non_negative_f64_to, positive_f32, positive_f64_to};
use super::progress::Progress as Bar;
use super::samples::SampleArgs;
use anyhow::{anyhow, bail, Result};
use dynaslice_core::format::MAX_WIDTH;
use dynaslice_figures::plot::loss_curve;
use dynaslice_output::{Kind, Plan};
use dynaslice_train::fit::{fit, InputRecord, Observer, RunFiles};
use dynaslice_train::journal::TERM_NAMES;
use dynaslice_train::spec::{
    TrainSpec, DEFAULT_CHECKPOINT_MINUTES, MAX_LR, MAX_MINUTES, MAX_OFFSET, MAX_OMEGA_0, MAX_STEPS,
    MAX_TEMPORAL_FACTOR, MAX_THREADS, MAX_WEIGHT,
};
use dynaslice_train::temporal_bound::DEFAULT_TEMPORAL_FACTOR;
use dynaslice_train::trainer::{Progress, TrainOptions};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `dynaslice train`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Beside MODEL.dsm the run writes MODEL.dsm.loss.csv (one row per step) and MODEL.dsm.loss.png.
While it goes it keeps a checkpoint MODEL.dsm.ckpt with its loss rows MODEL.dsm.ckpt.loss.csv;
a finished run removes both, an interrupted one keeps them. Ctrl-C (or SIGTERM, SIGHUP) stops
after the current step, saves the checkpoint and prints the command that continues the run
(--resume). A run that would replace an existing model or discard an existing checkpoint needs
--force; the loss rows of a run killed before its first checkpoint do not.")]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output model file (.dsm); the loss log (.loss.csv), loss curve (.loss.png) and checkpoint
    /// (.ckpt) are written beside it.
    #[arg(short, long, value_name = "MODEL.dsm")]
    output: PathBuf,
    /// Optimisation steps (the learning-rate schedule spans them). Default: 3000, or with
    /// --minutes as many as fit in the time (at most this many when given).
    #[arg(long, value_parser = count(1, MAX_STEPS))]
    steps: Option<u64>,
    /// Train for this many minutes: the step time is measured on the first steps and the
    /// learning-rate schedule planned to end, at its lowest rate, when the time is up; as the
    /// machine's speed changes the rest of the schedule is re-planned (the plan is recorded in
    /// the checkpoint, which a resumed run follows, and the model's metadata).
    #[arg(long, value_parser = positive_f64_to(MAX_MINUTES), allow_negative_numbers = true)]
    minutes: Option<f64>,
    /// Seed of initialisation and sampling.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (results are reproducible for a given count).
    #[arg(long, default_value_t = TrainOptions::default().threads,
          value_parser = count(1, MAX_THREADS))]
    threads: usize,
    /// Continue from the checkpoint beside the output, if there is one.
    #[arg(long)]
    resume: bool,
    /// Replace an existing model file, and without --resume discard an existing checkpoint.
    #[arg(long)]
    force: bool,
    /// Ablation: no temporal band limit (ω_t unclamped, initialised like ω_x).
    #[arg(long)]
    no_temporal_control: bool,
    /// Ablation: no orientation loss (λ_n = 0).
    #[arg(long)]
    no_orientation: bool,
    /// Widths of the sine layers.
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256",
          value_parser = count(1, MAX_WIDTH as u32))]
    widths: Vec<u32>,
    /// ω₀: the first layer's spatial frequency scale over the normalised cube.
    ///
    /// The default suits sparse planes, moving structures, small structures beside large ones
    /// (a 17 mm tumour beside the lungs, missed at 10) and thin parts (fingers); smooth shapes
    /// cut by 15 planes may fit 0.01 IoU better at 10. Densely sliced static anatomy
    /// (many planes, several orientations) fits finer at 30: held-out 2D IoU 0.94 against
    /// 0.87–0.91 on the TotalSegmentator CT. At 30 add `--warmup-steps 100`: without it,
    /// models measured there collapsed into spurious insides in some seeds. 15-plane `.csl`
    /// inputs and the moving synthetic chambers lose at 30 (docs/training.md, "When to change
    /// ω₀").
    #[arg(long, default_value_t = TrainOptions::default().omega_0,
          value_parser = positive_f32(MAX_OMEGA_0), allow_negative_numbers = true)]
    omega0: f32,
    /// Initial value of every channel in normalised units (the domain's half-width is 1): the
    /// network starts "outside" everywhere, so regions no data reaches stay background
    #[arg(long, default_value_t = TrainOptions::default().offset,
          value_parser = f32_in(-MAX_OFFSET, MAX_OFFSET), allow_negative_numbers = true)]
    init_offset: f32,
    /// c in ω_t^max = c·π/Δt (Eq. 4), Δt the annotated frames' spacing in normalised time.
    #[arg(long, default_value_t = DEFAULT_TEMPORAL_FACTOR,
          value_parser = positive_f32(MAX_TEMPORAL_FACTOR), allow_negative_numbers = true)]
    temporal_factor: f32,
    /// Initial learning rate (cosine decay to a tenth).
    #[arg(long, default_value_t = TrainOptions::default().lr, value_parser = positive_f32(MAX_LR),
          allow_negative_numbers = true)]
    lr: f32,
    /// Steps over which the learning rate ramps up linearly from lr / N to lr (0: none).
    ///
    /// Worth it at `--omega0 30`, where the first full-size steps can turn large regions of a
    /// channel inside: with 100 steps and the default `--init-offset` every model measured
    /// there was stable (docs/training.md, "When to change ω₀, and the learning-rate
    /// warm-up"). At the default ω₀ it is not needed.
    #[arg(long, default_value_t = TrainOptions::default().warmup_steps,
          value_parser = count(0, MAX_STEPS))]
    warmup_steps: u64,
    #[command(flatten)]
    loss: LossArgs,
    #[command(flatten)]
    samples: SampleArgs,
    /// Per-class weights of the contour and plane terms, one per class in class order (e.g.
    /// 1,1,4 to favour a small third structure); default all 1.
    #[arg(long, value_delimiter = ',', value_name = "W1,W2,…",
          value_parser = positive_f32(MAX_WEIGHT), allow_negative_numbers = true)]
    class_weights: Option<Vec<f32>>,
    /// Minutes between checkpoints (0: after every step).
    #[arg(long, default_value_t = DEFAULT_CHECKPOINT_MINUTES, value_parser = non_negative_f64_to(MAX_MINUTES),
          allow_negative_numbers = true)]
    checkpoint_minutes: f64,
}

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

impl Args {
    /// The flags as the one training specification.
    fn spec(&self) -> TrainSpec {
        TrainSpec {
            steps: self.steps,
            minutes: self.minutes,
            seed: Some(self.seed),
            threads: Some(self.threads),
            no_temporal_control: self.no_temporal_control,
            no_orientation: self.no_orientation,
            widths: Some(self.widths.clone()),
            omega0: Some(self.omega0),
            init_offset: Some(self.init_offset),
            temporal_factor: Some(self.temporal_factor),
            lr: Some(self.lr),
            warmup_steps: Some(self.warmup_steps),
            class_weights: self.class_weights.clone(),
            checkpoint_minutes: Some(self.checkpoint_minutes),
            resume: self.resume,
            force: self.force,
            ..self.samples.apply(self.loss.apply(TrainSpec::default()))
        }
    }
}

/// Runs `dynaslice train`: checks the options, the outputs and the checkpoint, reads the
/// input, trains ([`fit`]), then writes the model file and its loss log and curve.
pub fn run(a: Args) -> Result<()> {
    let spec = a.spec();
    spec.validate()?;
    let files = RunFiles::beside(&a.output);
    let inputs = a.input.inputs.iter().chain(&a.input.label_names);
    // Held for the whole run: every file below is claimed, so a second run on the same -o
    // refuses and what is on disk comes from one run.
    let mut plan = Plan::new(inputs, a.force);
    plan.file("-o", &files.model, Kind::Model)?;
    plan.beside(&files.csv)?;
    plan.beside(&files.png)?;
    // The run's state may exist: a checkpoint to resume (or, with --force, to replace).
    plan.continued(&files.checkpoint)?;
    plan.continued(&files.journal)?;
    files.check_state(&spec)?;
    if a.resume && !files.checkpoint.exists() {
        errln!(
            "--resume: no checkpoint at {}; starting at step 0",
            files.checkpoint.display()
        );
    }
    let input = a.input.spec();
    errln!("reading {}", input.describe());
    let seq = input.read()?;
    let (space, units) = input.space()?;
    let record = InputRecord {
        description: input.describe(),
        frames: input.frames().to_string(),
        reading: input.reading(),
        space,
        units,
    };
    // SIGINT, SIGTERM and SIGHUP stop the run after this step, with a checkpoint.
    let graceful = super::signals::graceful();
    let mut console = Console::new();
    let trained = fit(&seq, &spec, &record, Some(&files), &mut console);
    drop(graceful);
    console.finish();
    let trained = trained?;
    if trained.stopped {
        bail!(
            "interrupted at step {} of {}: checkpoint {} saved, no model written; continue \
             with\n  {}",
            trained.steps_done,
            trained.schedule_steps,
            files.checkpoint.display(),
            resume_command()
        );
    }
    trained.write(&files)?;
    let rows: Vec<(u64, &[f64])> = trained.rows.iter().map(|r| (r.0, &r.1[..])).collect();
    loss_curve(&files.png, &TERM_NAMES, &rows)?;
    // Outputs that contradict the data are reported: a class reaching far past its contours,
    // or far larger than they allow (dynaslice info MODEL INPUT repeats the check).
    let model = trained.bytes.model().map_err(|e| anyhow!("{e}"))?;
    let mut progress: Option<Bar> = None;
    let warnings = dynaslice_metrics::extent::check_model(&model, &seq, |done, total| {
        progress
            .get_or_insert_with(|| {
                Bar::new(
                    "checking the classes' extents against their contours: time",
                    total as u64,
                )
            })
            .set_position(done as u64)
    })?;
    if let Some(p) = progress {
        p.finish();
    }
    for w in warnings {
        log::warn!("{}: {w}", files.model.display());
    }
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

/// The run on the terminal: a progress bar there, a log line every 5 s elsewhere; Ctrl-C
/// stops it.
struct Console {
    bar: Option<ProgressBar>,
    last_log: Instant,
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
            last_log: Instant::now(),
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish();
        }
    }
}

/// One step's losses for the user.
fn report(p: &Progress) -> String {
    let t = &p.terms;
    format!(
        "loss {:.4e} (surface {:.3e}, orientation {:.3e}, plane {:.3e}, eikonal {:.3e}, spurious {:.3e}) lr {:.2e}",
        p.loss, t.surface, t.orientation, t.plane, t.eikonal, t.spurious, p.lr
    )
}

impl Observer for Console {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        match &self.bar {
            Some(bar) => {
                // A timed run's length is known once planned, and moves when re-planned.
                bar.set_length(p.steps);
                bar.set_position(p.step);
                bar.set_message(report(p));
            }
            None if self.last_log.elapsed() >= Duration::from_secs(5) || p.step == p.steps => {
                errln!(
                    "step {}/{} {:.1} s {}",
                    p.step,
                    p.steps,
                    p.elapsed,
                    report(p)
                );
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

    fn note(&mut self, line: &str) {
        match &self.bar {
            Some(bar) => bar.println(line),
            None => errln!("{line}"),
        }
    }
}
