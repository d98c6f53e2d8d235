//! `dynaslice rtstruct MODEL.dsm --like PHASE.dcm -o DIR` (plus `--ct CT_DIR` or
//! `--like-grid REF.nii.gz`, `--times`, `--itv`): the model's structures as DICOM RT Structure
//! Sets, one per time, on the planes of the reference geometry, for a treatment planning system
//! (docs/tps-import.md).

use super::console::errln;
use super::options::{count, f64_in, non_negative_f64_to, time_series, MAX_THREADS, MAX_TIMES};
use super::pool::pool;
use super::progress::Progress;
use super::times::times_option;
use anyhow::Result;
use dynaslice_data::TimeSeries;
use dynaslice_model::ModelFile;
use dynaslice_output::Plan;
use dynaslice_volume::rtstruct::{Contoured, Reference, StructureOptions, StructureSets, MANIFEST};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `dynaslice rtstruct`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Files: DIR/RS_tIII.dcm, one RT Structure Set per time (III its index from 000), and
DIR/rtstruct.seq listing them as `<time> <file>` lines (a sequence manifest, readable by
`dynaslice train`). Existing files are replaced only with --force.

Planes: every slice of --ct (the planning CT's images, each contour referencing its image),
else every slice of --like-grid (a NIfTI image of the patient), else every plane that --like
has contours on; only where the plane meets the model's domain. Contours: the Eq. 11 label
regions (what `dynaslice labels` writes), their boundaries placed on the model's zero level set,
simplified to --tolerance; holes as separate contours inside their outer one (even-odd rule). A
class drawn around others (nesting, see `dynaslice train --nesting`) is written whole: its own
region and theirs, as it was drawn.

Each file carries --like's patient, study, frame of reference and referenced series, and each
class its ROI (matched by name): ROI Number, Name, Display Color and RT ROI Interpreted Type.")]
pub struct Args {
    /// Model file (.dsm), trained on RT Structure Sets of this patient (or in their frame).
    model: PathBuf,
    /// An RT Structure Set of the patient (e.g. one phase of the training input): the patient,
    /// study, frame of reference, referenced images and ROIs the written files carry.
    #[arg(long, value_name = "PHASE.dcm")]
    like: PathBuf,
    /// Folder of the planning CT series (DICOM images): contours on its slices, referencing
    /// them.
    #[arg(long, value_name = "CT_DIR", conflicts_with = "like_grid")]
    ct: Option<PathBuf>,
    /// Reference image (NIfTI): contours on its slices (its k axis).
    #[arg(long, value_name = "REF.nii.gz")]
    like_grid: Option<PathBuf>,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: the times
    /// of the model's training input,
    /// read from the sequence manifest the model records).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Add to every file an ITV per class: the union of its regions over the written times,
    /// named "ITV <class>".
    #[arg(long)]
    itv: bool,
    /// In-plane sampling step (mm) of the contouring grid, 0.01 to 100 (default: the
    /// reference's pixel spacing, else 1 mm).
    #[arg(long, value_parser = f64_in(MIN_STEP_MM, MAX_STEP_MM))]
    step: Option<f64>,
    /// Simplification tolerance (mm), 0 to 5: the most a contour may move from the exact zero
    /// level set's vertices (Douglas–Peucker); 0 keeps every vertex.
    #[arg(long, default_value_t = 0.1, value_parser = non_negative_f64_to(MAX_TOLERANCE_MM))]
    tolerance: f64,
    /// Output folder (created where missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Replace existing files in the output folder.
    #[arg(long)]
    force: bool,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = count(1, MAX_THREADS))]
    threads: Option<usize>,
}

/// The finest contouring step (mm): a hundredth of a millimetre is far below any CT's pixel.
const MIN_STEP_MM: f64 = 0.01;
/// The coarsest contouring step (mm).
const MAX_STEP_MM: f64 = 100.0;
/// The largest simplification (mm): half a centimetre, a planning margin's size; beyond it a
/// contour no longer follows the model's surface.
const MAX_TOLERANCE_MM: f64 = 5.0;

/// Runs `dynaslice rtstruct` ([`dynaslice_volume::rtstruct`]).
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new(
        [Some(&a.model), Some(&a.like), a.like_grid.as_ref()]
            .into_iter()
            .flatten(),
        a.force,
    );
    plan.directory("-o", &a.output)?;
    let file = ModelFile::open(&a.model)?;
    let reference = match (a.ct, a.like_grid) {
        (Some(ct), _) => Reference::Ct(ct),
        (None, Some(grid)) => Reference::Grid(grid),
        (None, None) => Reference::Template,
    };
    let sets = StructureSets::prepare(
        &file,
        &StructureOptions {
            like: a.like,
            reference,
            times: a.times.as_ref().map(TimeSeries::times),
            times_option: times_option(a.times.as_ref()),
            itv: a.itv,
            step: a.step,
            tolerance: a.tolerance,
        },
    )?;
    for path in sets.files(&a.output) {
        plan.beside(&path)?;
    }
    let pool = pool(a.threads)?;
    let start = Instant::now();
    // Each time (and the ITV) contours every plane: tens of seconds on a loaded machine.
    // With --itv the count is of passes (the ITV's union, then each phase), not of phases.
    let progress = Progress::new(
        if a.itv {
            "contouring the ITV, then each phase: pass"
        } else {
            "contouring: phase"
        },
        (sets.times.len() + usize::from(a.itv)) as u64,
    );
    pool.install(|| {
        sets.write(&a.output, a.force, |step| {
            if let Contoured::Phase {
                path,
                time,
                rois,
                contours,
            } = step
            {
                progress.println(format!(
                    "contoured {} (t = {}): {rois} ROIs, {contours} contours",
                    path.display(),
                    time as f32,
                ));
            }
            progress.inc();
        })
    })?;
    progress.finish();
    errln!(
        "wrote {} ({} phases) in {:.1} s; {} planes, step {} mm, tolerance {} mm",
        a.output.join(MANIFEST).display(),
        sets.times.len(),
        start.elapsed().as_secs_f64(),
        sets.planes.len(),
        sets.options.step,
        sets.options.tolerance
    );
    Ok(())
}
