//! `dynaslice-lab results`: reproduce the paper's tables and write them as markdown
//! (lab/results/results.md), rewritten after every run so a killed job keeps what it measured.

use crate::experiments::multiclass::{self, Sharing, SharingRun};
use crate::experiments::reference::{self, CaseRun};
use crate::experiments::synthetic::{self, Run, Scene, Variant};
use crate::experiments::Protocol;
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_cli::loss::LossArgs;
use dynaslice_data::frame_range::FrameRange;
use dynaslice_data::nifti::read_volume;
use dynaslice_data::reslice::{reslice, ResliceOptions};
use dynaslice_data::LabelTable;
use dynaslice_metrics::benchmark::Resolution;
use dynaslice_metrics::heldout::Split;
use dynaslice_output::write_atomically;
use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};
use dynaslice_train::data_sampler::SampleCounts;
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::temporal_bound::DEFAULT_TEMPORAL_FACTOR;
use dynaslice_train::trainer::TrainOptions;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Arguments of `dynaslice-lab results`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Markdown output (the trained models are written beside it, in `<name>.models/`).
    #[arg(short, long, default_value = "lab/results/results.md")]
    output: PathBuf,
    /// Tables: synthetic (Table 3), multiclass (Table 2), static (.csl against reference meshes).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "synthetic,multiclass,static"
    )]
    tables: Vec<String>,
    /// Training time per model in minutes, as a step count calibrated per input at the start
    /// (every model of a table then runs exactly those steps).
    #[arg(long, default_value_t = 5.0)]
    minutes: f64,
    /// Steps of every model instead of calibrating `--minutes` (the multi-class table's
    /// equal-time independent models still take 1/K of `--minutes` each): a comparison of
    /// settings that the machine's load cannot tilt.
    #[arg(long)]
    steps: Option<u64>,
    /// Shapes of the synthetic table (blob, tube, torus, chambers).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "blob,tube,torus,chambers"
    )]
    shapes: Vec<Shape>,
    /// Variants of the synthetic table: siren (4D SIREN), orientation (+ orientation), full.
    #[arg(long, value_delimiter = ',', default_value = "siren,orientation,full")]
    variants: Vec<String>,
    /// Shared data folder with nifti/example_seg.nii.gz and csl/ (tables that need it are
    /// skipped, with a message, when it is absent).
    #[arg(long, default_value = "../shared/data")]
    data: PathBuf,
    /// Inputs of the multi-class table: chambers (synthetic), organs (the real CT).
    #[arg(long, value_delimiter = ',', default_value = "chambers,organs")]
    cases: Vec<String>,
    /// Ways of sharing of the multi-class table (those that apply to each input).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "independent,independent-equal-time,shared,shared-no-temporal"
    )]
    sharings: Vec<Sharing>,
    /// Steps of each equal-time independent model, instead of calibrating them to 1/K of
    /// --minutes (to give them a wall time measured in an earlier run).
    #[arg(long)]
    equal_time_steps: Option<u64>,
    /// Classes of the real multi-organ table: the largest labels of the segmentation.
    #[arg(long, default_value_t = 5)]
    organs: usize,
    /// Cells per axis of the 3D IoU grids.
    #[arg(long, default_value_t = 64)]
    resolution: usize,
    /// Lattice cells along the longest axis for the models' meshes.
    #[arg(long, default_value_t = 96)]
    mesh_resolution: u32,
    /// Lattice cells per axis for the exact shapes' meshes.
    #[arg(long, default_value_t = 192)]
    truth_resolution: u32,
    /// Area-uniform samples per surface for the Chamfer distance.
    #[arg(long, default_value_t = dynaslice_metrics::chamfer::DEFAULT_SAMPLES)]
    cd_samples: usize,
    /// Pixels along the longer side of each withheld plane (held-out 2D IoU).
    #[arg(long, default_value_t = 128)]
    pixels: usize,
    /// Widths of the sine layers.
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256")]
    widths: Vec<u32>,
    /// Initial learning rate.
    #[arg(long, default_value_t = TrainOptions::default().lr)]
    lr: f32,
    /// Learning-rate warm-up steps of every model (see `dynaslice train --help`).
    #[arg(long, default_value_t = TrainOptions::default().warmup_steps)]
    warmup_steps: u64,
    /// Worker threads.
    #[arg(long, default_value_t = TrainOptions::default().threads)]
    threads: usize,
    /// Contour and plane samples per class, and space-time samples, per step.
    #[arg(long, default_value_t = SampleCounts::default().space)]
    samples: usize,
    /// c of ω_t^max = c·π/Δt (Eq. 4) for the variants with temporal control.
    #[arg(long, default_value_t = DEFAULT_TEMPORAL_FACTOR)]
    temporal_factor: f32,
    /// ω₀: the first layer's spatial frequency scale over the normalised cube.
    #[arg(long, default_value_t = TrainOptions::default().omega_0)]
    omega0: f32,
    /// Initial value of every channel, normalised units (see `dynaslice train --help`).
    #[arg(long, default_value_t = TrainOptions::default().offset)]
    init_offset: f32,
    /// Seeds per (shape, variant) of the synthetic table and per (input, way of sharing) of the
    /// multi-class one, 0..N: the tables show their mean (one seed's ranking of two variants can
    /// flip with the next seed).
    #[arg(long, default_value_t = 3)]
    seeds: u64,
    /// Loss weights; the ablations set λ_n to 0.
    #[command(flatten)]
    loss: LossArgs,
}

