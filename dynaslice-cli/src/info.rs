//! `dynaslice info MODEL`.

use super::console::outln;
use super::input::{self, InputArgs};
use super::progress::Progress;
use anyhow::{Context, Result};
use dynaslice_core::Weights;
use dynaslice_metrics::extent;
use dynaslice_model::ModelFile;
use std::path::PathBuf;

/// Arguments of `dynaslice info`.
#[derive(clap::Args, Debug)]
#[command(
    // The training input is optional: without it the extent check has the model alone.
    mut_arg("inputs", |a| a.required(false)),
    after_help = "\
Extent check: info meshes every class (at a static model's time; a moving model's at up to 5
of the input's frame times, as after training, or without the input 5 times over its range) and
warns of classes the data does not support. With the training input (INPUT…, read with the same
options as when training), the check is training's: each class is compared with its contours: a
surface reaching past their box by more than half its longest side, or a volume over twice the
box's, is reported. Without it, the model holds only its domain (the data's box plus a margin):
a surface touching the domain's edge is reported, as it lies past every plane of the data.")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    #[command(flatten)]
    input: InputArgs,
}

/// Runs `dynaslice info`: prints the model's size, layer widths, cost per point, world bounds,
/// time range and ω_t^max (normalised time) of a moving model (a static one has no time axis),
/// classes with their source labels, and metadata.
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
    if file.is_static() {
        outln!(
            "time         none: a static model (trained on one timestep, ω_t^max = 0), the same \
             at every time; its outputs are one frame, at t = {t0}"
        )?;
    } else {
        outln!("time range   {t0} .. {t1}")?;
        outln!("ω_t^max      {} (normalised time)", model.omega_t_max())?;
    }
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
    check_extents(&args, &file)
}

/// The extent check ([`dynaslice_metrics::extent::check`]): each class's surfaces against its
/// contours in the input where given, and against the model's domain; the warnings on standard
/// error, a summary line on standard output.
fn check_extents(args: &Args, file: &ModelFile) -> Result<()> {
    let model = file.model();
    let seq = if args.input.inputs.is_empty() {
        None
    } else {
        Some(input::read_as_trained(&args.input, file)?)
    };
    let mut progress: Option<Progress> = None;
    let (times, warnings) = extent::check(&model, seq.as_ref(), |done, total| {
        progress
            .get_or_insert_with(|| {
                Progress::new("extent check: meshing the classes, time", total as u64)
            })
            .set_position(done as u64)
    })
    .with_context(|| match &seq {
        Some(_) => format!("{} against {}", args.model.display(), args.input.describe()),
        None => args.model.display().to_string(),
    })?;
    if let Some(p) = progress {
        p.finish();
    }
    for w in &warnings {
        log::warn!("{}: {w}", args.model.display());
    }
    let against = match &seq {
        Some(_) => format!("their contours in {} and the domain", args.input.describe()),
        None => "the model's domain only (give the training input to compare with the \
                 contours)"
            .to_string(),
    };
    let verdict = match warnings.len() {
        0 => "every class within them".to_string(),
        n => format!("{n} warning(s), on standard error"),
    };
    outln!(
        "extents      the classes' surfaces at {} time(s) against {against}: {verdict}",
        times.len()
    )?;
    Ok(())
}
