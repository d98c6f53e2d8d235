//! `dynaslice eval split` and `eval heldout`: a split's training input, and a model's 2D IoU on
//! the slices the split withheld.

use super::fmt;
use crate::console::{errln, outln};
use crate::input::{self, InputArgs};
use crate::memory::{self, MemoryArgs};
use crate::options::{count, MAX_PIXELS};
use anyhow::{anyhow, Context, Result};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_metrics::heldout::{self, Split, DEFAULT_PIXELS};
use dynaslice_model::ModelFile;
use dynaslice_output::write_atomically;
use dynaslice_output::{Kind, Plan};
use dynaslice_sequence::native;
use dynaslice_train::data_sampler::domain_for;
use dynaslice_train::model_file::check_model_limits;
use std::path::PathBuf;

/// Which frames and planes a split withholds.
#[derive(clap::Args, Debug, Clone)]
pub(super) struct Holdout {
    /// Frames withheld from training (indices of the full input), A:B:STEP.
    #[arg(long, value_name = "A:B:STEP")]
    holdout_frames: Option<FrameRange>,
    /// Planes withheld from training (indices within each frame), A:B:STEP.
    #[arg(long, value_name = "A:B:STEP")]
    holdout_planes: Option<FrameRange>,
}

impl Holdout {
    fn split(&self) -> Split {
        Split {
            frames: self.holdout_frames,
            planes: self.holdout_planes,
        }
    }
}

#[derive(clap::Args, Debug)]
pub(super) struct HeldoutArgs {
    /// Model file (.dsm), trained on `dynaslice eval split`'s output for the same split.
    model: PathBuf,
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    holdout: Holdout,
    /// Pixels along the longer side of each plane's region of interest.
    #[arg(long, default_value_t = DEFAULT_PIXELS, value_parser = count(2, MAX_PIXELS))]
    pixels: usize,
    #[command(flatten)]
    memory: MemoryArgs,
}

#[derive(clap::Args, Debug)]
pub(super) struct SplitArgs {
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    holdout: Holdout,
    /// Output training input (.json).
    #[arg(short, long)]
    output: PathBuf,
    /// Replace an existing file.
    #[arg(long)]
    force: bool,
}

/// Runs `dynaslice eval heldout`.
pub(super) fn held_out(a: HeldoutArgs) -> Result<()> {
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    // One row of points, times and labels (20 bytes a pixel) per worker thread.
    let threads = rayon::current_num_threads() as f64;
    memory::check(
        &format!("--pixels {}", a.pixels),
        a.pixels as f64 * 20.0 * threads,
        "lower --pixels",
        a.memory,
    )?;
    let seq = input::read_as_trained(&a.input, &file)?;
    let split = a.holdout.split();
    let scores = heldout::held_out(&model, &seq, &split, a.pixels)
        .with_context(|| format!("{} on {}", a.model.display(), a.input.describe()))?;
    let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    outln!(
        "2D IoU on withheld slices ({} pixels along each region's longer side)",
        a.pixels
    )?;
    outln!("| | planes | mean | {} |", names.join(" | "))?;
    outln!("|---|---|---|{}", "---|".repeat(names.len()))?;
    for row in scores.rows() {
        let per: Vec<String> = row.iou.iter().map(|v| fmt(*v, 4)).collect();
        let (label, n) = (row.category, row.planes);
        outln!(
            "| {label} | {n} | {} | {} |",
            fmt(row.mean, 4),
            per.join(" | ")
        )?;
    }
    Ok(())
}

/// Runs `dynaslice eval split`.
pub(super) fn split(a: SplitArgs) -> Result<()> {
    let inputs = a
        .input
        .given
        .inputs
        .iter()
        .chain(&a.input.given.label_names);
    let mut plan = Plan::new(inputs, a.force);
    plan.file("-o", &a.output, Kind::TrainingInput)?;
    // The contours as drawn: nested structures are found again (and made disjoint) when the
    // split is trained on, so the model records its nesting.
    let mut spec = a.input.spec();
    spec.nesting = Some(dynaslice_data::nesting::NestingMode::Off);
    let seq = spec.read()?;
    let train = a
        .holdout
        .split()
        .training(&seq)
        .with_context(|| a.input.describe())?;
    // Refused now, not after `dynaslice train` has read it.
    check_model_limits(train.classes(), &domain_for(&train))
        .map_err(|e| anyhow!("{}: {e}", a.input.describe()))?;
    write_atomically(&a.output, native::to_json(&train).as_bytes())?;
    let planes =
        |s: &dynaslice_data::Sequence| s.frames().iter().map(|f| f.planes.len()).sum::<usize>();
    errln!(
        "wrote {}: {} of {} frames, {} of {} planes",
        a.output.display(),
        train.frames().len(),
        seq.frames().len(),
        planes(&train),
        planes(&seq)
    );
    Ok(())
}