fn variant(name: &str) -> Result<Variant> {
    Variant::ALL
        .into_iter()
        .find(|v| v.key() == name)
        .ok_or_else(|| anyhow!("unknown variant {name:?} (expected siren, orientation or full)"))
}

/// Everything measured so far, rendered as one document.
struct Report {
    command: String,
    protocol: Protocol,
    synthetic_resolution: Resolution,
    static_resolution: reference::Resolution,
    synthetic: Vec<Run>,
    multiclass: Vec<(multiclass::Case, Vec<SharingRun>)>,
    statics: Vec<CaseRun>,
    skipped: Vec<String>,
}

impl Report {
    fn markdown(&self) -> String {
        let mut s = String::from("# Results\n\n");
        s += &format!(
            "Regenerate with `{}` (one model per row and input, each trained for the given \
             minutes, plus scoring). Written by that command; every figure below is its \
             output.\n\n",
            self.command
        );
        for why in &self.skipped {
            s += &format!("- skipped: {why}\n");
        }
        if !self.skipped.is_empty() {
            s.push('\n');
        }
        if !self.synthetic.is_empty() {
            s += &synthetic::markdown(&self.synthetic, &self.protocol, self.synthetic_resolution);
        }
        if !self.multiclass.is_empty() {
            s += "## Table 2 idea: one shared multi-class model against independent models\n\n";
            for (case, runs) in &self.multiclass {
                s += &multiclass::markdown(case, runs, &self.protocol);
            }
        }
        if !self.statics.is_empty() {
            s += &reference::markdown(&self.statics, &self.protocol, self.static_resolution);
        }
        s
    }

    fn write(&self, path: &Path) -> Result<()> {
        write_atomically(path, self.markdown().as_bytes())
    }
}

