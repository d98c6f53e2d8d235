//! `dynaslice train INPUT -o MODEL.dsm`: fit a 4D multi-class SIREN to cross-sections.

use super::input::{self, InputArgs};
use super::loss::LossArgs;
use anyhow::{Context, Result};
use dynaslice_data::atomic::write_atomically;
use dynaslice_figures::plot::{line_chart, Series};
use dynaslice_train::data_sampler::{domain_for, DataSampler, SampleCounts};
use dynaslice_train::model_file::TrainedModel;
use dynaslice_train::temporal_bound::{temporal_bound, DEFAULT_TEMPORAL_FACTOR};
use dynaslice_train::trainer::{self, Outcome, Progress, TrainOptions};
use indicatif::{ProgressBar, ProgressStyle};
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Arguments of `dynaslice train`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Output model file (.dsm); the loss log (.loss.csv), loss curve (.loss.png) and checkpoint
    /// (.ckpt) are written beside it.
    #[arg(short, long, value_name = "MODEL.dsm")]
    output: PathBuf,
    /// Optimisation steps (the learning-rate schedule spans them).
    #[arg(long, default_value_t = TrainOptions::default().steps)]
    steps: u64,
    /// Stop after this many minutes even if steps remain.
    #[arg(long)]
    minutes: Option<f64>,
    /// Seed of initialisation and sampling.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads (results are reproducible for a given count).
    #[arg(long, default_value_t = TrainOptions::default().threads)]
    threads: usize,
    /// Continue from the checkpoint beside the output, if there is one.
    #[arg(long)]
    resume: bool,
    /// Ablation: no temporal band limit (ω_t unclamped, initialised like ω_x).
    #[arg(long)]
    no_temporal_control: bool,
    /// Ablation: no orientation loss (λ_n = 0).
    #[arg(long)]
    no_orientation: bool,
    /// Widths of the sine layers.
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256")]
    widths: Vec<u32>,
    /// ω₀: the first layer's spatial frequency scale over the normalised cube.
    ///
    /// The default suits sparse planes and moving structures. Densely sliced static anatomy
    /// (many planes, several orientations) fits finer at 30: held-out 2D IoU 0.94 against
    /// 0.87–0.91 on the TotalSegmentator CT. At 30 add `--warmup-steps 100`: without it,
    /// models measured there collapsed into spurious insides in some seeds. 15-plane `.csl`
    /// inputs and the moving synthetic chambers lose at 30 (docs/training.md, "When to change
    /// ω₀"; the measurements are in lab/notes/training.md).
    #[arg(long, default_value_t = TrainOptions::default().omega_0)]
    omega0: f32,
    /// Initial value of every channel in normalised units (the domain's half-width is 1): the
    /// network starts "outside" everywhere, so regions no data reaches stay background
    #[arg(long, default_value_t = TrainOptions::default().offset)]
    init_offset: f32,
    /// c in ω_t^max = c·π/Δt (Eq. 4), Δt the annotated frames' spacing in normalised time.
    #[arg(long, default_value_t = DEFAULT_TEMPORAL_FACTOR)]
    temporal_factor: f32,
    /// Initial learning rate (cosine decay to a tenth).
    #[arg(long, default_value_t = TrainOptions::default().lr)]
    lr: f32,
    /// Steps over which the learning rate ramps up linearly from lr / N to lr (0: none).
    ///
    /// Worth it at `--omega0 30`, where the first full-size steps can turn large regions of a
    /// channel inside: with 100 steps and the default `--init-offset` every model measured
    /// there was stable (docs/training.md, "When to change ω₀, and the learning-rate warm-up";
    /// the runs are in lab/notes/training.md, "Learning-rate warm-up"). At the default ω₀ it is
    /// not needed.
    #[arg(long, default_value_t = TrainOptions::default().warmup_steps)]
    warmup_steps: u64,
    #[command(flatten)]
    loss: LossArgs,
    /// Contour points per class per step.
    #[arg(long, default_value_t = SampleCounts::default().contour_per_class)]
    contour_samples: usize,
    /// Plane samples per class per step.
    #[arg(long, default_value_t = SampleCounts::default().plane_per_class)]
    plane_samples: usize,
    /// Space-time samples per step.
    #[arg(long, default_value_t = SampleCounts::default().space)]
    space_samples: usize,
    /// Per-class weights of the contour and plane terms, one per class in class order (e.g.
    /// 1,1,4 to favour a small third structure); default all 1.
    #[arg(long, value_delimiter = ',', value_name = "W1,W2,…")]
    class_weights: Option<Vec<f32>>,
    /// Minutes between checkpoints.
    #[arg(long, default_value_t = 2.0)]
    checkpoint_minutes: f64,
}

