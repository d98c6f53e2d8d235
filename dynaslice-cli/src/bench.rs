//! `dynaslice bench`: training-step throughput against this machine's sgemm peak.

use super::console::outln;
use super::options::{count, MAX_REPEATS, MAX_THREADS};
use super::samples::SampleArgs;
use super::widths::check_widths;
use anyhow::{bail, Result};
use dynaslice_core::format::{MAX_CLASSES, MAX_WIDTH};
use dynaslice_train::bench::{self, StepRow};

/// Arguments of `dynaslice bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Widths of the sine layers (the paper's size: 4 layers of 256, ~200K parameters).
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256",
          value_parser = count(1, MAX_WIDTH as u32))]
    widths: Vec<u32>,
    /// Class counts to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,3,8,41",
          value_parser = count(1, MAX_CLASSES))]
    classes: Vec<usize>,
    #[command(flatten)]
    samples: SampleArgs,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = count(1, MAX_THREADS))]
    threads: usize,
    /// Timed repetitions (the median is reported).
    #[arg(long, default_value_t = 7, value_parser = count(1, MAX_REPEATS))]
    repeats: usize,
}

/// Times both space-time schemes for every K; the trainer uses the cheaper by FLOP count
/// (`SpaceTimeScheme::cheapest`), marked `*`. "hinge": the contour points whose orientation
/// term was active, whose tangent backward therefore ran. "× K=3": the step time of the
/// trainer's scheme over that of K = 3 (or of the first K given, without 3), measured in the
/// same run.
pub fn run(a: Args) -> Result<()> {
    check_widths(&a.widths)?;
    if a.classes.is_empty() {
        bail!("--classes: give at least one class count");
    }
    let counts = a.samples.counts();
    let peak = bench::sgemm_peak(a.threads, a.repeats);
    outln!(
        "sgemm peak (gemm crate, 1024³): {:.1} GFLOP/s on 1 thread, {:.1} on {} threads",
        peak.single,
        peak.all,
        a.threads
    )?;
    outln!(
        "training step, widths {:?}, {}; {} threads:",
        a.widths,
        counts.describe(),
        a.threads
    )?;
    let base_k = bench::base_classes(&a.classes).expect("checked above");
    outln!(
        "{:>3} {:>13} {:>25} {:>9} {:>10} {:>12} {:>9} {:>8} {:>7} {:>7}",
        "K",
        "samples",
        "space-time scheme",
        "params",
        "s/step",
        "points/s",
        "GFLOP/s",
        "of peak",
        "hinge",
        format!("× K={base_k}")
    )?;
    let rows = bench::step_table(&a.widths, &a.classes, &counts, a.threads, a.repeats);
    for StepRow {
        report: r,
        chosen,
        ratio,
    } in rows
    {
        let mark = if chosen { "*" } else { " " };
        let ratio = ratio.map_or(String::new(), |ratio| format!("{ratio:.2}"));
        let k = r.num_classes;
        outln!(
            "{:>3} {:>13} {:>24}{mark} {:>9} {:>10.4} {:>12.0} {:>9.1} {:>7.1}% {:>6.0}% {:>7}",
            r.num_classes,
            format!(
                "{}+{}+{}",
                counts.total(counts.contour_per_class, k),
                counts.total(counts.plane_per_class, k),
                counts.space
            ),
            format!("{:?} ({}M)", r.scheme, r.scheme.cost(k)),
            r.params,
            r.seconds,
            r.points_per_second,
            r.gflops,
            100.0 * r.gflops / peak.all,
            100.0 * r.active_contour,
            ratio
        )?;
    }
    outln!(
        "a moving input's motion model (f = g(x + u(x, t), t), u {:?}), the trainer's scheme:",
        dynaslice_train::warp::MOTION_WIDTHS
    )?;
    outln!(
        "{:>3} {:>16} {:>16} {:>9}",
        "K",
        "s/step (shape)",
        "s/step (motion)",
        "× shape"
    )?;
    for row in bench::motion_table(&a.widths, &a.classes, &counts, a.threads, a.repeats) {
        outln!(
            "{:>3} {:>16.4} {:>16.4} {:>9.2}",
            row.shape.num_classes,
            row.shape.seconds,
            row.motion.seconds,
            row.motion.seconds / row.shape.seconds
        )?;
    }
    Ok(())
}