pub fn run(a: Args) -> Result<()> {
    let variants = a
        .variants
        .iter()
        .map(|v| variant(v))
        .collect::<Result<Vec<_>>>()?;
    for t in &a.tables {
        if !["synthetic", "multiclass", "static"].contains(&t.as_str()) {
            bail!("unknown table {t:?} (expected synthetic, multiclass or static)");
        }
    }
    let wants = |t: &str| a.tables.iter().any(|x| x == t);
    let protocol = Protocol {
        minutes: a.minutes,
        steps: a.steps,
        spec: a.loss.apply(TrainSpec {
            widths: Some(a.widths.clone()),
            threads: Some(a.threads.max(1)),
            lr: Some(a.lr),
            warmup_steps: Some(a.warmup_steps),
            omega0: Some(a.omega0),
            init_offset: Some(a.init_offset),
            contour_samples: Some(a.samples),
            plane_samples: Some(a.samples),
            space_samples: Some(a.samples),
            temporal_factor: Some(a.temporal_factor),
            ..TrainSpec::default()
        }),
    };
    // Every option checked, by the rules `dynaslice train` applies, before any work.
    protocol.spec.validate()?;
    let command = std::iter::once("dynaslice-lab".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    if let Some(dir) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let models = a.output.with_extension("models");
    std::fs::create_dir_all(&models)
        .with_context(|| format!("cannot create {}", models.display()))?;
    let save = |name: String, bytes: &[u8]| write_atomically(&models.join(name), bytes);
    let mut report = Report {
        command,
        protocol: protocol.clone(),
        synthetic_resolution: Resolution {
            iou: a.resolution,
            mesh: a.mesh_resolution,
            truth: a.truth_resolution,
            samples: a.cd_samples,
        },
        static_resolution: reference::Resolution {
            mesh: a.mesh_resolution,
            iou: a.resolution,
            samples: a.cd_samples,
        },
        synthetic: Vec::new(),
        multiclass: Vec::new(),
        statics: Vec::new(),
        skipped: Vec::new(),
    };
    if wants("synthetic") {
        for &shape in &a.shapes {
            let scene = Scene::new(shape, report.synthetic_resolution)?;
            let steps = scene.calibrate(&protocol)?;
            for seed in 0..a.seeds.max(1) {
                for &v in &variants {
                    eprintln!(
                        "{} / {} / seed {seed}: {steps} steps",
                        shape.name(),
                        v.name()
                    );
                    let run = scene.run(v, seed, &protocol, steps)?;
                    eprintln!("{}", run.summary());
                    save(
                        format!("{}_{}_seed{seed}.dsm", shape.name(), v.key()),
                        &run.fitted.bytes,
                    )?;
                    report.synthetic.push(run);
                    report.write(&a.output)?;
                }
            }
        }
    }
    if wants("multiclass") {
        for c in &a.cases {
            if !["chambers", "organs"].contains(&c.as_str()) {
                bail!("unknown multi-class case {c:?} (expected chambers or organs)");
            }
        }
        let mut cases = Vec::new();
        if a.cases.iter().any(|c| c == "chambers") {
            cases.push(chambers_case(a.pixels)?);
        }
        if a.cases.iter().any(|c| c == "organs") {
            match organs_case(&a.data, a.organs, a.pixels) {
                Ok(case) => cases.push(case),
                Err(e) => {
                    let why = format!("the real multi-organ case: {e:#}");
                    eprintln!("skipped {why}");
                    report.skipped.push(why);
                }
            }
        }
        for mut case in cases {
            case.equal_time_steps = a.equal_time_steps;
            let steps = case.calibrate(&protocol)?;
            report.multiclass.push((case, Vec::new()));
            let i = report.multiclass.len() - 1;
            for seed in 0..a.seeds.max(1) {
                let sharings = report.multiclass[i].0.sharings();
                for sharing in sharings.into_iter().filter(|s| a.sharings.contains(s)) {
                    let case = &report.multiclass[i].0;
                    eprintln!("{} / {} / seed {seed}", case.name, sharing.name());
                    // The run reports its own steps: equal-time independents calibrate theirs.
                    let run = case.run(sharing, seed, &protocol, steps)?;
                    eprintln!("  {} steps per model, {:.0} s", run.steps, run.seconds);
                    report.multiclass[i].1.push(run);
                    report.write(&a.output)?;
                }
            }
        }
    }
    if wants("static") {
        let dir = a.data.join("csl");
        for name in ["eight_15", "hand_ok", "balloondog"] {
            let case = match reference::Case::read(&dir, name) {
                Ok(case) => case,
                Err(e) => {
                    let why = format!("{name}: {e:#}");
                    eprintln!("skipped {why}");
                    report.skipped.push(why);
                    continue;
                }
            };
            let steps = case.calibrate(&protocol)?;
            eprintln!("{name}: {steps} steps");
            let run = case.run(&protocol, steps, report.static_resolution)?;
            eprintln!(
                "{name}: CD×10⁴ {:?}, IoU {:?} in {:.0} s",
                run.cd, run.iou, run.fitted.seconds
            );
            save(format!("{name}.dsm"), &run.fitted.bytes)?;
            report.statics.push(run);
            report.write(&a.output)?;
        }
    }
    report.write(&a.output)?;
    println!("{}", report.markdown());
    Ok(())
}

/// The benchmark's chambers (10 annotated frames of 15 + 15 planes), withholding every 3rd
/// frame from frame 1 and every 4th plane from plane 3.
fn chambers_case(pixels: usize) -> Result<multiclass::Case> {
    let seq = slice_sequence(Shape::Chambers, &BenchmarkOptions::default())?;
    Ok(multiclass::Case {
        name: "Synthetic chambers".into(),
        source: "`dynaslice synth --shape chambers`, its 10 annotated frames".into(),
        seq,
        split: Split {
            frames: Some(FrameRange {
                start: 1,
                end: None,
                step: 3,
            }),
            planes: Some(FrameRange {
                start: 3,
                end: None,
                step: 4,
            }),
        },
        pixels,
        equal_time_steps: None,
    })
}

/// The TotalSegmentator volume's `organs` largest labels, resliced by the paper's protocol
/// (20 rotated planes, every 2nd axial slice), withholding every 4th plane from plane 3.
fn organs_case(data: &Path, organs: usize, pixels: usize) -> Result<multiclass::Case> {
    let path = data.join("nifti/example_seg.nii.gz");
    if !path.exists() {
        bail!("{} is absent", path.display());
    }
    let volume = read_volume(&path)?;
    let mut counts: HashMap<i32, usize> = HashMap::new();
    for &l in volume.labels.iter().filter(|&&l| l != 0) {
        *counts.entry(l).or_default() += 1;
    }
    let mut by_size: Vec<(i32, usize)> = counts.into_iter().collect();
    by_size.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let mut labels: Vec<i32> = by_size.iter().take(organs.max(1)).map(|l| l.0).collect();
    labels.sort_unstable();
    let options = ResliceOptions {
        labels: Some(labels.clone()),
        ..ResliceOptions::default()
    };
    let split = Split {
        frames: None,
        planes: Some(FrameRange {
            start: 3,
            end: None,
            step: 4,
        }),
    };
    let mut seq =
        reslice(&volume, &options, &LabelTable::default()).map_err(|e| e.in_file(&path))?;
    // A small organ may be crossed only by withheld planes: nothing to train it on. Such
    // labels are dropped, and the caption says which.
    let frame = &seq.frames()[0];
    let count = frame.planes.len();
    let trained: Vec<i32> = seq
        .classes()
        .iter()
        .enumerate()
        .filter(|&(c, _)| {
            frame.planes.iter().enumerate().any(|(i, plane)| {
                !split.planes.is_some_and(|r| r.contains(i, count))
                    && plane.annotation(c).is_some_and(|a| !a.polygons.is_empty())
            })
        })
        .map(|(_, class)| class.label)
        .collect();
    let dropped: Vec<i32> = labels
        .iter()
        .copied()
        .filter(|l| !trained.contains(l))
        .collect();
    if !dropped.is_empty() {
        eprintln!("organs: labels {dropped:?} lie only on withheld planes; dropped");
        let options = ResliceOptions {
            labels: Some(trained.clone()),
            ..ResliceOptions::default()
        };
        seq = reslice(&volume, &options, &LabelTable::default()).map_err(|e| e.in_file(&path))?;
    }
    let dropped_text = if dropped.is_empty() {
        String::new()
    } else {
        format!(
            "; labels {dropped:?} dropped: only withheld planes cross them, so nothing trains them"
        )
    };
    Ok(multiclass::Case {
        name: "TotalSegmentator CT segmentation (real, static)".into(),
        source: format!(
            "`{}`, its {} largest labels ({trained:?}) resliced by the paper's protocol (20 \
             rotated + every 2nd axial plane){dropped_text}",
            path.display(),
            trained.len()
        ),
        seq,
        split,
        pixels,
        equal_time_steps: None,
    })
}
