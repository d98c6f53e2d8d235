//! `dynaslice eval …`: accuracy of a model against ground truth (synthetic benchmark, reference
//! mesh), on held-out slices, and its class volumes over time. Definitions: docs/metrics.md.

use super::console::{errln, outln};
use super::input::regular_file;
use super::input::{self, InputArgs};
use super::memory::{self, MemoryArgs};
use super::options::{
    count, finite_f32, time_series, MAX_CHAMFER_SAMPLES, MAX_IOU_RESOLUTION, MAX_MESH_RESOLUTION,
    MAX_PIXELS, MAX_TIMES,
};
use super::progress::Progress;
use super::times::{model_times, times_option};
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::format::MAX_CLASSES;
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::TimeSeries;
use dynaslice_figures::plot::volume_chart;
use dynaslice_mesh::lattice::MIN_RESOLUTION;
use dynaslice_metrics::benchmark::{Resolution, Scores, Truth};
use dynaslice_metrics::chamfer::{self, DEFAULT_SAMPLES};
use dynaslice_metrics::heldout::{self, Split, DEFAULT_PIXELS};
use dynaslice_metrics::volume::volume_curve_with;
use dynaslice_metrics::Frames;
use dynaslice_model::ModelFile;
use dynaslice_output::write_atomically;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};
use dynaslice_sequence::native;
use dynaslice_synth::{BenchmarkOptions, Shape};
use dynaslice_train::data_sampler::domain_for;
use dynaslice_train::model_file::check_model_limits;
use std::path::PathBuf;

/// Arguments of `dynaslice eval`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Examples:
  dynaslice eval synthetic model.dsm --shape chambers --csv frames.csv
  dynaslice eval reference model.dsm eight_15_reference.stl
  dynaslice eval split seg.nii.gz --holdout-planes 3::4 -o train.json
  dynaslice train train.json -o model.dsm
  dynaslice eval heldout model.dsm seg.nii.gz --holdout-planes 3::4
  dynaslice eval volume model.dsm --times 0:1:37 -o volumes.csv

Definitions of every score: docs/metrics.md.")]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand, Debug)]
enum What {
    /// 3D IoU and Chamfer distance against a synthetic benchmark shape at every frame, split
    /// into annotated and unannotated frames.
    Synthetic(SyntheticArgs),
    /// Chamfer distance of one class against a reference mesh (STL) at one time.
    Reference(ReferenceArgs),
    /// 2D IoU on the planes and frames a split withheld (spatial, temporal, spatio-temporal).
    Heldout(HeldoutArgs),
    /// Write the training input of a held-out split (native JSON) for `dynaslice train`.
    Split(SplitArgs),
    /// Each class's volume over time: CSV and a PNG chart beside it.
    Volume(VolumeArgs),
}

#[derive(clap::Args, Debug)]
struct SyntheticArgs {
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
    #[arg(long, default_value_t = 128, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
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

#[derive(clap::Args, Debug)]
struct ReferenceArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// Reference surface (.stl, binary or ASCII), in the model's world coordinates.
    reference: PathBuf,
    /// World time of the model's surface, within its time range (default: its start).
    #[arg(long, allow_negative_numbers = true, value_parser = finite_f32)]
    time: Option<f32>,
    /// Class compared with the reference, 1..K.
    #[arg(long, default_value_t = 1, value_parser = count(1, MAX_CLASSES))]
    class: usize,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = 128, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    mesh_resolution: u32,
    /// Area-uniform samples per surface.
    #[arg(long, default_value_t = DEFAULT_SAMPLES, value_parser = count(1, MAX_CHAMFER_SAMPLES))]
    samples: usize,
}

/// Which frames and planes a split withholds.
#[derive(clap::Args, Debug, Clone)]
struct Holdout {
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
struct HeldoutArgs {
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
struct SplitArgs {
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

#[derive(clap::Args, Debug)]
struct VolumeArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: the model's
    /// time range in 20 steps; a
    /// static model, the same at every time, is measured once).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = 128, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    resolution: u32,
    /// Output CSV (.csv); the chart is written beside it as .png.
    #[arg(short, long)]
    output: PathBuf,
    /// Replace existing files (the CSV and its chart).
    #[arg(long)]
    force: bool,
}

/// Runs `dynaslice eval`: one accuracy measure or the volume curve, printed as a table.
pub fn run(a: Args) -> Result<()> {
    match a.what {
        What::Synthetic(a) => synthetic(a),
        What::Reference(a) => reference(a),
        What::Heldout(a) => held_out(a),
        What::Split(a) => split(a),
        What::Volume(a) => volume(a),
    }
}

fn fmt(v: Option<f64>, digits: usize) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.digits$}"))
}

