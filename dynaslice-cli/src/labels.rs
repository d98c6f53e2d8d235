//! `dynaslice labels MODEL.dsm --like REF.nii.gz -o OUT.nii.gz` (or `--bounds`, `--spacing`,
//! `--times`): the model's Eq. 11 label volume, written frame by frame (docs/metrics.md).

use super::memory::{self, MemoryArgs};
use super::model::ModelFile;
use super::options::{count, finite_f64, positive_f64, time_series, MAX_THREADS, MAX_TIMES};
use super::output::{regular_file, Kind, Plan};
use anyhow::{bail, Context, Result};
use dynaslice_core::Model;
use dynaslice_data::nifti::read_volume;
use dynaslice_data::TimeSeries;
use dynaslice_volume::VoxelGrid;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `dynaslice labels`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// Reference NIfTI image: the volume gets its dimensions, affine and frames (frame f at
    /// time f · its frame interval, as when training on it).
    #[arg(long, value_name = "REF.nii.gz", conflicts_with_all = ["bounds", "spacing", "times"])]
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
    /// Frames at N times evenly from A to B inclusive (default: the model's time range in 10
    /// frames).
    #[arg(long, value_name = "A:B:N", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Output .nii or .nii.gz (one file, a frame per time), or .seg.nrrd (a 3D Slicer
    /// segmentation per frame, OUT_tF.seg.nrrd when there are several, classes as named segments).
    #[arg(short, long, value_name = "OUT.nii.gz")]
    output: PathBuf,
    /// Replace an existing label volume.
    #[arg(long)]
    force: bool,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = count(1, MAX_THREADS))]
    threads: Option<usize>,
    #[command(flatten)]
    memory: MemoryArgs,
}

/// Bytes per voxel while a frame is labelled and written: a u32 class index and an i32 label
/// per voxel ([`dynaslice_volume::write_model_labels`]), and up to 2 more for the frame's
/// encoded copy in the NIfTI writer.
const BYTES_PER_VOXEL: f64 = 10.0;

/// Runs `dynaslice labels`: the model's Eq. 11 label volume on a reference grid or a box, as NIfTI.
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new(
        [Some(&a.model), a.like.as_ref()].into_iter().flatten(),
        a.force,
    );
    plan.file("-o", &a.output, Kind::LabelVolume)?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let grid = match &a.like {
        // The reference's voxels are read and dropped at once: only its geometry is used.
        Some(reference) => {
            regular_file("reference", reference)?;
            VoxelGrid::like(&read_volume(reference)?)
        }
        None => bounds_grid(&a, &model)?,
    };
    let [nx, ny, nz] = grid.dims;
    memory::check(
        &format!("a label volume of {nx}×{ny}×{nz} voxels"),
        grid.dims.iter().map(|&n| n as f64).product::<f64>() * BYTES_PER_VOXEL,
        "use a coarser --spacing or smaller --bounds",
        a.memory,
    )?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let start = Instant::now();
    let frames = grid.times.len();
    let terminal = std::io::stderr().is_terminal();
    let bar = terminal.then(|| {
        let bar = ProgressBar::new(frames as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:30}] frame {pos}/{len} ETA {eta}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    });
    let mut last_log = Instant::now();
    let counts = pool.install(|| {
        dynaslice_volume::write_model_labels(&model, &grid, &a.output, |f| match &bar {
            Some(bar) => bar.set_position(f as u64 + 1),
            None if last_log.elapsed() >= Duration::from_secs(10) => {
                eprintln!(
                    "frame {}/{frames}, {:.0} s",
                    f + 1,
                    start.elapsed().as_secs_f64()
                );
                last_log = Instant::now();
            }
            None => {}
        })
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    eprintln!(
        "wrote {}: {nx}×{ny}×{nz} voxels × {frames} frame(s) in {:.1} s",
        a.output.display(),
        start.elapsed().as_secs_f64()
    );
    // The class volumes of the first and last frame, a quick plausibility check.
    let voxel = grid.voxel_volume();
    for (k, class) in model.classes().enumerate() {
        let v = |f: usize| counts[f][k + 1] as f64 * voxel;
        eprintln!(
            "  label {} {:?}: {:.6} at t = {}, {:.6} at t = {} (world units³)",
            class.label,
            class.name,
            v(0),
            // Times come from f32 header fields: print them at that precision (1, not
            // 1.0000000074505806).
            grid.times[0] as f32,
            v(frames - 1),
            grid.times[frames - 1] as f32
        );
    }
    Ok(())
}

/// The grid of `--bounds`, `--spacing` and `--times`, each defaulting to the model's.
fn bounds_grid(a: &Args, model: &Model) -> Result<VoxelGrid> {
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
    let times = match a.times {
        Some(series) => series.times(),
        None => {
            let (t0, t1) = model.domain().time_range();
            TimeSeries::across(t0, t1, 10)
                .map_err(anyhow::Error::msg)?
                .times()
        }
    };
    VoxelGrid::from_bounds(lo, hi, spacing, times)
}
