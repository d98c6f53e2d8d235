//! `dynaslice picture --3d MODEL -o FIG.png`: the classes' surfaces at a few times, shaded.

use super::Args;
use crate::console::errln;
use crate::progress::Progress;
use crate::times::{model_times, times_option};
use anyhow::{bail, Result};
use dynaslice_figures::render3d::{self, default_times, draw_model, Camera, RenderOptions};
use dynaslice_mesh::Options;
use dynaslice_model::ModelFile;
use dynaslice_output::{Kind, Plan};

/// Runs `dynaslice picture --3d`: every class of the model meshed at each time (the mesh
/// command's extraction) and rendered shaded, one panel per time, with a legend.
pub(super) fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new([&a.model], a.force);
    plan.file("-o", &a.output, Kind::Png)?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let times: Vec<f32> = match &a.times {
        Some(t) if t.len() > render3d::MAX_PANELS => bail!(
            "--times: at most {} times fit one 3D picture, {} given",
            render3d::MAX_PANELS,
            t.len()
        ),
        // The network takes f32 times.
        Some(t) => t.times().into_iter().map(|t| t as f32).collect(),
        None if file.is_static() => vec![file.time("--times", None)?],
        None => {
            let (t0, t1) = model.domain().time_range();
            default_times(t0, t1)
        }
    };
    // Every time is checked before any meshing: outside the range the network extrapolates. A
    // static model is drawn once.
    let times = model_times(
        &file,
        &times_option(a.times.as_ref()),
        &times,
        "drawing one panel",
    )?;
    let options = Options {
        resolution: a.resolution,
        ..Options::default()
    };
    let render = RenderOptions {
        camera: Camera::from_side(a.view),
        panel: a.size,
        ..RenderOptions::default()
    };
    let progress = Progress::new("meshing: time", times.len() as u64);
    // Names, labels and the input's colours where the model records them.
    let classes = file.classes();
    draw_model(
        &model,
        &classes,
        &times,
        &options,
        &render,
        &a.output,
        |cost| {
            progress.println(cost);
            progress.inc();
        },
    )?;
    progress.finish();
    errln!("wrote {}", a.output.display());
    Ok(())
}
