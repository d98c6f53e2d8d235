//! `dynaslice picture MODEL INPUT -o FIG.png`: predicted labels and input contours on a plane.
//! `dynaslice picture --3d MODEL -o FIG.png`: the classes' surfaces at a few times, shaded.

use super::console::errln;
use super::input::{self, InputArgs};
use super::mesh::surfaces_at;
use super::options::{count, time_series, MAX_MESH_RESOLUTION};
use super::progress::Progress;
use super::times::{model_times, note, times_option};
use anyhow::{bail, Context, Result};
use dynaslice_data::TimeSeries;
use dynaslice_figures::display::Display;
use dynaslice_figures::picture::{match_classes, plane_labels, Panel};
use dynaslice_figures::render3d::{self, Camera, RenderOptions, SurfacePanel};
use dynaslice_mesh::lattice::MIN_RESOLUTION;
use dynaslice_mesh::Options;
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};
use std::path::PathBuf;

/// Extra times one picture shows at most (each is a panel of the picture).
const MAX_PANELS: usize = 64;
/// Panels of a 3D picture of a moving model by default: enough to see the motion, few enough
/// to stay readable side by side.
const DEFAULT_3D_TIMES: usize = 4;

/// Arguments of `dynaslice picture`.
#[derive(clap::Args, Debug)]
#[command(
    // INPUT is required by the shared input options; a 3D picture needs the model alone. The
    // two modes' options exclude each other, each named on its own in the error.
    mut_args(one_mode),
    mut_arg("inputs", |a| a.required(false).required_unless_present("three_d")),
    after_help = "\
Two kinds of picture:
  dynaslice picture MODEL INPUT -o fig.png      the labels on an input plane, with its contours
  dynaslice picture --3d MODEL -o surfaces.png  the classes' surfaces in 3D, no input needed

--3d meshes every class at each time as `dynaslice mesh` does (at --resolution) and draws the
surfaces shaded, one panel per time (by default 4 times evenly over the model's time range, the
model's time for a static one), all panels from the same camera and framing so motion shows,
with a legend of the class names and colours. Views, in the model's RAS world: oblique
(default: from the front, a little to the patient's right and above, superior up), anterior,
posterior, left, right (superior up), superior, inferior (anterior up); a small R/A/S triad in
each panel shows the axes.")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    #[command(flatten)]
    input: InputArgs,
    /// Output picture (.png).
    #[arg(short, long)]
    output: PathBuf,
    /// Replace an existing picture.
    #[arg(long)]
    force: bool,
    /// Draw the model's class surfaces in 3D (shaded, one panel per time) instead of labels on
    /// an input plane; takes no INPUT.
    #[arg(long = "3d", id = "three_d")]
    three_d: bool,
    /// Annotated frame whose plane and contours are shown (index into the selected frames).
    #[arg(long, default_value_t = 0)]
    frame: usize,
    /// Plane of that frame (default: the one with the most contour length).
    #[arg(long)]
    plane: Option<usize>,
    /// Extra times shown on the same plane without contours, a list (0,0.5,1) or A:B:N, N
    /// evenly from A to B inclusive; default: halfway to the next annotated frame. With --3d:
    /// the panels' times (default: 4 evenly over the model's time range).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_PANELS.max(render3d::MAX_PANELS)))]
    times: Option<TimeSeries>,
    /// Which way round axial and coronal planes are drawn: radiological (the patient's left on
    /// the right, anterior or superior up, as PACS and planning systems show them) or
    /// neurological (the patient's left on the left). The picture's note names it.
    #[arg(long, value_enum, default_value_t = Convention::Radiological, conflicts_with = "three_d")]
    display: Convention,
    /// --3d: where the surfaces are seen from.
    #[arg(long, value_enum, default_value_t = View::Oblique, requires = "three_d")]
    view: View,
    /// --3d: meshing lattice cells along the longest axis of the model's bounds.
    #[arg(long, default_value_t = 96, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION),
          requires = "three_d")]
    resolution: u32,
    /// --3d: side of each panel in pixels.
    #[arg(long, default_value_t = 480, value_parser = count(16, render3d::MAX_PANEL),
          requires = "three_d")]
    size: u32,
}

/// The options of a 3D picture only.
const THREE_D_ONLY: [&str; 4] = ["three_d", "view", "resolution", "size"];

/// `arg` made to conflict with the 3D-only options where it is one of the plane picture's
/// (the shared input options, `--frame`, `--plane`). Conflicts, unlike `requires`, hold
/// whichever side is given (clap lets a present conflicting argument excuse a missing required
/// one).
fn one_mode(arg: clap::Arg) -> clap::Arg {
    let inputs = <InputArgs as clap::Args>::augment_args(clap::Command::new("input"));
    let id = arg.get_id().as_str();
    if ["frame", "plane"].contains(&id) || inputs.get_arguments().any(|i| i.get_id() == id) {
        arg.conflicts_with_all(THREE_D_ONLY)
    } else {
        arg
    }
}

