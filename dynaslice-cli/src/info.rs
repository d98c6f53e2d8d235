//! `dynaslice info MODEL`.

use super::console::outln;
use super::input::{self, InputArgs};
use super::progress::Progress;
use anyhow::{Context, Result};
use dynaslice_metrics::extent;
use dynaslice_model::{describe, ModelFile};
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

/// Runs `dynaslice info`: prints the model's description ([`describe`]: size, layer widths,
/// cost per point, world bounds, time range and ω_t^max or that it is static, classes with
/// their source labels, metadata), then the extent check.
pub fn run(args: Args) -> Result<()> {
    let file = ModelFile::open(&args.model)?;
    outln!("model        {}", args.model.display())?;
    for line in describe(&file.model(), file.len()) {
        outln!("{line}")?;
    }
    check_extents(&args, &file)
}

/// The extent check ([`dynaslice_metrics::extent::check`]): each class's surfaces against its
/// contours in the input where given, and against the model's domain; the warnings on standard
/// error, a summary line on standard output.
fn check_extents(args: &Args, file: &ModelFile) -> Result<()> {
    let model = file.model();
    let seq = if args.input.given.inputs.is_empty() {
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
