//! `dynaslice-lab torch-step`: our training step against the same step written in PyTorch
//! (lab/pytorch/step.py), in one run, at the same widths and sample counts.
//!
//! For every K it first checks that both compute the same thing: on a small batch at the
//! benchmark's widths, the Rust objective's loss terms and parameter gradient are written to a
//! JSON file and `step.py check` recomputes them with autograd; a disagreement stops the run.
//! Then it alternates `--rounds` times between our step (`dynaslice_train::bench::step`, the
//! trainer's space-time scheme) and PyTorch's (a subprocess), each reporting the median of
//! `--repeats` steps, and prints the median of the rounds. The same-run sgemm peak (the `gemm`
//! crate, as `dynaslice bench`) is measured before every K; both steps' "% of peak" use the
//! FLOPs our step counts (bench.rs), so they compare like for like.
//!
//! Our figure is the loss and gradient only (the trainer's Adam on ~200K parameters adds well
//! under 1 ms); PyTorch's is a whole optimiser step (zero_grad, loss, backward, Adam, clamp).

use anyhow::{anyhow, bail, Context, Result};
use clap::builder::RangedU64ValueParser;
use dynaslice_cli::samples::SampleArgs;
use dynaslice_cli::widths::check_widths;
use dynaslice_core::format::{MAX_CLASSES, MAX_WIDTH};
use dynaslice_core::Layout;
use dynaslice_train::bench::{self, StepReport};
use dynaslice_train::data_sampler::SampleCounts;
use dynaslice_train::loss::{LossWeights, PlaneKind};
use dynaslice_train::network::{Network, OMEGA_0};
use dynaslice_train::objective::{Batch, Objective, SpaceTimeScheme};
use dynaslice_train::trainer::TrainOptions;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Exit status of `step.py check` when the two disagree (see the script).
const DISAGREE: i32 = 3;

/// Arguments of `dynaslice-lab torch-step`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Class counts K to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2,8,41",
          value_parser = RangedU64ValueParser::<usize>::new().range(1..=MAX_CLASSES as u64))]
    pub classes: Vec<usize>,
    /// Widths of the sine layers (the paper's size).
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256",
          value_parser = clap::value_parser!(u32).range(1..=MAX_WIDTH as i64))]
    pub widths: Vec<u32>,
    /// Samples per step, as `dynaslice bench` and `dynaslice train` take them.
    #[command(flatten)]
    pub samples: SampleArgs,
    /// Worker threads of both (PyTorch: `torch.set_num_threads`).
    #[arg(long, default_value_t = 2,
          value_parser = RangedU64ValueParser::<usize>::new().range(1..=1024))]
    pub threads: usize,
    /// Timed steps per measurement (after one warm-up step); the median is kept.
    #[arg(long, default_value_t = 5,
          value_parser = RangedU64ValueParser::<usize>::new().range(1..=1000))]
    pub repeats: usize,
    /// Alternations of ours and PyTorch's measurement per K; the median round is reported.
    #[arg(long, default_value_t = 3,
          value_parser = RangedU64ValueParser::<usize>::new().range(1..=100))]
    pub rounds: usize,
    /// PyTorch's space-time gradients: one backward per channel (loop) or one vmapped backward
    /// of all channels (batched).
    #[arg(long, default_value = "loop", value_parser = ["loop", "batched"])]
    pub torch_grad: String,
    /// Contour, plane and space-time samples of the agreement check's batch, per class.
    #[arg(long, default_value_t = 24,
          value_parser = RangedU64ValueParser::<usize>::new().range(1..=4096))]
    pub check_samples: usize,
    /// Only run the agreement checks (no timing).
    #[arg(long)]
    pub check_only: bool,
    /// Keep each check's input as DIR/check-k<K>.json (otherwise a temporary file, removed).
    #[arg(long)]
    pub keep_checks: Option<PathBuf>,
    /// The Python interpreter (with torch installed).
    #[arg(long, default_value = "python3")]
    pub python: PathBuf,
    /// The PyTorch step script.
    #[arg(long, default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/pytorch/step.py"))]
    pub script: PathBuf,
}

