//! `dynaslice labels MODEL.dsm --like REF.nii.gz -o OUT.nii.gz` (or `--bounds`, `--spacing`,
//! `--times`): the model's Eq. 11 label volume, written frame by frame (docs/metrics.md), with
//! its colour tables, or as 3D Slicer segmentations and their sequence.

use super::console::errln;
use super::memory::{self, MemoryArgs};
use super::options::{
    count, f32_in, finite_f64, positive_f64, time_series, MAX_SAFETY, MAX_THREADS, MAX_TIMES,
};
use super::pool::pool;
use super::progress::Progress;
use super::times::{note, times_option};
use anyhow::{bail, Result};
use dynaslice_data::TimeSeries;
use dynaslice_metrics::motion::Units;
use dynaslice_model::ModelFile;
use dynaslice_output::{Kind, Plan};
use dynaslice_sequence::palette;
use dynaslice_volume::{class_volumes, describe_files, fit_times, output_files, working_bytes};
use dynaslice_volume::{Evaluation, VoxelGrid, WriteOptions, DEFAULT_SAFETY};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `dynaslice labels`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Files: -o NAME.nii.gz (or .nii) writes the volume, a frame per time, and beside it NAME.ctbl
(a 3D Slicer colour table) and NAME.label.txt (an ITK-SNAP label description file) giving each
label its class's name and colour. -o NAME.seg.nrrd writes a 3D Slicer segmentation; with
several frames, one NAME_tF.seg.nrrd per frame plus NAME.seq.nrrd, all frames as one sequence
for Slicer's Sequences module (Slicer 5.10 and later index it by time, earlier 5.x number the
frames). Existing files are replaced only with --force. Classes take the colours of the
model's training input where it had them (recorded in the model file), else the palette's.

Evaluation: pruned by default (the network is evaluated near the boundaries between labels and
blocks far from every boundary are filled), in a fraction of the time of --dense (every voxel)
and with the same labels wherever the network's gradients are at most --safety (a trained
distance field's are close to 1; docs/performance.md).")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// Reference NIfTI image: the volume gets its dimensions, affine and frames (frame f at
    /// time toffset + f · pixdim[4], as when training on it; --times gives other times on its
    /// grid); only its header is read, so any voxel type will do.
    #[arg(long, value_name = "REF.nii.gz", conflicts_with_all = ["bounds", "spacing"])]
    like: Option<PathBuf>,
    /// World box X0,Y0,Z0,X1,Y1,Z1 (default: the model's domain).
    #[arg(
        long,
        value_delimiter = ',',
        allow_negative_numbers = true,
        value_name = "X0,Y0,Z0,X1,Y1,Z1",
        value_parser = finite_f64
    )]
    bounds: Option<Vec<f64>>,
    /// Voxel size: one value, or SX,SY,SZ (default: 128 voxels along the longest axis).
    #[arg(long, value_delimiter = ',', value_parser = positive_f64, allow_negative_numbers = true)]
    spacing: Option<Vec<f64>>,
    /// Frames at these times, in the model's time units: a list (0,0.5,1) or A:B:N, N evenly
    /// from A to B inclusive (default: --like's frames, else the model's time range in 10
    /// frames; a static model, the same at every time, gets one frame).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Output .nii or .nii.gz (one file, a frame per time, plus OUT.ctbl and OUT.label.txt
    /// colour tables), or .seg.nrrd (a 3D Slicer segmentation per frame, OUT_tF.seg.nrrd when
    /// there are several, plus their sequence OUT.seq.nrrd; classes as named segments).
    #[arg(short, long, value_name = "OUT.nii.gz")]
    output: PathBuf,
    /// Replace existing output files (the volume, its colour tables or sequence).
    #[arg(long)]
    force: bool,
    /// Evaluate the network at every voxel: the slow check of the default pruned evaluation,
    /// whose labels are the same wherever the gradients are at most --safety.
    #[arg(long)]
    dense: bool,
    /// Safety factor s of the pruned evaluation's distance bound: a block is filled when every
    /// corner's certified radius divided by s covers it (≥ 1; larger is safer for models far
    /// from ‖∇f‖ = 1).
    #[arg(long, default_value_t = DEFAULT_SAFETY, value_parser = f32_in(1.0, MAX_SAFETY),
          allow_negative_numbers = true, conflicts_with = "dense")]
    safety: f32,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = count(1, MAX_THREADS))]
    threads: Option<usize>,
    #[command(flatten)]
    memory: MemoryArgs,
}

