//! `dynaslice eval …`: accuracy of a model against ground truth (synthetic benchmark, reference
//! mesh), on held-out slices, and its class volumes over time. Definitions: docs/metrics.md.

use super::input::{self, InputArgs};
use super::model::ModelFile;
use anyhow::{bail, Context, Result};
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::native;
use dynaslice_data::synth::{BenchmarkOptions, Shape};
use dynaslice_data::TimeSeries;
use dynaslice_figures::plot::volume_chart;
use dynaslice_metrics::benchmark::{Resolution, Scores, Truth};
use dynaslice_metrics::chamfer::{self, DEFAULT_SAMPLES};
use dynaslice_metrics::heldout::{self, Split, DEFAULT_PIXELS};
use dynaslice_metrics::volume::volume_curve;
use dynaslice_metrics::Frames;
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
    #[arg(long, default_value_t = 64)]
    resolution: usize,
    /// Lattice cells per axis for the model's meshes.
    #[arg(long, default_value_t = 128)]
    mesh_resolution: u32,
    /// Lattice cells per axis for the exact shapes' meshes.
    #[arg(long, default_value_t = 256)]
    truth_resolution: u32,
    /// Area-uniform samples per surface for the Chamfer distance.
    #[arg(long, default_value_t = DEFAULT_SAMPLES)]
    samples: usize,
    /// Per-frame CSV (IoU and CD×10⁴ per class).
    #[arg(long)]
    csv: Option<PathBuf>,
}

#[derive(clap::Args, Debug)]
struct ReferenceArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// Reference surface (.stl, binary or ASCII), in the model's world coordinates.
    reference: PathBuf,
    /// World time of the model's surface (default: the start of its time range).
    #[arg(long, allow_negative_numbers = true)]
    time: Option<f64>,
    /// Class compared with the reference, 1..K.
    #[arg(long, default_value_t = 1)]
    class: usize,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = 128)]
    mesh_resolution: u32,
    /// Area-uniform samples per surface.
    #[arg(long, default_value_t = DEFAULT_SAMPLES)]
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
    #[arg(long, default_value_t = DEFAULT_PIXELS)]
    pixels: usize,
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
}

#[derive(clap::Args, Debug)]
struct VolumeArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// N times evenly from A to B inclusive (default: the model's time range in 20 steps).
    #[arg(long, value_name = "A:B:N", allow_hyphen_values = true)]
    times: Option<TimeSeries>,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = 128)]
    resolution: u32,
    /// Output CSV; the chart is written beside it as .png.
    #[arg(short, long)]
    output: PathBuf,
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
    let annotated_frames = a.annotated.indices(bench.timesteps);
    let resolution = Resolution {
        iou: a.resolution,
        mesh: a.mesh_resolution,
        truth: a.truth_resolution,
        samples: a.samples,
    };
    let truth = Truth::new(shape, &annotated_frames, resolution)?;
    let Scores { iou, cd } = truth
        .score(&model)
        .with_context(|| a.model.display().to_string())?;
    println!(
        "{} ({} classes), {} frames ({} annotated): 3D IoU on a {}³ grid over [-1, 1]³; \
         CD×10⁴ over {} samples per surface, unit-normalised by the domain diagonal 2√3",
        shape.name(),
        names.len(),
        iou.times.len(),
        annotated_frames.len(),
        a.resolution,
        a.samples
    );
    println!("| | IoU | CD×10⁴ |\n|---|---|---|");
    for (label, frames) in [
        ("all frames", Frames::All),
        ("annotated", Frames::Annotated),
        ("unannotated", Frames::Unannotated),
    ] {
        println!(
            "| {label} | {} | {} |",
            fmt(iou.mean(frames), 4),
            fmt(cd.mean(frames), 3)
        );
    }
    for (c, name) in names.iter().enumerate() {
        println!(
            "| class {} {name} | {} | {} |",
            c + 1,
            fmt(iou.class_mean(c, Frames::All), 4),
            fmt(cd.class_mean(c, Frames::All), 3)
        );
    }
    if let Some(path) = &a.csv {
        let s = Scores { iou, cd }.to_csv(names);
        std::fs::write(path, s).with_context(|| format!("cannot write {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn reference(a: ReferenceArgs) -> Result<()> {
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let k = model.num_classes();
    if !(1..=k).contains(&a.class) {
        bail!(
            "{}: --class {} but the model has classes 1..{k}",
            a.model.display(),
            a.class
        );
    }
    if a.samples == 0 {
        bail!("--samples 0: the Chamfer distance needs at least 1 sample per surface");
    }
    let reference = dynaslice_mesh::io::read_stl(&a.reference)?;
    let t = a.time.unwrap_or(f64::from(model.domain().time_range().0));
    let cd = chamfer::against_reference(
        &model,
        a.class - 1,
        t as f32,
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
    println!(
        "CD×10⁴ = {:.4} (model → reference {:.4}, reference → model {:.4}); {} samples per \
         surface, unit-normalised by the reference's bounding-box diagonal {diagonal:.4}",
        cd.scaled(),
        cd.to_reference * 1e4,
        cd.from_reference * 1e4,
        a.samples
    );
    Ok(())
}

fn held_out(a: HeldoutArgs) -> Result<()> {
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let seq = input::read(&a.input)?;
    let split = a.holdout.split();
    let scores = heldout::held_out(&model, &seq, &split, a.pixels)
        .with_context(|| format!("{} on {}", a.model.display(), a.input.input.display()))?;
    let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    println!(
        "2D IoU on withheld slices ({} pixels along each region's longer side)",
        a.pixels
    );
    println!("| | planes | mean | {} |", names.join(" | "));
    println!("|---|---|---|{}", "---|".repeat(names.len()));
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
        println!("| {label} | {n} | {} | {} |", fmt(mean, 4), per.join(" | "));
    }
    Ok(())
}

fn split(a: SplitArgs) -> Result<()> {
    let seq = input::read(&a.input)?;
    let train = a
        .holdout
        .split()
        .training(&seq)
        .with_context(|| format!("{}", a.input.input.display()))?;
    native::write(&train, &a.output)?;
    let planes =
        |s: &dynaslice_data::Sequence| s.frames().iter().map(|f| f.planes.len()).sum::<usize>();
    eprintln!(
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
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let times = match a.times {
        Some(series) => series.times(),
        None => {
            let (t0, t1) = model.domain().time_range();
            TimeSeries::across(t0, t1, 20)
                .map_err(anyhow::Error::msg)?
                .times()
        }
    };
    let curve = volume_curve(&model, &times, a.resolution)?;
    curve.write_csv(&a.output)?;
    let png = a.output.with_extension("png");
    let title = format!("class volumes of {}", a.model.display());
    volume_chart(&png, &title, &curve.classes, &curve.times, &curve.volumes)?;
    eprintln!("wrote {} and {}", a.output.display(), png.display());
    for (c, name) in curve.classes.iter().enumerate() {
        let v: Vec<f64> = curve.volumes.iter().map(|v| v[c]).collect();
        let (lo, hi) = v
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), &x| (l.min(x), h.max(x)));
        println!(
            "class {} {name:?}: volume {lo:.6} to {hi:.6} (world units³)",
            c + 1
        );
    }
    Ok(())
}