/// The conventions of `--display`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum Convention {
    /// The patient's left on the right of the picture.
    Radiological,
    /// The patient's left on the left of the picture.
    Neurological,
}

impl From<Convention> for Display {
    fn from(c: Convention) -> Display {
        match c {
            Convention::Radiological => Display::Radiological,
            Convention::Neurological => Display::Neurological,
        }
    }
}

/// The views of `--view`, in the model's RAS world.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum View {
    /// From the front, a little to the patient's right and above; superior up.
    Oblique,
    /// From the front (+A); superior up, the patient's right on the left.
    Anterior,
    /// From behind (−A); superior up.
    Posterior,
    /// From the patient's left (−R); superior up.
    Left,
    /// From the patient's right (+R); superior up.
    Right,
    /// From above (+S); anterior up, the patient's right on the right.
    Superior,
    /// From below (−S), as axial images are shown; anterior up, the patient's right on the left.
    Inferior,
}

impl View {
    fn camera(self) -> Camera {
        const S: [f64; 3] = [0.0, 0.0, 1.0];
        const A: [f64; 3] = [0.0, 1.0, 0.0];
        let (from, up) = match self {
            View::Oblique => return Camera::ANTERIOR_OBLIQUE,
            View::Anterior => (A, S),
            View::Posterior => ([0.0, -1.0, 0.0], S),
            View::Left => ([-1.0, 0.0, 0.0], S),
            View::Right => ([1.0, 0.0, 0.0], S),
            View::Superior => (S, A),
            View::Inferior => ([0.0, 0.0, -1.0], A),
        };
        Camera {
            from,
            up,
            ..Camera::ANTERIOR_OBLIQUE
        }
    }
}

/// Runs `dynaslice picture --3d`: every class of the model meshed at each time (the mesh
/// command's extraction) and rendered shaded, one panel per time, with a legend.
fn run_3d(a: Args) -> Result<()> {
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
            let n = DEFAULT_3D_TIMES;
            (0..n)
                .map(|i| t0 + (t1 - t0) * i as f32 / (n - 1) as f32)
                .collect()
        }
    };
    // Every time is checked before any meshing: outside the range the network extrapolates. A
    // static model is drawn once.
    let times = model_times(
        &file,
        &a.model,
        &times_option(a.times.as_ref()),
        &times,
        "drawing one panel",
    )?;
    // Names, labels and the input's colours where the model records them.
    let classes = file.classes();
    let channels: Vec<usize> = (0..model.num_classes()).collect();
    let options = Options {
        resolution: a.resolution,
        ..Options::default()
    };
    let progress = Progress::new("meshing: time", times.len() as u64);
    let report = |line: String| progress.println(line);
    let meshes = times
        .iter()
        .map(|&t| {
            let meshes = surfaces_at(&model, t, &channels, &options, report)?.meshes;
            progress.inc();
            Ok(meshes)
        })
        .collect::<Result<Vec<_>>>()?;
    progress.finish();
    let panels = SurfacePanel::per_time(&times, &meshes);
    let options = RenderOptions {
        camera: a.view.camera(),
        panel: a.size,
        ..RenderOptions::default()
    };
    write_via(&a.output, |tmp| {
        render3d::render_surfaces(tmp, &panels, &classes, &options)
    })?;
    errln!("wrote {}", a.output.display());
    Ok(())
}

/// Runs `dynaslice picture`: with `--3d` the surfaces ([`run_3d`]); otherwise the labels on
/// one input plane (by default the frame's plane with the longest contours) at the frame's
/// time, with its contours, and at the extra times (by default midway to the next frame),
/// written as one PNG.
pub fn run(a: Args) -> Result<()> {
    if a.three_d {
        return run_3d(a);
    }
    let inputs = [&a.model]
        .into_iter()
        .chain(&a.input.inputs)
        .chain(&a.input.label_names);
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
    // Only the model's classes are drawn: the input's others (a 41-label map behind a model of
    // 3 of its labels) are left out of the contours and the legend, with a note.
    let classes = file.classes();
    let drawn_as = match_classes(&classes, seq.classes());
    let left_out: Vec<&str> = seq
        .classes()
        .iter()
        .zip(&drawn_as)
        .filter(|(_, k)| k.is_none())
        .map(|(c, _)| c.name.as_str())
        .collect();
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
            &model,
            &classes,
            &drawn_as,
            plane,
            &panels,
            unit,
            a.display.into(),
            tmp,
        )
    })?;
    progress.set_position(panels.len() as u64);
    progress.finish();
    errln!("wrote {}", a.output.display());
    Ok(())
}