fn beside(model: &Path, suffix: &str) -> PathBuf {
    let mut s = model.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Runs `dynaslice train`: trains on the input's frames (checkpointing beside the output),
/// then writes the model file atomically and its loss log (`.loss.csv`) and curve (`.loss.png`).
pub fn run(a: Args) -> Result<()> {
    let seq = input::read(&a.input)?;
    let domain = domain_for(&seq);
    let omega_t_max = temporal_bound(&seq, &domain, a.temporal_factor, !a.no_temporal_control);
    let options = TrainOptions {
        widths: a.widths.clone(),
        steps: a.steps,
        time_limit: a.minutes.map(|m| Duration::from_secs_f64(m * 60.0)),
        omega_0: a.omega0,
        offset: a.init_offset,
        seed: a.seed,
        threads: a.threads.max(1),
        lr: a.lr,
        lr_final: a.lr / 10.0,
        warmup_steps: a.warmup_steps,
        loss: a.loss.weights(!a.no_orientation),
        omega_t_max,
        checkpoint: Some(beside(&a.output, ".ckpt")),
        checkpoint_every: Duration::from_secs_f64(a.checkpoint_minutes * 60.0),
        resume: a.resume,
    };
    let counts = SampleCounts {
        contour_per_class: a.contour_samples,
        plane_per_class: a.plane_samples,
        space: a.space_samples,
    };
    let k = seq.classes().len();
    eprintln!(
        "{}: {} classes, {} frames, {} planes; domain centre {:?}, half-width {:.4}, time {}..{}; ω_t^max {}",
        a.input.input.display(),
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
            .map_err(|e| anyhow::anyhow!("--class-weights: {e}"))?;
    }
    let outcome = run_with_progress(&options, k, &mut sampler)?;

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
            a.input.input.display(),
            a.input.frames
        ),
    }
    .to_bytes()
    .map_err(|e| anyhow::anyhow!("cannot write the model: {e}"))?;
    write_atomically(&a.output, &bytes)?;
    write_loss_log(&a.output, &outcome)?;
    eprintln!(
        "wrote {} after {} steps in {:.1} s ({} bytes); loss log {}, curve {}",
        a.output.display(),
        outcome.steps_done,
        outcome.elapsed.as_secs_f64(),
        bytes.len(),
        beside(&a.output, ".loss.csv").display(),
        beside(&a.output, ".loss.png").display()
    );
    Ok(())
}

/// Trains with a progress bar on a terminal, periodic log lines otherwise.
fn run_with_progress(o: &TrainOptions, k: usize, sampler: &mut DataSampler) -> Result<Outcome> {
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
    let mut last_log = Instant::now();
    let report = |p: &Progress| {
        let t = &p.terms;
        format!(
            "loss {:.4e} (surface {:.3e}, orientation {:.3e}, plane {:.3e}, eikonal {:.3e}, spurious {:.3e}) lr {:.2e}",
            p.loss, t.surface, t.orientation, t.plane, t.eikonal, t.spurious, p.lr
        )
    };
    let outcome = trainer::train(o, k, sampler, |p| {
        match &bar {
            Some(bar) => {
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
        ControlFlow::Continue(())
    });
    if let Some(bar) = bar {
        bar.finish();
    }
    outcome.context("training failed")
}

/// The loss terms of every step as CSV and a PNG curve, beside the model.
fn write_loss_log(model: &Path, outcome: &Outcome) -> Result<()> {
    let mut csv = String::from("step,total,surface,orientation,plane,eikonal,spurious\n");
    for (step, t, total) in &outcome.history {
        writeln!(
            csv,
            "{step},{total},{},{},{},{},{}",
            t.surface, t.orientation, t.plane, t.eikonal, t.spurious
        )?;
    }
    write_atomically(&beside(model, ".loss.csv"), csv.as_bytes())?;
    let series = |name, f: &dyn Fn(&dynaslice_train::loss::LossTerms, f64) -> f64| Series {
        name,
        points: outcome
            .history
            .iter()
            .map(|(s, t, total)| (*s as f64, f(t, *total)))
            .collect(),
    };
    let all = [
        series("total", &|_, total| total),
        series("surface |f|", &|t, _| t.surface),
        series("orientation", &|t, _| t.orientation),
        series("plane SDF", &|t, _| t.plane),
        series("eikonal", &|t, _| t.eikonal),
        series("spurious exp(-a|f|)", &|t, _| t.spurious),
    ];
    line_chart(
        &beside(model, ".loss.png"),
        "DynaSlice training loss",
        "step",
        "loss (unweighted terms)",
        &all,
        true,
    )
}
