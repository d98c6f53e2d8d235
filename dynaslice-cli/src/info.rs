//! `dynaslice info MODEL`.

use super::console::outln;
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
    outln!("model        {}", args.model.display())?;
    outln!(
        "size         {} bytes ({} weights, {dtype})",
        file.len(),
        layout.param_count()
    )?;
    outln!("sine layers  {:?}", layout.widths())?;
    outln!("classes      {}", layout.num_classes())?;
    outln!(
        "cost         {} multiply-adds per point for f (x4 with ∇ₓf)",
        layout.macs_per_point()
    )?;
    outln!(
        "bounds       [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2]
    )?;
    outln!("time range   {t0} .. {t1}")?;
    outln!("ω_t^max      {} (normalised time)", model.omega_t_max())?;
    for (k, class) in model.classes().enumerate() {
        outln!(
            "class {:<6} {:?} (source label {})",
            k + 1,
            class.name,
            class.label
        )?;
    }
    if !model.metadata().is_empty() {
        outln!("metadata")?;
        for line in model.metadata().lines() {
            outln!("  {line}")?;
        }
    }
    Ok(())
}
