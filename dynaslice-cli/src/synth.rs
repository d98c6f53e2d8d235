//! `dynaslice synth -o DIR [--shape NAME|all]`: the synthetic 4D benchmark.

use super::console::outln;
use super::memory::{self, MemoryArgs};
use super::options::{
    count, MAX_PLANE_RESOLUTION, MAX_SYNTH_PLANES, MAX_SYNTH_TIMESTEPS, MAX_VOLUME_RESOLUTION,
};
use super::progress::Progress;
use anyhow::{bail, Result};
use dynaslice_output::Plan;
use dynaslice_synth::{write_data_sets, BenchmarkOptions, Shape};
use std::path::PathBuf;

/// Arguments of `dynaslice synth`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output folder; each shape goes to DIR/<shape>/ (slices.json, truth.nii.gz, labels.txt).
    #[arg(short, long)]
    output: PathBuf,
    /// Shape to write (blob, tube, torus, chambers) or `all`.
    #[arg(long, default_value = "all")]
    shape: String,
    /// Timesteps uniformly spaced over [0, 1].
    #[arg(long, default_value_t = 37, value_parser = count(2, MAX_SYNTH_TIMESTEPS))]
    timesteps: usize,
    /// Slice every N-th timestep for training.
    #[arg(long, default_value_t = 4, value_parser = count(1, MAX_SYNTH_TIMESTEPS))]
    train_every: usize,
    /// Rotated and parallel planes per training timestep, `R,P` (default 15,15; 35,35 for thin
    /// shapes).
    #[arg(long, value_parser = parse_pair)]
    planes: Option<(usize, usize)>,
    /// Grid points per axis used to contour each plane.
    #[arg(long, default_value_t = 256, value_parser = count(2, MAX_PLANE_RESOLUTION))]
    plane_resolution: usize,
    /// Voxels per axis of the ground-truth volume.
    #[arg(long, default_value_t = 64, value_parser = count(1, MAX_VOLUME_RESOLUTION))]
    volume_resolution: usize,
    /// Replace the data sets of these shapes where DIR already holds them.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    memory: MemoryArgs,
}

fn parse_pair(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s.split_once(',').ok_or("expected R,P")?;
    let n = |x: &str| count(0, MAX_SYNTH_PLANES)(x).map_err(|e| format!("`{x}`: {e}"));
    let (r, p) = (n(a)?, n(b)?);
    if r + p == 0 {
        return Err("no plane: R + P must be at least 1".into());
    }
    Ok((r, p))
}

/// Runs `dynaslice synth`: each shape's data set is written into a temporary folder inside
/// DIR and renamed to DIR/<shape> when complete, so a failed run leaves no partial data set.
pub fn run(args: Args) -> Result<()> {
    let shapes: Vec<Shape> = if args.shape == "all" {
        Shape::ALL.to_vec()
    } else {
        vec![args.shape.parse().map_err(anyhow::Error::msg)?]
    };
    let dir = &args.output;
    // Held until the data sets are in place: a second run on DIR refuses.
    let mut plan = Plan::new(std::iter::empty::<PathBuf>(), args.force);
    plan.directory("-o", dir)?;
    for shape in &shapes {
        let target = dir.join(shape.name());
        if target.exists() && !args.force {
            bail!(
                "-o {}: {} exists; add --force to replace it",
                dir.display(),
                target.display()
            );
        }
    }
    let options = BenchmarkOptions {
        timesteps: args.timesteps,
        train_every: args.train_every,
        planes: args.planes,
        plane_resolution: args.plane_resolution,
        volume_resolution: args.volume_resolution,
    };
    memory::check(
        &format!(
            "--volume-resolution {} over {} timesteps",
            args.volume_resolution, args.timesteps
        ),
        options.truth_bytes(),
        "lower --volume-resolution or --timesteps",
        args.memory,
    )?;
    // Slicing and the ground-truth volumes take a minute per shape on a loaded machine.
    let progress = Progress::new(
        "writing the slices and ground truth: shape",
        shapes.len() as u64,
    );
    // A failed listing (the reader of standard output gone) stops the listing, not the
    // remaining data sets.
    let mut listed = Ok(());
    write_data_sets(dir, &shapes, &options, |files| {
        progress.inc();
        for f in files {
            if listed.is_err() {
                break;
            }
            let (name, slices, truth) = (f.shape.name(), f.slices.display(), f.truth.display());
            listed = outln!("{name:<9} {slices}  {truth}");
        }
    })?;
    progress.finish();
    Ok(listed?)
}
