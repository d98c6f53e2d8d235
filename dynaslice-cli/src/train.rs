//! `dynaslice train INPUT -o MODEL.dsm`: fit a 4D multi-class SIREN to cross-sections.
//!
//! Everything that can be checked is checked before the first step: the options (at parse
//! time, [`super::options`]), the outputs ([`super::output`]), an existing checkpoint (kept
//! unless `--resume` or `--force` says what to do with it), and the input's fit to the model
//! format ([`check_model_limits`]). The loss rows of every step go to a log beside the
//! checkpoint as they are made, so a resumed run's loss log starts at step 1.

use super::input::{self, InputArgs};
use super::loss::LossArgs;
use super::options::{
    count, f32_in, non_negative_f64_to, positive_f32, positive_f64_to, MAX_LR, MAX_MINUTES,
    MAX_OMEGA_0, MAX_STEPS, MAX_TEMPORAL_FACTOR, MAX_THREADS, MAX_WEIGHT,
};
use super::output::{Kind, Plan};
use super::samples::SampleArgs;
use super::widths::check_widths;
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::format::MAX_WIDTH;
use dynaslice_data::atomic::write_atomically;
use dynaslice_data::atomic::write_via;
use dynaslice_figures::plot::{line_chart, Series};
use dynaslice_train::data_sampler::{domain_for, DataSampler};
use dynaslice_train::model_file::{check_model_limits, TrainedModel};
use dynaslice_train::temporal_bound::{temporal_bound, DEFAULT_TEMPORAL_FACTOR};
use dynaslice_train::trainer::{self, Outcome, Progress, TrainOptions};
use indicatif::{ProgressBar, ProgressStyle};
use std::fs::File;
use std::io::{BufRead, BufReader, IsTerminal, Read, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// |`--init-offset`| at most, in normalised units (the domain's half-width is 1).
const MAX_OFFSET: f32 = 100.0;

/// Arguments of `dynaslice train`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Beside MODEL.dsm the run writes MODEL.dsm.loss.csv (one row per step), MODEL.dsm.loss.png and a
checkpoint MODEL.dsm.ckpt with its loss rows MODEL.dsm.ckpt.loss.csv. Ctrl-C stops after the
current step, saves the checkpoint and prints the command that continues the run (--resume).
A run that would replace an existing model or discard an existing checkpoint needs --force.")]
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
    /// learning-rate schedule planned to end, at its lowest rate, when the time is up (the
    /// planned steps are recorded in the checkpoint and the model's metadata).
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
    /// The default suits sparse planes and moving structures. Densely sliced static anatomy
    /// (many planes, several orientations) fits finer at 30: held-out 2D IoU 0.94 against
    /// 0.87–0.91 on the TotalSegmentator CT. At 30 add `--warmup-steps 100`: without it,
    /// models measured there collapsed into spurious insides in some seeds. 15-plane `.csl`
    /// inputs and the moving synthetic chambers lose at 30 (docs/training.md, "When to change
    /// ω₀"; the measurements are in lab/notes/training.md).
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
    /// there was stable (docs/training.md, "When to change ω₀, and the learning-rate warm-up";
    /// the runs are in lab/notes/training.md, "Learning-rate warm-up"). At the default ω₀ it is
    /// not needed.
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
    #[arg(long, default_value_t = 2.0, value_parser = non_negative_f64_to(MAX_MINUTES),
          allow_negative_numbers = true)]
    checkpoint_minutes: f64,
}

/// The files of one training run, all beside the model.
struct Files {
    model: PathBuf,
    csv: PathBuf,
    png: PathBuf,
    checkpoint: PathBuf,
    /// The loss rows as they are made (appended every step): what a resumed run's loss log
    /// starts from.
    journal: PathBuf,
}

impl Files {
    fn of(model: &Path) -> Files {
        let beside = |suffix: &str| {
            let mut s = model.as_os_str().to_owned();
            s.push(suffix);
            PathBuf::from(s)
        };
        Files {
            model: model.to_path_buf(),
            csv: beside(".loss.csv"),
            png: beside(".loss.png"),
            checkpoint: beside(".ckpt"),
            journal: beside(".ckpt.loss.csv"),
        }
    }
}