// The two calls into `dynaslice_train::bench`, kept here so a change of its API is one edit.

/// Our step: the trainer's space-time scheme for K, median of `repeats` steps.
fn our_step(a: &Args, k: usize) -> StepReport {
    let scheme = SpaceTimeScheme::cheapest(k);
    bench::step(
        &a.widths,
        k,
        scheme,
        &a.samples.counts(),
        a.threads,
        a.repeats,
        false,
    )
}

/// The benchmark's batch for K classes at `counts` (what [`our_step`] times).
fn bench_batch(k: usize, counts: &SampleCounts, seed: u64) -> Batch {
    bench::random_batch(k, counts, seed)
}

/// Samples of each class in `classes` (class indices below K).
fn per_class(classes: impl Iterator<Item = u32>, k: usize) -> Vec<usize> {
    let mut n = vec![0; k];
    classes.for_each(|c| n[c as usize] += 1);
    n
}

/// One PyTorch measurement (the fields of `step.py time`'s JSON that the table uses).
struct TorchStep {
    seconds: f64,
    params: usize,
    sgemm_gflops: f64,
    version: String,
}

/// Runs `step.py` with `args` and returns its exit status and stdout (stderr is passed on).
fn python(a: &Args, args: &[String]) -> Result<(Option<i32>, String)> {
    let out = Command::new(&a.python)
        .arg(&a.script)
        .args(args)
        .output()
        .with_context(|| format!("running {} {}", a.python.display(), a.script.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() && out.status.code() != Some(DISAGREE) {
        bail!(
            "{} {} {} failed ({}):\n{}",
            a.python.display(),
            a.script.display(),
            args.join(" "),
            out.status,
            stderr.trim_end()
        );
    }
    Ok((out.status.code(), stdout))
}

fn list(v: &[usize]) -> String {
    v.iter().map(usize::to_string).collect::<Vec<_>>().join(",")
}

fn torch_step(a: &Args, k: usize, batch: &Batch) -> Result<TorchStep> {
    let contour = per_class(batch.contour.iter().map(|s| s.class), k);
    let plane = per_class(batch.plane.iter().map(|s| s.class), k);
    let widths: Vec<usize> = a.widths.iter().map(|&w| w as usize).collect();
    let args: Vec<String> = [
        "time",
        "--classes",
        &k.to_string(),
        "--contour",
        &list(&contour),
        "--plane",
        &list(&plane),
        "--space",
        &batch.space_x.len().to_string(),
        "--widths",
        &list(&widths),
        "--threads",
        &a.threads.to_string(),
        "--repeats",
        &a.repeats.to_string(),
        "--warmup",
        "1",
        "--grad",
        &a.torch_grad,
    ]
    .map(String::from)
    .to_vec();
    let (_, stdout) = python(a, &args)?;
    let v: Value = serde_json::from_str(stdout.trim())
        .with_context(|| format!("step.py time printed {stdout:?}"))?;
    let num = |key: &str| {
        v[key]
            .as_f64()
            .ok_or_else(|| anyhow!("step.py time: no number {key:?} in {stdout}"))
    };
    Ok(TorchStep {
        seconds: num("seconds")?,
        params: num("params")? as usize,
        sgemm_gflops: num("sgemm_gflops")?,
        version: v["torch"].as_str().unwrap_or("?").to_string(),
    })
}

/// The agreement check's batch: the benchmark's points with what the benchmark leaves uniform
/// varied, so every branch of the loss is exercised: normals in all in-plane directions (the
/// orientation hinge active on some points, not on others), a third of the plane samples
/// marking an absent class (the one-sided hinge), uneven weights.
fn check_batch(k: usize, samples: usize) -> Batch {
    let counts = SampleCounts {
        contour_per_class: samples,
        plane_per_class: samples,
        space: samples,
        budget_classes: k,
        min_per_class: samples,
    };
    let mut b = bench_batch(k, &counts, 7);
    for (i, n) in b.contour_normal.iter_mut().enumerate() {
        // Golden-angle steps spread the directions evenly.
        let a = i as f32 * 2.399_963;
        *n = [a.cos(), a.sin(), 0.0];
    }
    for (i, s) in b.contour.iter_mut().enumerate() {
        s.weight *= 0.5 + (i % 4) as f32 * 0.25;
    }
    for (i, s) in b.plane.iter_mut().enumerate() {
        s.weight *= 0.5 + (i % 3) as f32 * 0.5;
        if i % 3 == 0 {
            s.kind = PlaneKind::Absent;
            s.target = 0.05;
        } else {
            s.target = 0.3 * (i as f32 * 0.7).sin();
        }
    }
    b
}

/// Our loss terms and gradient at `net` on `batch`, as the JSON `step.py check` reads.
fn check_input(net: &Network, batch: &Batch, weights: &LossWeights) -> Value {
    let k = net.layout.num_classes();
    let max_set = batch
        .contour_x
        .len()
        .max(batch.plane_x.len())
        .max(batch.space_x.len());
    // One worker: the reference sums in one fixed order.
    let mut objective = Objective::with_scheme(net, 1, max_set, SpaceTimeScheme::cheapest(k));
    let mut grad = vec![0.0; net.params.len()];
    let t = objective.evaluate(net, batch, weights, &mut grad);
    json!({
        "widths": net.layout.widths(),
        "classes": k,
        "weights": {
            "orientation": weights.orientation,
            "plane": weights.plane,
            "regulariser": weights.regulariser,
            "alpha": weights.alpha,
        },
        "params": net.params,
        "batch": {
            "contour_x": batch.contour_x,
            "contour_normal": batch.contour_normal,
            "contour_class": batch.contour.iter().map(|s| s.class).collect::<Vec<_>>(),
            "contour_weight": batch.contour.iter().map(|s| s.weight).collect::<Vec<_>>(),
            "plane_x": batch.plane_x,
            "plane_class": batch.plane.iter().map(|s| s.class).collect::<Vec<_>>(),
            "plane_target": batch.plane.iter().map(|s| s.target).collect::<Vec<_>>(),
            "plane_absent": batch.plane.iter().map(|s| s.kind == PlaneKind::Absent).collect::<Vec<_>>(),
            "plane_weight": batch.plane.iter().map(|s| s.weight).collect::<Vec<_>>(),
            "space_x": batch.space_x,
        },
        "expected": {
            "terms": {
                "surface": t.surface,
                "orientation": t.orientation,
                "plane": t.plane,
                "eikonal": t.eikonal,
                "spurious": t.spurious,
                "total": t.total(weights),
            },
            "gradient": grad,
        },
    })
}

/// Writes K's check input to `path` and runs `step.py check` on it; errors on disagreement.
fn check(a: &Args, k: usize, path: &Path) -> Result<String> {
    let layout = Layout::new(&a.widths, k as u32).map_err(|e| anyhow!("layout: {e:?}"))?;
    // SIREN's ω₀ = 30, as the benchmark's network, and the trainer's outward offset, so f has
    // both signs and sizes on the batch.
    let net = Network::siren(layout, OMEGA_0, 0.2, 10.0, 3);
    let input = check_input(
        &net,
        &check_batch(k, a.check_samples),
        &TrainOptions::default().loss,
    );
    std::fs::write(path, serde_json::to_vec(&input)?)
        .with_context(|| format!("writing {}", path.display()))?;
    let args: Vec<String> = [
        "check",
        &path.to_string_lossy(),
        "--grad",
        &a.torch_grad,
        "--threads",
        &a.threads.to_string(),
    ]
    .map(String::from)
    .to_vec();
    let (status, stdout) = python(a, &args)?;
    let v: Value = serde_json::from_str(stdout.trim())
        .with_context(|| format!("step.py check printed {stdout:?}"))?;
    let summary = format!(
        "K = {k}: worst loss term {:.1e} relative, gradient {:.1e} (relative L2)",
        v["relative_errors"].as_object().map_or(f64::NAN, |e| e
            .values()
            .filter_map(Value::as_f64)
            .fold(0.0, f64::max)),
        v["gradient_relative_l2"].as_f64().unwrap_or(f64::NAN)
    );
    if status == Some(DISAGREE) {
        bail!("PyTorch and the trainer disagree ({summary}): {stdout}");
    }
    Ok(summary)
}

/// Median of a non-empty list.
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Runs `dynaslice-lab torch-step`: the checks, then the table on stdout (progress on stderr).
pub fn run(a: Args) -> Result<()> {
    check_widths(&a.widths)?;
    if a.classes.is_empty() {
        bail!("--classes: give at least one class count");
    }
    // Removed when dropped, at the end of the run, unless the checks are kept.
    let temp = tempfile::tempdir().context("creating a temporary folder")?;
    let dir = match &a.keep_checks {
        Some(d) => {
            std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
            d.as_path()
        }
        None => temp.path(),
    };
    for &k in &a.classes {
        let summary = check(&a, k, &dir.join(format!("check-k{k}.json")))?;
        eprintln!("agreement check, widths {:?}: {summary}", a.widths);
    }
    if a.check_only {
        return Ok(());
    }

    let counts = a.samples.counts();
    println!(
        "training step, widths {:?}, {}; {} threads; medians of {} rounds of {} steps",
        a.widths,
        counts.describe(),
        a.threads,
        a.rounds,
        a.repeats
    );
    println!();
    println!(
        "| K | samples | scheme | params | ours s/step | torch s/step | torch/ours | ours % peak \
         | torch % peak | sgemm peak GFLOP/s | torch sgemm GFLOP/s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut version = String::new();
    for &k in &a.classes {
        let peak = bench::sgemm_peak(a.threads, a.repeats.max(3)).all;
        let batch = bench_batch(k, &counts, 2);
        let (mut ours, mut torch, mut torch_sgemm) = (Vec::new(), Vec::new(), Vec::new());
        let mut flops = 0.0;
        let mut report = None;
        for round in 0..a.rounds {
            let r = our_step(&a, k);
            let t = torch_step(&a, k, &batch)?;
            if t.params != r.params {
                bail!(
                    "PyTorch's network has {} parameters, ours {}",
                    t.params,
                    r.params
                );
            }
            eprintln!(
                "K = {k}, round {}: ours {:.4} s, torch {:.4} s (peak {peak:.1} GFLOP/s)",
                round + 1,
                r.seconds,
                t.seconds
            );
            // The step's work as bench.rs counts it (the same in every round).
            flops = r.gflops * r.seconds * 1e9;
            ours.push(r.seconds);
            torch.push(t.seconds);
            torch_sgemm.push(t.sgemm_gflops);
            version = t.version;
            report = Some(r);
        }
        let r = report.expect("at least one round");
        let (ours, torch) = (median(ours), median(torch));
        println!(
            "| {k} | {}+{}+{} | {:?} | {} | {ours:.4} | {torch:.4} | {:.2} | {:.0} % | {:.0} % | {peak:.1} | {:.1} |",
            batch.contour_x.len(),
            batch.plane_x.len(),
            batch.space_x.len(),
            r.scheme,
            r.params,
            torch / ours,
            100.0 * flops / ours / 1e9 / peak,
            100.0 * flops / torch / 1e9 / peak,
            median(torch_sgemm),
        );
    }
    println!();
    println!("PyTorch {version}, `step.py --grad {}`", a.torch_grad);
    Ok(())
}
