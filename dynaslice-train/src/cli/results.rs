//! `dynaslice results`: reproduce the paper's tables and write them as markdown.

use crate::experiments::synthetic::{self, Protocol, Scene, Variant};
use crate::model_file::write_atomically;
use crate::synth::Shape;
use crate::train::data_sampler::SampleCounts;
use crate::train::trainer::TrainOptions;
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `dynaslice results`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Markdown output (a per-frame CSV and the trained models are written beside it).
    #[arg(short, long, default_value = "docs/results.md")]
    output: PathBuf,
    /// Training time per (shape, variant) in minutes, as a step count calibrated per shape at
    /// the start (every variant then runs exactly those steps).
    #[arg(long, default_value_t = 5.0)]
    minutes: f64,
    /// IoU grid resolution (cells per axis).
    #[arg(long, default_value_t = 128)]
    resolution: usize,
    /// Shapes (blob, tube, torus, chambers).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "blob,tube,torus,chambers"
    )]
    shapes: Vec<Shape>,
    /// Variants: siren (4D SIREN), orientation (+ orientation), full (DynaSlice).
    #[arg(long, value_delimiter = ',', default_value = "siren,orientation,full")]
    variants: Vec<String>,
    /// Widths of the sine layers.
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256")]
    widths: Vec<u32>,
    /// Initial learning rate.
    #[arg(long, default_value_t = TrainOptions::default().lr)]
    lr: f32,
    /// Worker threads.
    #[arg(long, default_value_t = TrainOptions::default().threads)]
    threads: usize,
    /// Contour and plane samples per class, and space-time samples, per step.
    #[arg(long, default_value_t = SampleCounts::default().space)]
    samples: usize,
}

fn variant(name: &str) -> Result<Variant> {
    Ok(match name {
        "siren" => Variant::Siren4d,
        "orientation" => Variant::Orientation,
        "full" => Variant::Full,
        other => anyhow::bail!("unknown variant {other:?} (expected siren, orientation or full)"),
    })
}

pub fn run(a: Args) -> Result<()> {
    let variants = a
        .variants
        .iter()
        .map(|v| variant(v))
        .collect::<Result<Vec<_>>>()?;
    let protocol = Protocol {
        minutes: a.minutes,
        resolution: a.resolution,
        options: TrainOptions {
            widths: a.widths.clone(),
            threads: a.threads.max(1),
            lr: a.lr,
            lr_final: a.lr / 10.0,
            ..TrainOptions::default()
        },
        counts: SampleCounts {
            contour_per_class: a.samples,
            plane_per_class: a.samples,
            space: a.samples,
        },
        temporal_factor: 1.0,
    };
    let command = std::iter::once("dynaslice".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    if let Some(dir) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let mut runs = Vec::new();
    let mut csv = String::from("shape,variant,frame,annotated,mean_iou,class_iou\n");
    let models = a.output.with_extension("models");
    std::fs::create_dir_all(&models)
        .with_context(|| format!("cannot create {}", models.display()))?;
    for &shape in &a.shapes {
        let scene = Scene::new(shape)?;
        let steps = scene.calibrate(&protocol)?;
        for &v in &variants {
            let run = scene.run(v, &protocol, steps, &mut |line| eprintln!("{line}"))?;
            for (i, ((iou, annotated), classes)) in run
                .frame_iou
                .iter()
                .zip(&run.annotated)
                .zip(&run.frame_class_iou)
                .enumerate()
            {
                let classes: Vec<String> = classes
                    .iter()
                    .map(|c| c.map_or("".into(), |v| format!("{v:.4}")))
                    .collect();
                writeln!(
                    csv,
                    "{},{},{i},{annotated},{iou},{}",
                    shape.name(),
                    v.name(),
                    classes.join(";")
                )?;
            }
            let file = models.join(format!(
                "{}_{}.dsm",
                shape.name(),
                v.name().split_whitespace().last().unwrap_or("model")
            ));
            write_atomically(&file, &run.model)?;
            runs.push(run);
            // Rewrite after every run so a long job that is killed keeps what it measured.
            write_atomically(
                &a.output,
                synthetic::markdown(&runs, &protocol, &command).as_bytes(),
            )?;
            write_atomically(&a.output.with_extension("frames.csv"), csv.as_bytes())?;
        }
    }
    println!("{}", synthetic::markdown(&runs, &protocol, &command));
    Ok(())
}