/// Set by Ctrl-C: the run stops after the current step and saves its checkpoint.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler once per process (the demo trains through this module too).
/// A second Ctrl-C ends the process at once.
fn catch_interrupt() {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    INSTALLED.get_or_init(|| {
        let installed = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!(
                "\ninterrupted: stopping after this step to save the checkpoint \
                 (Ctrl-C again to quit without it)"
            );
        });
        if let Err(e) = installed {
            log::warn!("Ctrl-C will end training without a checkpoint: {e}");
        }
    });
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

/// Runs `dynaslice train`: checks the outputs and the input, trains on the input's frames
/// (checkpointing beside the output), then writes the model file and its loss log
/// (`.loss.csv`) and curve (`.loss.png`), each atomically.
pub fn run(a: Args) -> Result<()> {
    check_widths(&a.widths)?;
    let files = Files::of(&a.output);
    let inputs = a.input.inputs.iter().chain(&a.input.label_names);
    let mut plan = Plan::new(inputs, a.force);
    plan.file("-o", &files.model, Kind::Model)?;
    for p in [&files.csv, &files.png, &files.checkpoint, &files.journal] {
        plan.beside(p)?;
    }
    let has_checkpoint = files.checkpoint.exists();
    if has_checkpoint && !a.resume && !a.force {
        bail!(
            "{} holds the checkpoint of an earlier run; add --resume to continue it, or \
             --force to start afresh and replace it",
            files.checkpoint.display()
        );
    }
    if a.resume && !has_checkpoint {
        eprintln!(
            "--resume: no checkpoint at {}; starting at step 0",
            files.checkpoint.display()
        );
    }

    let seq = input::read(&a.input)?;
    let domain = domain_for(&seq);
    check_model_limits(seq.classes(), &domain)
        .map_err(|e| anyhow!("{}: {e}", a.input.describe()))?;
    let omega_t_max = temporal_bound(&seq, &domain, a.temporal_factor, !a.no_temporal_control);
    let options = TrainOptions {
        widths: a.widths.clone(),
        steps: match (a.steps, a.minutes) {
            (Some(steps), _) => steps,
            // The plan sets the schedule's length; the cap only bounds it.
            (None, Some(_)) => MAX_STEPS,
            (None, None) => TrainOptions::default().steps,
        },
        // Both in range of `Duration` by their value parsers.
        time_limit: a.minutes.map(|m| Duration::from_secs_f64(m * 60.0)),
        omega_0: a.omega0,
        offset: a.init_offset,
        seed: a.seed,
        threads: a.threads,
        lr: a.lr,
        lr_final: a.lr / 10.0,
        warmup_steps: a.warmup_steps,
        loss: a.loss.weights(!a.no_orientation),
        omega_t_max,
        checkpoint: Some(files.checkpoint.clone()),
        checkpoint_every: Duration::from_secs_f64(a.checkpoint_minutes * 60.0),
        resume: a.resume,
    };
    let counts = a.samples.counts();
    let k = seq.classes().len();
    eprintln!(
        "{}: {} classes, {} frames, {} planes; domain centre {:?}, half-width {:.4}, time {}..{}; ω_t^max {}",
        a.input.describe(),
        k,
        seq.frames().len(),
        seq.frames().iter().map(|f| f.planes.len()).sum::<usize>(),
        domain.center,
        domain.scale[0],
        domain.time_origin,
        domain.time_origin + domain.time_span,
        omega_t_max
    );
    let mut sampler = DataSampler::new(&seq, domain, counts);
    if let Some(w) = &a.class_weights {
        sampler = sampler
            .with_class_weights(w)
            .map_err(|e| anyhow!("--class-weights: {e}"))?;
    }
    let earlier = if a.resume && has_checkpoint {
        read_journal(&files.journal)?
    } else {
        Vec::new()
    };
    catch_interrupt();
    let (outcome, rows) = run_with_progress(&options, k, &mut sampler, &files, earlier)?;
    if INTERRUPTED.load(Ordering::SeqCst) {
        bail!(
            "interrupted at step {} of {}: checkpoint {} saved, no model written; continue \
             with\n  {}",
            outcome.steps_done,
            outcome.planned_steps.unwrap_or(options.steps),
            files.checkpoint.display(),
            resume_command()
        );
    }
    if outcome.steps_done == 0 {
        bail!(
            "no training step finished within --minutes {}; no model written",
            a.minutes.unwrap_or_default()
        );
    }

    let bytes = TrainedModel {
        outcome: &outcome,
        domain,
        classes: seq.classes(),
        options: &options,
        counts,
        temporal_factor: a.temporal_factor,
        class_weights: a.class_weights.as_deref(),
        input: &format!(
            "input = {}\nframes = {}",
            a.input.describe(),
            a.input.frames
        ),
    }
    .to_bytes()
    .map_err(|e| anyhow!("cannot write the model: {e}"))?;
    write_atomically(&files.model, &bytes)?;
    write_loss_log(&files, &rows)?;
    eprintln!(
        "wrote {} after {} steps in {:.1} s ({} bytes); loss log {}, curve {}",
        files.model.display(),
        outcome.steps_done,
        outcome.elapsed.as_secs_f64(),
        bytes.len(),
        files.csv.display(),
        files.png.display()
    );
    Ok(())
}

