//! `dynaslice report MODEL -o report.html`: one self-contained page (dynaslice_report) of what
//! the model was trained on and how, its classes, the figures of `dynaslice measure` as charts
//! and tables, and its surfaces in 3D at several times; with the model's input, a plane of it
//! that follows the 3D view's slider.

use super::console::errln;
use super::input::{self, InputArgs};
use super::measure;
use super::options::{count, time_series, MAX_MESH_RESOLUTION, MAX_TIMES};
use super::progress::Progress;
use super::times::times_option;
use anyhow::{Context, Result};
use dynaslice_data::TimeSeries;
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::measurement::times_of;
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};
use dynaslice_train::fit::RunFiles;
use std::path::PathBuf;

/// Arguments of `dynaslice report`.
#[derive(clap::Args, Debug)]
#[command(
    // The input is optional: without it the page has no plane view.
    mut_arg("inputs", |a| a.required(false)),
    after_help = "\
The page holds: the input (what the model was trained on, its units and patient frame), the
training (the model file's record and the loss curve from MODEL.dsm.loss.csv beside the model,
when present), the classes with their names, labels and colours, the volume over time and the
centroid's trajectory along each axis as charts, the per-class figures over the cycle and the
per-time table (the numbers of `dynaslice measure` with the same --times and --resolution, digit
for digit), the surfaces in an interactive 3D view (WebGL: turn, zoom and pan with the mouse,
play or slide through every time, a toggle per class, the volumes at the time shown) and as
pictures at 4 times. With the model's input (INPUT…, read with the same options as when
training), a plane view below the 3D view follows the slider: the first frame's plane with the
most contour, the model's predicted labels on it at the time shown and the input's contours
where that time is annotated (as `dynaslice picture`). Images and the view's data are inline:
the one file opens in any browser without a network.")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    #[command(flatten)]
    input: InputArgs,
    /// Output page (.html).
    #[arg(short, long, value_name = "REPORT.html")]
    output: PathBuf,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: as
    /// `dynaslice measure`).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Meshing lattice cells along the longest axis of the model's domain (measurements and
    /// the 3D picture).
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    resolution: u32,
    /// Replace an existing page (a symbolic link there is replaced, its target left alone).
    #[arg(long)]
    force: bool,
}

/// Runs `dynaslice report`: the page of [`dynaslice_report::assemble`], written atomically.
pub fn run(a: Args) -> Result<()> {
    let loss_csv = RunFiles::beside(&a.model).csv;
    let inputs = [&a.model, &loss_csv]
        .into_iter()
        .chain(&a.input.given.inputs)
        .chain(&a.input.given.label_names);
    let mut plan = Plan::new(inputs, a.force);
    plan.file("-o", &a.output, Kind::Html)?;
    let file = ModelFile::open(&a.model)?;
    let times = times_of(&file, a.times.as_ref(), &times_option(a.times.as_ref()))?;
    let m = measure::measure(&file, &times, a.resolution)?;
    let seq = if a.input.given.inputs.is_empty() {
        None
    } else {
        Some(input::read_as_trained(&a.input, &file)?)
    };
    let input = seq.as_ref().map(|sequence| dynaslice_report::Input {
        sequence,
        name: a.input.describe(),
    });
    // Drawing the charts, surfaces and plane pictures takes tens of seconds: a line every few seconds.
    let drawing = Progress::new("drawing the report's charts, surfaces and pictures", 1);
    let html = dynaslice_report::assemble_with_input(&file, &m, Some(&loss_csv), input.as_ref())?
        .to_html();
    drawing.inc();
    drawing.finish();
    write_via(&a.output, |tmp| {
        std::fs::write(tmp, &html).with_context(|| format!("cannot write {}", tmp.display()))
    })?;
    errln!("wrote {} ({} KiB)", a.output.display(), html.len() / 1024);
    Ok(())
}
