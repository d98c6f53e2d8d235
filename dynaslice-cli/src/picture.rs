//! `dynaslice picture MODEL INPUT -o FIG.png`: predicted labels and input contours on a plane.

use super::input::{self, InputArgs};
use super::model::ModelFile;
use super::options::finite_f64;
use super::output::{write_via, Kind, Plan};
use anyhow::{bail, Context, Result};
use dynaslice_figures::picture::{plane_labels, Panel};
use std::path::PathBuf;

/// Extra times one picture shows at most (each is a panel of the picture).
const MAX_PANELS: usize = 64;

/// Arguments of `dynaslice picture`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    #[command(flatten)]
    input: InputArgs,
    /// Output picture (.png).
    #[arg(short, long)]
    output: PathBuf,
    /// Annotated frame whose plane and contours are shown (index into the selected frames).
    #[arg(long, default_value_t = 0)]
    frame: usize,
    /// Plane of that frame (default: the one with the most contour length).
    #[arg(long)]
    plane: Option<usize>,
    /// Extra times (world units) shown on the same plane without contours; default: halfway
    /// to the next annotated frame.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true,
          value_parser = finite_f64)]
    times: Option<Vec<f64>>,
}

/// Runs `dynaslice picture`: the labels on one input plane (by default the frame's plane with
/// the longest contours) at the frame's time, with its contours, and at the extra times
/// (by default midway to the next frame), written as one PNG.
pub fn run(a: Args) -> Result<()> {
    let inputs = [&a.model]
        .into_iter()
        .chain(&a.input.inputs)
        .chain(&a.input.label_names);
    Plan::new(inputs, true).file("-o", &a.output, Kind::Png)?;
    if a.times.as_ref().is_some_and(|t| t.len() > MAX_PANELS) {
        bail!("--times: at most {MAX_PANELS} extra times fit one picture");
    }
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let seq = input::read(&a.input)?;
    let frames = seq.frames();
    let Some(frame) = frames.get(a.frame) else {
        bail!(
            "{}: --frame {} but the input has {} frames",
            a.input.describe(),
            a.frame,
            frames.len()
        );
    };
    let length = |i: usize| -> f64 {
        frame.planes[i]
            .annotations
            .iter()
            .flat_map(|an| &an.polygons)
            .map(|p| {
                (0..p.len())
                    .map(|j| {
                        (p[j][0] - p[(j + 1) % p.len()][0]).hypot(p[j][1] - p[(j + 1) % p.len()][1])
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    let plane_index = match a.plane {
        Some(p) if p < frame.planes.len() => p,
        Some(p) => bail!(
            "{}: --plane {p} but frame {} has {} planes",
            a.input.describe(),
            a.frame,
            frame.planes.len()
        ),
        None => (0..frame.planes.len())
            .max_by(|&i, &j| length(i).total_cmp(&length(j)))
            .context("the frame has no plane")?,
    };
    let plane = &frame.planes[plane_index];
    let extra = match a.times {
        Some(t) => t,
        None => match frames.get(a.frame + 1) {
            Some(next) => vec![0.5 * (frame.time + next.time)],
            None => vec![],
        },
    };
    let mut panels = vec![Panel {
        time: frame.time,
        title: format!("t = {:.4} (annotated), plane {plane_index}", frame.time),
        contours: Some(plane),
    }];
    panels.extend(extra.iter().map(|&t| Panel {
        time: t,
        title: format!("t = {t:.4} (not annotated)"),
        contours: None,
    }));
    write_via(&a.output, |tmp| {
        plane_labels(&model, &seq, plane, &panels, tmp)
    })?;
    eprintln!("wrote {}", a.output.display());
    Ok(())
}
