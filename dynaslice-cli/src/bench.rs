//! `dynaslice bench`: training-step throughput against this machine's sgemm peak.

use super::options::{count, MAX_REPEATS, MAX_SAMPLES_PER_STEP, MAX_THREADS};
use anyhow::{bail, Result};
use dynaslice_core::format::{MAX_CLASSES, MAX_SINE_LAYERS, MAX_WIDTH};
use dynaslice_train::bench;
use dynaslice_train::objective::SpaceTimeScheme;

/// Arguments of `dynaslice bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Widths of the sine layers (the paper's size: 4 layers of 256, ~200K parameters).
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256",
          value_parser = count(1, MAX_WIDTH as u32))]
    widths: Vec<u32>,
    /// Class counts to measure.
    #[arg(long, value_delimiter = ',', default_value = "1,2,8",
          value_parser = count(1, MAX_CLASSES))]
    classes: Vec<usize>,
    /// Contour and plane samples per class.
    #[arg(long, default_value_t = 4096, value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    per_class: usize,
    /// Space-time samples.
    #[arg(long, default_value_t = 4096, value_parser = count(1, MAX_SAMPLES_PER_STEP))]
    space: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 2, value_parser = count(1, MAX_THREADS))]
    threads: usize,
    /// Timed repetitions (the median is reported).
    #[arg(long, default_value_t = 7, value_parser = count(1, MAX_REPEATS))]
    repeats: usize,
}

/// Times both space-time schemes for every K; the trainer uses the cheaper by FLOP count
/// (`SpaceTimeScheme::cheapest`), marked `*`. "hinge": the contour points whose orientation
/// term was active, whose tangent backward therefore ran.
pub fn run(a: Args) -> Result<()> {
    if a.widths.is_empty() || a.widths.len() > MAX_SINE_LAYERS {
        bail!(
            "--widths: {} layers; a model has 1 to {MAX_SINE_LAYERS} sine layers",
            a.widths.len()
        );
    }
    let peak = bench::sgemm_peak(a.threads, a.repeats);
    println!(
        "sgemm peak (gemm crate, 1024³): {:.1} GFLOP/s on 1 thread, {:.1} on {} threads",
        peak.single, peak.all, a.threads
    );
    println!("training step, widths {:?}, {} contour + {} plane samples per class, {} space-time, {} threads:", a.widths, a.per_class, a.per_class, a.space, a.threads);
    println!(
        "{:>3} {:>25} {:>9} {:>10} {:>12} {:>9} {:>8} {:>7}",
        "K", "space-time scheme", "params", "s/step", "points/s", "GFLOP/s", "of peak", "hinge"
    );
    for &k in &a.classes {
        for scheme in [
            SpaceTimeScheme::ReverseOverReverse,
            SpaceTimeScheme::ForwardTangents,
        ] {
            let r = bench::step(
                &a.widths,
                k,
                scheme,
                a.per_class,
                a.space,
                a.threads,
                a.repeats,
            );
            let mark = if scheme == SpaceTimeScheme::cheapest(k) {
                "*"
            } else {
                " "
            };
            println!(
                "{:>3} {:>24}{mark} {:>9} {:>10.4} {:>12.0} {:>9.1} {:>7.1}% {:>6.0}%",
                r.num_classes,
                format!("{:?} ({}M)", scheme, scheme.cost(k)),
                r.params,
                r.seconds,
                r.points_per_second,
                r.gflops,
                100.0 * r.gflops / peak.all,
                100.0 * r.active_contour
            );
        }
    }
    Ok(())
}
