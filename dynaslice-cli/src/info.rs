//! `dynaslice info MODEL`.

use super::model::ModelFile;
use anyhow::Result;
use dynaslice_core::Weights;
use std::path::PathBuf;

/// Arguments of `dynaslice info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
}

/// Runs `dynaslice info`: prints the model's size, layer widths, cost per point, world bounds,
/// time range, ω_t^max (normalised time), classes with their source labels, and metadata.
pub fn run(args: Args) -> Result<()> {
    let file = ModelFile::open(&args.model)?;
    let model = file.model();
    let layout = model.layout();
    let d = model.domain();
    let (lo, hi) = d.bounds();
    let (t0, t1) = d.time_range();
    let dtype = match model.weights() {
        Weights::F32(_) => "f32",
        Weights::F16(_) => "f16",
    };
    println!("model        {}", args.model.display());
    println!(
        "size         {} bytes ({} weights, {dtype})",
        file.len(),
        layout.param_count()
    );
    println!("sine layers  {:?}", layout.widths());
    println!("classes      {}", layout.num_classes());
    println!(
        "cost         {} multiply-adds per point for f (x4 with ∇ₓf)",
        layout.macs_per_point()
    );
    println!(
        "bounds       [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
        lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
    );
    println!("time range   {t0} .. {t1}");
    println!("ω_t^max      {} (normalised time)", model.omega_t_max());
    for (k, class) in model.classes().enumerate() {
        println!(
            "class {:<6} {:?} (source label {})",
            k + 1,
            class.name,
            class.label
        );
    }
    if !model.metadata().is_empty() {
        println!("metadata");
        for line in model.metadata().lines() {
            println!("  {line}");
        }
    }
    Ok(())
}
