//! `dynaslice labels MODEL.dsm --like REF.nii.gz -o OUT.nii.gz` (or `--bounds`, `--spacing`,
//! `--times`): the model's Eq. 11 label volume, written frame by frame (docs/metrics.md), with
//! its colour tables, or as 3D Slicer segmentations and their sequence.

use super::console::errln;
use super::input::regular_file;
use super::memory::{self, MemoryArgs};
use super::options::{
    count, f32_in, finite_f64, positive_f64, time_series, MAX_SAFETY, MAX_THREADS, MAX_TIMES,
};
use super::progress::Progress;
use super::times::{note, times_option};
use anyhow::{bail, Context, Result};
use dynaslice_core::Model;
use dynaslice_data::nifti::read_geometry;
use dynaslice_data::TimeSeries;
use dynaslice_metrics::motion::Units;
use dynaslice_model::ModelFile;
use dynaslice_output::{Kind, Plan};
use dynaslice_sequence::palette;
use dynaslice_volume::{output_files, Evaluation, VoxelGrid, WriteOptions, DEFAULT_SAFETY};
use std::path::{Path, PathBuf};
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

/// Bytes per voxel while a frame is labelled and written: a u32 class index and an i32 label
/// per voxel ([`dynaslice_volume::write_model_labels_with`]), and up to 4 more for the frame's
/// encoded copy (2 in the NIfTI writer, up to 4 in a `.seg.nrrd` of labels beyond 16 bits; the
/// sequence is compressed in chunks).
const BYTES_PER_VOXEL: f64 = 12.0;