/// The loss log's header; a row is the step then these values.
const CSV_HEADER: &str = "step,total,surface,orientation,plane,eikonal,spurious";

/// One step's losses: the step, then total, surface, orientation, plane, eikonal, spurious.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Row(u64, [f64; 6]);

impl Row {
    fn of(step: u64, t: &dynaslice_train::loss::LossTerms, total: f64) -> Row {
        Row(
            step,
            [
                total,
                t.surface,
                t.orientation,
                t.plane,
                t.eikonal,
                t.spurious,
            ],
        )
    }

    /// The CSV line (f64 `Display` is the shortest exact form, so [`Row::parse`] restores it).
    fn line(&self) -> String {
        let v = self.1;
        format!(
            "{},{},{},{},{},{},{}\n",
            self.0, v[0], v[1], v[2], v[3], v[4], v[5]
        )
    }

    fn parse(line: &str) -> Option<Row> {
        let mut it = line.trim().split(',');
        let step = it.next()?.parse().ok()?;
        let mut v = [0.0; 6];
        for x in &mut v {
            *x = it.next()?.parse().ok()?;
        }
        it.next().is_none().then_some(Row(step, v))
    }
}

/// The rows of the journal beside a checkpoint, in step order (none if it is missing). A
/// torn last line (a kill mid-write) is dropped; the file's size is bounded first.
fn read_journal(path: &Path) -> Result<Vec<Row>> {
    let Ok(file) = File::open(path) else {
        return Ok(Vec::new());
    };
    // The longest line is 20 digits and six f64s of at most 24 characters, plus commas.
    let max = (MAX_STEPS + 1) * 180;
    let mut rows = Vec::new();
    let reader = BufReader::new(file.take(max));
    for line in reader.lines().skip(1) {
        let line = line.with_context(|| format!("cannot read {}", path.display()))?;
        match Row::parse(&line) {
            Some(r) if rows.last().is_none_or(|l: &Row| l.0 < r.0) => rows.push(r),
            _ => break,
        }
    }
    Ok(rows)
}

/// The journal as the run goes: rewritten at the first step with the rows the checkpoint
/// covers, then one row appended (and flushed) per step.
struct Journal {
    path: PathBuf,
    file: Option<File>,
    earlier: Vec<Row>,
    rows: Vec<Row>,
    error: Option<anyhow::Error>,
}

impl Journal {
    /// Records the row of `p`, the first of this process at `p.step`.
    fn record(&mut self, row: Row, resumed_from: impl FnOnce(u64)) -> Result<()> {
        if self.file.is_none() {
            let start = row.0 - 1;
            self.rows = self.earlier.drain(..).filter(|r| r.0 <= start).collect();
            if start > 0 {
                resumed_from(start);
                if self.rows.len() as u64 != start {
                    log::warn!(
                        "{}: loss rows of {} of the checkpoint's {start} steps; the loss log \
                         lacks the others",
                        self.path.display(),
                        self.rows.len()
                    );
                }
            }
            let mut text = format!("{CSV_HEADER}\n");
            self.rows.iter().for_each(|r| text += &r.line());
            write_atomically(&self.path, text.as_bytes())?;
            let file = std::fs::OpenOptions::new()
                .append(true)
                .open(&self.path)
                .with_context(|| format!("cannot append to {}", self.path.display()))?;
            self.file = Some(file);
        }
        if let Some(file) = &mut self.file {
            file.write_all(row.line().as_bytes())
                .with_context(|| format!("cannot write {}", self.path.display()))?;
        }
        self.rows.push(row);
        Ok(())
    }
}

