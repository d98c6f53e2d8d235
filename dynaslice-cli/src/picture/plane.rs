//! `dynaslice picture MODEL INPUT -o FIG.png`: predicted labels and input contours on a plane.

use super::{Args, MAX_PANELS};
use crate::console::errln;
use crate::input;
use crate::progress::Progress;
use crate::times::{note, times_option};
use anyhow::{bail, Context, Result};
use dynaslice_figures::picture::{longest_plane, match_classes, plane_labels, undrawn, Panel};
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};

/// Runs `dynaslice picture` without `--3d`: the labels on one input plane (by default the
/// frame's plane with the longest contours) at the frame's time, with its contours, and at the
/// extra times (by default midway to the next frame), written as one PNG.
pub(super) fn run(a: Args) -> Result<()> {
    let inputs = [&a.model]
        .into_iter()
        .chain(&a.input.given.inputs)
        .chain(&a.input.given.label_names);
    let mut plan = Plan::new(inputs, a.force);
    plan.file("-o", &a.output, Kind::Png)?;
    if a.times.as_ref().is_some_and(|t| t.len() > MAX_PANELS) {
        bail!("--times: at most {MAX_PANELS} extra times fit one picture");
    }
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let seq = input::read_as_trained(&a.input, &file)?;
    let frames = seq.frames();
    let Some(frame) = frames.get(a.frame) else {
        bail!(
            "{}: --frame {} but the input has {} frames",
            a.input.describe(),
            a.frame,
            frames.len()
        );
    };
    let plane_index = match a.plane {
        Some(p) if p < frame.planes.len() => p,
        Some(p) => bail!(
            "{}: --plane {p} but frame {} has {} planes",
            a.input.describe(),
            a.frame,
            frame.planes.len()
        ),
        None => longest_plane(frame).context("the frame has no plane")?,
    };
    let plane = &frame.planes[plane_index];
    let option = times_option(a.times.as_ref());
    let extra = match a.times {
        Some(t) if file.is_static() => {
            note(&format!(
                "{}: a static model (trained on one timestep, ω_t^max = 0) is the same at \
                 every time; drawing one panel, not the {} extra time(s) of --times",
                a.model.display(),
                t.len()
            ));
            vec![]
        }
        Some(t) => t.times(),
        // Another time of a static model would show the same labels.
        None if file.is_static() => vec![],
        None => match frames.get(a.frame + 1) {
            Some(next) => vec![0.5 * (frame.time + next.time)],
            None => vec![],
        },
    };
    for &t in &extra {
        file.check_time(&option, t as f32)?;
    }
    let mut panels = vec![Panel::annotated(frame, plane_index)];
    panels.extend(extra.iter().map(|&t| Panel::unannotated(t)));
    // Only the model's classes are drawn: the input's others (a 41-label map behind a model of
    // 3 of its labels) are left out of the contours and the legend, with a note.
    let classes = file.classes();
    let drawn_as = match_classes(&classes, seq.classes());
    let left_out = undrawn(seq.classes(), &drawn_as);
    if !left_out.is_empty() {
        note(&format!(
            "{} of the input's {} classes are not the model's and are not drawn ({}{})",
            left_out.len(),
            drawn_as.len(),
            left_out[..left_out.len().min(5)].join(", "),
            if left_out.len() > 5 { ", …" } else { "" }
        ));
    }
    // Each panel evaluates the network at every pixel: tens of seconds on a loaded machine.
    let progress = Progress::new(
        "drawing the model's labels on the plane: panels",
        panels.len() as u64,
    );
    // Ticks, scale bar and plane position in the input's unit (mm for DICOM, NIfTI, NRRD).
    let unit = file.units().length();
    write_via(&a.output, |tmp| {
        plane_labels(
            &model, &classes, &drawn_as, plane, &panels, unit, a.display, tmp,
        )
    })?;
    progress.set_position(panels.len() as u64);
    progress.finish();
    errln!("wrote {}", a.output.display());
    Ok(())
}