/// Runs `dynaslice labels`: the model's Eq. 11 label volume on a reference grid or a box, as
/// NIfTI with colour tables or as 3D Slicer segmentations and their sequence.
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new(
        [Some(&a.model), a.like.as_ref()].into_iter().flatten(),
        a.force,
    );
    plan.file("-o", &a.output, Kind::LabelVolume)?;
    let evaluation = if a.dense {
        Evaluation::Dense
    } else {
        Evaluation::Pruned { safety: a.safety }
    };
    evaluation.validate()?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let mut grid = match &a.like {
        // The header alone: the reference's voxels are never needed, and its size is known
        // (and checked below) before anything is allocated for it.
        Some(reference) => {
            regular_file("reference", reference)?;
            let name = reference.to_string_lossy().to_ascii_lowercase();
            if !(name.ends_with(".nii") || name.ends_with(".nii.gz")) {
                bail!(
                    "--like {}: not a NIfTI image (.nii, .nii.gz), so it has no voxel grid to \
                     label on; give --bounds and --spacing (or neither: the model's domain at \
                     128 voxels along its longest side), or a NIfTI image of the same subject",
                    reference.display()
                );
            }
            let mut grid = VoxelGrid::like(&read_geometry(reference)?);
            if let Some(series) = &a.times {
                grid.times = series.times();
            }
            grid
        }
        None => bounds_grid(&a, &model, file.is_static())?,
    };
    if file.is_static() && grid.times.len() > 1 {
        // The same labels at every time: one frame, not N identical ones.
        note(&format!(
            "{}: a static model (trained on one timestep, ω_t^max = 0) is the same at every \
             time; writing one label frame, not the {} frames of {}",
            a.model.display(),
            grid.times.len(),
            if a.like.is_some() {
                "--like"
            } else {
                "--times"
            }
        ));
        grid.times.truncate(1);
    }
    // The one time rule: a frame outside the model's range (a --times series past it, or a
    // reference with more or longer frames) is refused, never extrapolated.
    let from_like = a.like.is_some() && a.times.is_none();
    let option = if from_like {
        "--like's frame time".to_string()
    } else {
        times_option(a.times.as_ref())
    };
    if !file.is_static() {
        file.check_times(&option, grid.times.iter().copied())
            .map_err(|e| match from_like {
                true => anyhow::anyhow!(
                    "{e:#}; --like's frame f is at toffset + f × pixdim[4] of its header: give \
                     --times (a list or A:B:N) for other times on its grid"
                ),
                false => e,
            })?;
    }
    let [nx, ny, nz] = grid.dims;
    memory::check(
        &format!("a label volume of {nx}×{ny}×{nz} voxels"),
        grid.dims.iter().map(|&n| n as f64).product::<f64>() * BYTES_PER_VOXEL,
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
    let options = WriteOptions {
        evaluation,
        colors: file.classes().into_iter().map(|c| c.color).collect(),
        companions: true,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let start = Instant::now();
    let progress = Progress::new("labelling: frame", frames as u64);
    let counts = pool.install(|| {
        dynaslice_volume::write_model_labels_with(&model, &grid, &a.output, &options, |f| {
            progress.set_position(f as u64 + 1)
        })
    })?;
    progress.finish();
    let (volume, companions) = describe(&files);
    errln!(
        "wrote {volume}: {nx}×{ny}×{nz} voxels × {frames} frame(s) in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    for companion in companions {
        errln!("  and {companion}");
    }
    // The class volumes of the first and last frame, a quick plausibility check, and the
    // colour each class has in every output; in mL where the input's units are millimetres.
    let voxel = grid.voxel_volume();
    let colors = file.class_colors();
    let units = file.units();
    for ((k, class), color) in model.classes().enumerate().zip(colors) {
        let v = |f: usize| units.from_world_volume(counts[f][k + 1] as f64 * voxel);
        // Times come from f32 header fields: print them at that precision (1, not
        // 1.0000000074505806).
        let at = |f: usize| format!("{:.6} at t = {}", v(f), grid.times[f] as f32);
        let volumes = if frames == 1 {
            at(0)
        } else {
            format!("{}, {}", at(0), at(frames - 1))
        };
        errln!(
            "  label {} {:?} {}: {volumes} ({})",
            class.label,
            class.name,
            palette::to_hex(color),
            match units {
                Units::Millimetres => "mL",
                Units::Plain => "the input's plain units³",
            }
        );
    }
    Ok(())
}

/// The written `files` ([`output_files`]) for the summary: the volume (a series of frames by
/// its first and last), and the companion files, each named with what it is for.
fn describe(files: &[PathBuf]) -> (String, Vec<String>) {
    let lower = |p: &Path| p.to_string_lossy().to_ascii_lowercase();
    let (volume, companions): (Vec<&PathBuf>, Vec<&PathBuf>) = files.iter().partition(|p| {
        let name = lower(p);
        name.ends_with(".seg.nrrd") || name.ends_with(".nii") || name.ends_with(".nii.gz")
    });
    let volume = match volume[..] {
        [one] => one.display().to_string(),
        [first, .., last] => format!(
            "{} … {} (a segmentation per frame)",
            first.display(),
            last.display()
        ),
        [] => String::new(),
    };
    let companions = companions
        .iter()
        .map(|p| {
            let name = lower(p);
            let what = if name.ends_with(".ctbl") {
                "3D Slicer colour table"
            } else if name.ends_with(".label.txt") {
                "ITK-SNAP label descriptions"
            } else {
                "3D Slicer sequence of the frames"
            };
            format!("{} ({what})", p.display())
        })
        .collect();
    (volume, companions)
}

/// The grid of `--bounds`, `--spacing` and `--times`, each defaulting to the model's (a static
/// model's times to its one time).
fn bounds_grid(a: &Args, model: &Model, is_static: bool) -> Result<VoxelGrid> {
    let (lo, hi) = match &a.bounds {
        Some(b) => match b[..] {
            [x0, y0, z0, x1, y1, z1] => ([x0, y0, z0], [x1, y1, z1]),
            _ => bail!("--bounds takes 6 values X0,Y0,Z0,X1,Y1,Z1, not {}", b.len()),
        },
        None => {
            let (lo, hi) = model.domain().bounds();
            (lo.map(f64::from), hi.map(f64::from))
        }
    };
    let spacing = match a.spacing.as_deref() {
        Some(&[s]) => [s; 3],
        Some(&[x, y, z]) => [x, y, z],
        Some(other) => bail!("--spacing takes 1 or 3 values, not {}", other.len()),
        None => {
            let longest = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
            [longest / 128.0; 3]
        }
    };
    // A voxel wider than the box along every axis is one voxel of nothing: a mistyped value.
    if (0..3).all(|i| spacing[i] > hi[i] - lo[i]) {
        bail!(
            "--spacing {spacing:?} is wider than the box (sides {:?}, {lo:?} to {hi:?}) along every \
             axis: the volume would be a single voxel",
            [0, 1, 2].map(|i| hi[i] - lo[i])
        );
    }
    let times = match &a.times {
        Some(series) => series.times(),
        None if is_static => vec![f64::from(model.domain().time_range().0)],
        None => {
            let (t0, t1) = model.domain().time_range();
            TimeSeries::across(t0, t1, 10)
                .map_err(anyhow::Error::msg)?
                .times()
        }
    };
    VoxelGrid::from_bounds(lo, hi, spacing, times)
}