fn synthetic(a: SyntheticArgs) -> Result<()> {
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
    // The exact surfaces' samples (3 f64 each) of every frame and class, held throughout, and
    // one truth meshing lattice at a time (f64 per vertex and class, hash-map entry).
    let classes = names.len() as f64;
    let samples = bench.timesteps as f64 * classes * a.samples as f64 * 24.0;
    let lattice = (f64::from(a.truth_resolution) + 1.0).powi(3) * (8.0 * classes + 48.0);
    memory::check(
        &format!(
            "--samples {} at --truth-resolution {}",
            a.samples, a.truth_resolution
        ),
        samples + lattice,
        "lower --samples or --truth-resolution",
        a.memory,
    )?;
    let annotated_frames = a.annotated.indices(bench.timesteps);
    let resolution = Resolution {
        iou: a.resolution,
        mesh: a.mesh_resolution,
        truth: a.truth_resolution,
        samples: a.samples,
    };
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

fn reference(a: ReferenceArgs) -> Result<()> {
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let k = model.num_classes();
    let t = match a.time {
        Some(t) => model_times(&file, &a.model, "--time", &[t], "scoring its one surface")?[0],
        None => model.domain().time_range().0,
    };
    if !(1..=k).contains(&a.class) {
        bail!(
            "{}: --class {} but the model has classes 1..{k}",
            a.model.display(),
            a.class
        );
    }
    regular_file("reference mesh", &a.reference)?;
    let reference = dynaslice_mesh::io::read_stl(&a.reference)?;
    let cd = chamfer::against_reference(
        &model,
        a.class - 1,
        t,
        &reference,
        a.mesh_resolution,
        a.samples,
    )?;
    let Some(cd) = cd else {
        bail!(
            "{}: class {} has no surface at time {t}; no Chamfer distance",
            a.model.display(),
            a.class
        );
    };
    let diagonal = chamfer::bounding_diagonal(&reference);
    let when = if file.is_static() {
        format!("(a static model, the same at every time; its time {t})")
    } else {
        format!("at t = {t}")
    };
    outln!(
        "class {} {:?} {when}: CD×10⁴ = {:.4} (model → reference {:.4}, reference → model \
         {:.4}); {} samples per surface, unit-normalised by the reference's bounding-box \
         diagonal {diagonal:.4}",
        a.class,
        model.class(a.class as u32)?.name,
        cd.scaled(),
        cd.to_reference * 1e4,
        cd.from_reference * 1e4,
        a.samples
    )?;
    Ok(())
}

fn held_out(a: HeldoutArgs) -> Result<()> {
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
    for (label, o, n) in [
        ("spatial", &scores.spatial, scores.planes[0]),
        ("temporal", &scores.temporal, scores.planes[1]),
        ("spatio-temporal", &scores.spatio_temporal, scores.planes[2]),
    ] {
        let iou = o.iou();
        let present: Vec<f64> = iou.iter().flatten().copied().collect();
        let mean =
            (!present.is_empty()).then(|| present.iter().sum::<f64>() / present.len() as f64);
        let per: Vec<String> = iou.iter().map(|v| fmt(*v, 4)).collect();
        outln!("| {label} | {n} | {} | {} |", fmt(mean, 4), per.join(" | "))?;
    }
    Ok(())
}

fn split(a: SplitArgs) -> Result<()> {
    let inputs = a.input.inputs.iter().chain(&a.input.label_names);
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

fn volume(a: VolumeArgs) -> Result<()> {
    let png = a.output.with_extension("png");
    let mut plan = Plan::new([&a.model], a.force);
    plan.file("-o", &a.output, Kind::Csv)?;
    plan.beside(&png)?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let option = times_option(a.times.as_ref());
    let requested: Vec<f32> = match a.times {
        // The network takes f32 times.
        Some(series) => series.times().into_iter().map(|t| t as f32).collect(),
        None if file.is_static() => vec![model.domain().time_range().0],
        None => {
            let (t0, t1) = model.domain().time_range();
            TimeSeries::across(t0, t1, 20)
                .map_err(anyhow::Error::msg)?
                .times()
                .into_iter()
                .map(|t| t as f32)
                .collect()
        }
    };
    let times: Vec<f64> = model_times(&file, &a.model, &option, &requested, "measuring once")?
        .into_iter()
        .map(f64::from)
        .collect();
    let progress = Progress::new("measuring class volumes: time", times.len() as u64);
    let curve = volume_curve_with(&model, &times, a.resolution, |i| {
        progress.set_position(i as u64)
    })?;
    progress.finish();
    // In the unit every command reports volumes in: mL for a model of millimetres, the input's
    // plain units³ otherwise.
    let units = file.units();
    let mut curve = curve;
    for v in curve.volumes.iter_mut().flatten() {
        *v = units.from_world_volume(*v);
    }
    write_via(&a.output, |tmp| curve.write_csv(tmp))?;
    let title = format!("class volumes of {}", a.model.display());
    write_via(&png, |tmp| {
        volume_chart(
            tmp,
            &title,
            units.volume(),
            &curve.classes,
            &[],
            &curve.times,
            &curve.volumes,
        )
    })?;
    errln!("wrote {} and {}", a.output.display(), png.display());
    for (c, name) in curve.classes.iter().enumerate() {
        let v: Vec<f64> = curve.volumes.iter().map(|v| v[c]).collect();
        let (lo, hi) = v
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
        outln!(
            "class {} {name:?}: volume {lo:.6} to {hi:.6} {}",
            c + 1,
            units.volume()
        )?;
    }
    Ok(())
}
