//! `dynaslice synth -o DIR [--shape NAME|all]`: the synthetic 4D benchmark.

use std::path::PathBuf;

use anyhow::Result;

use dynaslice_data::synth::{write_benchmark, BenchmarkOptions, Shape};

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
    #[arg(long, default_value_t = 37)]
    timesteps: usize,
    /// Slice every N-th timestep for training.
    #[arg(long, default_value_t = 4)]
    train_every: usize,
    /// Rotated and parallel planes per training timestep, `R,P` (default 15,15; 35,35 for thin
    /// shapes).
    #[arg(long, value_parser = parse_pair)]
    planes: Option<(usize, usize)>,
    /// Grid points per axis used to contour each plane.
    #[arg(long, default_value_t = 256)]
    plane_resolution: usize,
    /// Voxels per axis of the ground-truth volume.
    #[arg(long, default_value_t = 64)]
    volume_resolution: usize,
}

fn parse_pair(s: &str) -> Result<(usize, usize), String> {
    let (a, b) = s.split_once(',').ok_or("expected R,P")?;
    let n = |x: &str| x.trim().parse::<usize>().map_err(|e| format!("`{x}`: {e}"));
    Ok((n(a)?, n(b)?))
}

/// Runs `dynaslice synth`.
pub fn run(args: Args) -> Result<()> {
    let shapes: Vec<Shape> = if args.shape == "all" {
        Shape::ALL.to_vec()
    } else {
        vec![args.shape.parse().map_err(anyhow::Error::msg)?]
    };
    if args.timesteps < 2 || args.train_every == 0 {
        anyhow::bail!("--timesteps must be at least 2 and --train-every at least 1");
    }
    let options = BenchmarkOptions {
        timesteps: args.timesteps,
        train_every: args.train_every,
        planes: args.planes,
        plane_resolution: args.plane_resolution.max(2),
        volume_resolution: args.volume_resolution.max(1),
    };
    for files in write_benchmark(&args.output, &shapes, &options)? {
        println!(
            "{:<9} {}  {}",
            files.shape.name(),
            files.slices.display(),
            files.truth.display()
        );
    }
    Ok(())
}