/// Trains with a progress bar on a terminal, periodic log lines otherwise; returns the outcome
/// and the loss rows from step 1 (the `earlier` journal rows the checkpoint covers, then this
/// run's).
fn run_with_progress(
    o: &TrainOptions,
    k: usize,
    sampler: &mut DataSampler,
    files: &Files,
    earlier: Vec<Row>,
) -> Result<(Outcome, Vec<Row>)> {
    let terminal = std::io::stderr().is_terminal();
    let bar = terminal.then(|| {
        let bar = ProgressBar::new(o.steps);
        bar.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:30}] {pos}/{len} {per_sec} ETA {eta} {msg}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    });
    let mut journal = Journal {
        path: files.journal.clone(),
        file: None,
        rows: Vec::new(),
        earlier,
        error: None,
    };
    let mut last_log = Instant::now();
    let report = |p: &Progress| {
        let t = &p.terms;
        format!(
            "loss {:.4e} (surface {:.3e}, orientation {:.3e}, plane {:.3e}, eikonal {:.3e}, spurious {:.3e}) lr {:.2e}",
            p.loss, t.surface, t.orientation, t.plane, t.eikonal, t.spurious, p.lr
        )
    };
    let checkpoint = files.checkpoint.display().to_string();
    let outcome = trainer::train(o, k, sampler, |p| {
        let row = Row::of(p.step, &p.terms, p.loss);
        let resumed = |step| {
            let line = format!("resumed from {checkpoint} at step {step} of {}", p.steps);
            match &bar {
                Some(bar) => bar.println(line),
                None => eprintln!("{line}"),
            }
        };
        if let Err(e) = journal.record(row, resumed) {
            journal.error = Some(e);
            return ControlFlow::Break(());
        }
        match &bar {
            Some(bar) => {
                // A timed run's length is known once planned.
                bar.set_length(p.steps);
                bar.set_position(p.step);
                bar.set_message(report(p));
            }
            None if last_log.elapsed() >= Duration::from_secs(10) || p.step == p.steps => {
                eprintln!(
                    "step {}/{} {:.1} s {}",
                    p.step,
                    p.steps,
                    p.elapsed,
                    report(p)
                );
                last_log = Instant::now();
            }
            None => {}
        }
        if INTERRUPTED.load(Ordering::SeqCst) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    if let Some(bar) = bar {
        bar.finish();
    }
    let outcome = outcome.context("training failed")?;
    if let Some(e) = journal.error {
        return Err(e.context("the loss log failed; the checkpoint is saved"));
    }
    if outcome.history.is_empty() && outcome.steps_done > 0 {
        // Resumed from a checkpoint that already held every step: no step ran here.
        eprintln!(
            "{} already holds all {} steps",
            files.checkpoint.display(),
            outcome.steps_done
        );
        journal.rows = journal
            .earlier
            .into_iter()
            .filter(|r| r.0 <= outcome.steps_done)
            .collect();
    }
    Ok((outcome, journal.rows))
}

/// The loss terms of every step as CSV and a PNG curve, beside the model, each atomically.
fn write_loss_log(files: &Files, rows: &[Row]) -> Result<()> {
    let mut csv = format!("{CSV_HEADER}\n");
    rows.iter().for_each(|r| csv += &r.line());
    write_atomically(&files.csv, csv.as_bytes())?;
    let names = [
        "total",
        "surface |f|",
        "orientation",
        "plane SDF",
        "eikonal",
        "spurious exp(-a|f|)",
    ];
    let all: Vec<Series> = names
        .iter()
        .enumerate()
        .map(|(i, &name)| Series {
            name,
            points: rows.iter().map(|r| (r.0 as f64, r.1[i])).collect(),
        })
        .collect();
    write_via(&files.png, |tmp| {
        line_chart(
            tmp,
            "DynaSlice training loss",
            "step",
            "loss (unweighted terms)",
            &all,
            true,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_torn_lines_end_the_journal() {
        let r = Row(3, [0.1, 1e-30, 0.0, 2.5, 1.0 / 3.0, 7.0]);
        assert_eq!(Row::parse(&r.line()), Some(r));
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j.csv");
        let text = format!(
            "{CSV_HEADER}\n{}{}4,0.5,1",
            Row(1, r.1).line(),
            Row(2, r.1).line()
        );
        std::fs::write(&path, text).unwrap();
        let rows = read_journal(&path).unwrap();
        assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [1, 2]);
        assert!(read_journal(&dir.path().join("none")).unwrap().is_empty());
    }
}
