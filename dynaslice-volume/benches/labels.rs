//! Label volumes: pruned against dense evaluation, measured in one run (ratios, not absolute
//! times, are comparable between runs on a shared machine).
//!
//! ```sh
//! cargo bench -p dynaslice-volume --bench labels -- [--model PATH] [--steps N] [--frames N]
//!     [--slices M] [--safety S] [--threads N]
//! ```
//!
//! The model is a SIREN of `dynaslice train`'s default size (4 sine layers of 256) trained for
//! `--steps` (default 1500) steps on the
//! synthetic benchmark's chambers (three moving classes, `dynaslice synth --shape chambers`), saved
//! to `--model` (default `target/labels-bench-chambers.dsm`) and reused when that file exists.
//!
//! Cases:
//! - the benchmark's cube at 80³ voxels, 37 frames over t ∈ [0, 1] (`--frames` of them measured,
//!   evenly spread, default 7): dense and pruned on every measured frame, voxels compared;
//! - one 512×512×300 frame over the same cube (a CT-sized grid): pruned on the whole frame, dense
//!   on `--slices` z-slices (default 12) spread through it, compared there; the dense time of
//!   the frame is the measured per-voxel rate times its voxels (dense work is the same at every
//!   voxel).

use anyhow::{bail, Context, Result};
use dynaslice_core::{Model, ModelBytes, Scratch};
use dynaslice_data::{Space, TimeUnit, Units};
use dynaslice_synth::{BenchmarkOptions, Shape};
use dynaslice_train::fit::{fit, InputRecord, Quiet};
use dynaslice_train::spec::TrainSpec;
use dynaslice_volume::{label_indices_with, Evaluation, VoxelGrid, DEFAULT_SAFETY};
use std::path::PathBuf;
use std::time::Instant;

struct Args {
    model: PathBuf,
    steps: u64,
    frames: usize,
    slices: usize,
    safety: f32,
}

fn parse() -> Result<Args> {
    let mut a = Args {
        model: PathBuf::from("target/labels-bench-chambers.dsm"),
        steps: 1500,
        frames: 7,
        slices: 12,
        safety: DEFAULT_SAFETY,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().with_context(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--model" => a.model = value()?.into(),
            "--steps" => a.steps = value()?.parse()?,
            "--frames" => a.frames = value()?.parse()?,
            "--slices" => a.slices = value()?.parse()?,
            "--safety" => a.safety = value()?.parse()?,
            "--threads" => {
                let n: usize = value()?.parse()?;
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build_global()?;
            }
            "--bench" => {}
            other => bail!("unknown argument {other}"),
        }
    }
    Ok(a)
}