/// Runs `dynaslice labels`: the model's Eq. 11 label volume on a reference grid or a box, as
/// NIfTI with colour tables or as 3D Slicer segmentations and their sequence.
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new(
        [Some(&a.model), a.like.as_ref()].into_iter().flatten(),
        a.force,
    );
    plan.file("-o", &a.output, Kind::LabelVolume)?;
    let evaluation = match a.dense {
        true => Evaluation::Dense,
        false => Evaluation::Pruned { safety: a.safety },
    };
    evaluation.validate()?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let times = a.times.as_ref().map(TimeSeries::times);
    let mut grid = match &a.like {
        Some(reference) => VoxelGrid::like_file(reference, times)?,
        None => {
            let (bounds, spacing) = (a.bounds.as_deref(), a.spacing.as_deref());
            VoxelGrid::over_model(&model, file.is_static(), bounds, spacing, times)?
        }
    };
    // The one time rule: a frame outside the model's range (a --times series past it, or a
    // reference with more or longer frames) is refused, never extrapolated.
    let from_like = a.like.is_some() && a.times.is_none();
    let option = match from_like {
        true => "--like's frame time".to_string(),
        false => times_option(a.times.as_ref()),
    };
    let of = match a.like {
        Some(_) => "--like",
        None => "--times",
    };
    match fit_times(&file, &mut grid, &option) {
        // The same labels at every time: one frame, not N identical ones.
        Ok(0) => {}
        Ok(dropped) => note(&format!(
            "{}: a static model (trained on one timestep, ω_t^max = 0) is the same at every \
             time; writing one label frame, not the {} frames of {of}",
            a.model.display(),
            dropped + 1,
        )),
        Err(e) if from_like => bail!(
            "{e:#}; --like's frame f is at toffset + f × pixdim[4] of its header: give --times \
             (a list or A:B:N) for other times on its grid"
        ),
        Err(e) => return Err(e),
    }
    let [nx, ny, nz] = grid.dims;
    memory::check(
        &format!("a label volume of {nx}×{ny}×{nz} voxels"),
        working_bytes(&grid),
        "use a coarser --spacing or smaller --bounds",
        a.memory,
    )?;
    let frames = grid.times.len();
    // Every file the run writes, checked before any work: the frames' segmentations, the
    // sequence and the colour tables may replace files as the volume may.
    let files = output_files(&a.output, frames, true);
    for path in files.iter().filter(|p| **p != a.output) {
        plan.beside(path)?;
    }
    let options = WriteOptions::for_model(&file, evaluation);
    let pool = pool(a.threads)?;
    let start = Instant::now();
    let progress = Progress::new("labelling: frame", frames as u64);
    let counts = pool.install(|| {
        dynaslice_volume::write_model_labels_with(&model, &grid, &a.output, &options, |f| {
            progress.set_position(f as u64 + 1)
        })
    })?;
    progress.finish();
    let (volume, companions) = describe_files(&files);
    errln!(
        "wrote {volume}: {nx}×{ny}×{nz} voxels × {frames} frame(s) in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    for companion in companions {
        errln!("  and {companion}");
    }
    // The class volumes of the first and last frame, a quick plausibility check, and the
    // colour each class has in every output; in mL where the input's units are millimetres.
    let volumes = class_volumes(&file, &grid, &counts);
    let unit = match file.units() {
        Units::Millimetres => "mL",
        Units::Plain => "the input's plain units³",
    };
    for ((k, class), color) in model.classes().enumerate().zip(file.class_colors()) {
        // Times come from f32 header fields: print them at that precision (1, not
        // 1.0000000074505806).
        let at = |f: usize| format!("{:.6} at t = {}", volumes[f][k], grid.times[f] as f32);
        let volumes = match frames {
            1 => at(0),
            _ => format!("{}, {}", at(0), at(frames - 1)),
        };
        let hex = palette::to_hex(color);
        errln!(
            "  label {} {:?} {hex}: {volumes} ({unit})",
            class.label,
            class.name
        );
    }
    Ok(())
}
