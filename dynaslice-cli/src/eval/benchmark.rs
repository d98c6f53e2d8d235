//! `dynaslice eval synthetic`: a model against the synthetic benchmark's exact shapes.

use super::fmt;
use crate::console::{errln, outln};
use crate::memory::{self, MemoryArgs};
use crate::options::{count, MAX_CHAMFER_SAMPLES, MAX_IOU_RESOLUTION, MAX_MESH_RESOLUTION};
use crate::progress::Progress;
use anyhow::{bail, Context, Result};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::benchmark::{Resolution, Scores, Truth};
use dynaslice_metrics::chamfer::DEFAULT_SAMPLES;
use dynaslice_metrics::Frames;
use dynaslice_model::ModelFile;
use dynaslice_output::write_atomically;
use dynaslice_output::{Kind, Plan};
use dynaslice_synth::{BenchmarkOptions, Shape};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(super) struct SyntheticArgs {
    /// Model file (.dsm), trained on `dynaslice synth` slices of the shape.
    model: PathBuf,
    /// Benchmark shape: blob, tube, torus or chambers.
    #[arg(long)]
    shape: Shape,
    /// Frames the model was trained on, among the 37 (default: the protocol's every 4th).
    #[arg(long, default_value = "0::4", value_name = "A:B:STEP")]
    annotated: FrameRange,
    /// Cells per axis of the IoU grid over [−1, 1]³.
    #[arg(long, default_value_t = 64, value_parser = count(1, MAX_IOU_RESOLUTION))]
    resolution: usize,
    /// Lattice cells per axis for the model's meshes.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    mesh_resolution: u32,
    /// Lattice cells per axis for the exact shapes' meshes.
    #[arg(long, default_value_t = 256, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    truth_resolution: u32,
    /// Area-uniform samples per surface for the Chamfer distance.
    #[arg(long, default_value_t = DEFAULT_SAMPLES, value_parser = count(1, MAX_CHAMFER_SAMPLES))]
    samples: usize,
    /// Per-frame CSV (IoU and CD×10⁴ per class).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Replace an existing --csv file.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    memory: MemoryArgs,
}

/// Runs `dynaslice eval synthetic`.
pub(super) fn synthetic(a: SyntheticArgs) -> Result<()> {
    let mut plan = Plan::new([&a.model], a.force);
    if let Some(csv) = &a.csv {
        plan.file("--csv", csv, Kind::Csv)?;
    }
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let shape = a.shape;
    let names = shape.class_names();
    if model.num_classes() != names.len() {
        bail!(
            "{}: {} classes, but {} has {}",
            a.model.display(),
            model.num_classes(),
            shape.name(),
            names.len()
        );
    }
    let bench = BenchmarkOptions::default();
    let resolution = Resolution {
        iou: a.resolution,
        mesh: a.mesh_resolution,
        truth: a.truth_resolution,
        samples: a.samples,
    };
    memory::check(
        &format!(
            "--samples {} at --truth-resolution {}",
            a.samples, a.truth_resolution
        ),
        resolution.truth_bytes(bench.timesteps, names.len()),
        "lower --samples or --truth-resolution",
        a.memory,
    )?;
    let annotated_frames = a.annotated.indices(bench.timesteps);
    let frames = bench.timesteps as u64;
    let progress = Progress::new(
        &format!(
            "meshing the exact {} at {}³: frame",
            shape.name(),
            a.truth_resolution
        ),
        frames,
    );
    let truth = Truth::new_with(shape, &annotated_frames, resolution, |f| {
        progress.set_position(f as u64)
    })?;
    progress.finish();
    let progress = Progress::new("scoring the model: frame", frames);
    let scores = truth
        .score_with(&model, |f| progress.set_position(f as u64))
        .with_context(|| a.model.display().to_string())?;
    progress.finish();
    // The file first: a closed standard output ends the command at the table.
    if let Some(path) = &a.csv {
        write_atomically(path, scores.to_csv(names).as_bytes())?;
        errln!("wrote {}", path.display());
    }
    let Scores { iou, cd } = scores;
    outln!(
        "{} ({} classes), {} frames ({} annotated): 3D IoU on a {}³ grid over [-1, 1]³; \
         CD×10⁴ over {} samples per surface, unit-normalised by the domain diagonal 2√3",
        shape.name(),
        names.len(),
        iou.times.len(),
        annotated_frames.len(),
        a.resolution,
        a.samples
    )?;
    outln!("| | IoU | CD×10⁴ |\n|---|---|---|")?;
    for (label, frames) in [
        ("all frames", Frames::All),
        ("annotated", Frames::Annotated),
        ("unannotated", Frames::Unannotated),
    ] {
        outln!(
            "| {label} | {} | {} |",
            fmt(iou.mean(frames), 4),
            fmt(cd.mean(frames), 3)
        )?;
    }
    for (c, name) in names.iter().enumerate() {
        outln!(
            "| class {} {name} | {} | {} |",
            c + 1,
            fmt(iou.class_mean(c, Frames::All), 4),
            fmt(cd.class_mean(c, Frames::All), 3)
        )?;
    }
    Ok(())
}