fn trained_model(a: &Args) -> Result<ModelBytes> {
    if a.model.exists() {
        eprintln!("model: {}", a.model.display());
        return Ok(ModelBytes::read(&a.model)?);
    }
    let seq = dynaslice_synth::slice_sequence(Shape::Chambers, &BenchmarkOptions::default())?;
    let spec = TrainSpec {
        steps: Some(a.steps),
        ..TrainSpec::default()
    };
    let input = InputRecord {
        description: "synth chambers (labels bench)".into(),
        frames: "0:".into(),
        reading: None,
        space: Space::Ras,
        units: Units::Plain,
        time_unit: TimeUnit::Plain,
    };
    eprintln!("training {} steps on the synthetic chambers", a.steps);
    let trained = fit(&seq, &spec, &input, None, &mut Quiet)?;
    std::fs::write(&a.model, trained.bytes.as_bytes())?;
    eprintln!(
        "trained in {:.0} s, saved to {}",
        trained.elapsed.as_secs_f64(),
        a.model.display()
    );
    Ok(trained.bytes)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Dense labels of z-slices `slices` of `grid` (the same points as the dense evaluation of the
/// whole frame), x fastest, slice after slice.
fn dense_slices(model: &Model, grid: &VoxelGrid, t: f64, slices: &[usize]) -> Vec<u32> {
    use rayon::prelude::*;
    let [nx, ny, _] = grid.dims;
    let mut out = vec![0u32; nx * ny * slices.len()];
    out.par_chunks_mut(nx).enumerate().for_each_init(
        || (Scratch::boxed(), Vec::with_capacity(nx)),
        |(scratch, points), (r, labels)| {
            let (j, k) = (r % ny, slices[r / ny]);
            points.clear();
            points.extend((0..nx).map(|i| grid.world(i, j, k).map(|v| v as f32)));
            let times = vec![t as f32; nx];
            model
                .label_batch(scratch, points, &times, labels)
                .expect("sized to the row");
        },
    );
    out
}

fn main() -> Result<()> {
    let a = parse()?;
    let bytes = trained_model(&a)?;
    let model = bytes.model()?;
    let pruned = Evaluation::Pruned { safety: a.safety };
    println!(
        "label volumes, pruned (safety {}) against dense, {} threads",
        a.safety,
        rayon::current_num_threads()
    );

    // 80³ × 37 over the benchmark's cube.
    let times: Vec<f64> = (0..37).map(|i| i as f64 / 36.0).collect();
    let grid = VoxelGrid::from_bounds([-1.0; 3], [1.0; 3], [2.0 / 80.0; 3], times)?;
    let n = grid.voxels_per_frame();
    let (mut dense, mut fast) = (vec![0u32; n], vec![0u32; n]);
    let (mut ratios, mut evaluated, mut differ) = (Vec::new(), 0u64, 0usize);
    let (mut t_dense, mut t_pruned) = (0.0, 0.0);
    let step = 36 / (a.frames.max(2) - 1);
    for f in (0..37).step_by(step.max(1)).take(a.frames.max(1)) {
        let t = grid.times[f];
        let start = Instant::now();
        label_indices_with(&model, &grid, t, Evaluation::Dense, &mut dense)?;
        let d = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let stats = label_indices_with(&model, &grid, t, pruned, &mut fast)?;
        let p = start.elapsed().as_secs_f64();
        differ += dense.iter().zip(&fast).filter(|(x, y)| x != y).count();
        evaluated += stats.evaluated;
        ratios.push(d / p);
        (t_dense, t_pruned) = (t_dense + d, t_pruned + p);
        println!(
            "80³ frame {f:2}: dense {d:.3} s, pruned {p:.3} s, {:.1}x, {:.2}% of voxels evaluated",
            d / p,
            100.0 * stats.evaluated as f64 / n as f64
        );
    }
    let measured = ratios.len();
    println!(
        "80³ × {measured} frames: median ratio {:.1}x (total {:.1}x), {:.2}% evaluated, {differ} voxels differ",
        median(ratios),
        t_dense / t_pruned,
        100.0 * evaluated as f64 / (measured * n) as f64
    );

    // One 512 × 512 × 300 frame over the same cube, at t = 0.5.
    let dims = [512usize, 512, 300];
    let spacing = std::array::from_fn(|a| 2.0 / dims[a] as f64);
    let grid = VoxelGrid::from_bounds([-1.0; 3], [1.0; 3], spacing, vec![0.5])?;
    assert_eq!(grid.dims, dims);
    let n = grid.voxels_per_frame();
    let mut fast = vec![0u32; n];
    let start = Instant::now();
    let stats = label_indices_with(&model, &grid, 0.5, pruned, &mut fast)?;
    let p = start.elapsed().as_secs_f64();
    let slices: Vec<usize> = (0..a.slices.max(1))
        .map(|i| (2 * i + 1) * dims[2] / (2 * a.slices.max(1)))
        .collect();
    let start = Instant::now();
    let dense = dense_slices(&model, &grid, 0.5, &slices);
    let d = start.elapsed().as_secs_f64() * (dims[2] as f64 / slices.len() as f64);
    let plane = dims[0] * dims[1];
    let differ: usize = slices
        .iter()
        .enumerate()
        .map(|(s, &k)| {
            let got = &fast[k * plane..][..plane];
            let want = &dense[s * plane..][..plane];
            got.iter().zip(want).filter(|(x, y)| x != y).count()
        })
        .sum();
    println!(
        "512×512×300 frame: pruned {p:.2} s, dense {d:.1} s (from {} slices), {:.1}x, {:.3}% of \
         voxels evaluated, {differ} of {} compared voxels differ",
        slices.len(),
        d / p,
        100.0 * stats.evaluated as f64 / n as f64,
        slices.len() * plane
    );
    Ok(())
}
