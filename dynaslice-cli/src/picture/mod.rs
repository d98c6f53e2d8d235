//! `dynaslice picture MODEL INPUT -o FIG.png`: predicted labels and input contours on a plane.
//! `dynaslice picture --3d MODEL -o FIG.png`: the classes' surfaces at a few times, shaded.

mod plane;
mod three_d;

use super::input::InputArgs;
use super::options::{choice, count, time_series, MAX_MESH_RESOLUTION};
use anyhow::Result;
use dynaslice_data::TimeSeries;
use dynaslice_figures::display::Display;
use dynaslice_figures::render3d::{self, Side};
use dynaslice_mesh::lattice::MIN_RESOLUTION;
use std::path::PathBuf;

/// Extra times one picture shows at most (each is a panel of the picture).
const MAX_PANELS: usize = 64;

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
    #[arg(long, value_parser = choice(&Display::ALL, Display::name, Display::help),
          default_value = Display::default().name(), conflicts_with = "three_d")]
    display: Display,
    /// --3d: where the surfaces are seen from.
    #[arg(long, value_parser = choice(&Side::ALL, Side::name, Side::help),
          default_value = Side::Oblique.name(), requires = "three_d")]
    view: Side,
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

/// Runs `dynaslice picture`: with `--3d` the surfaces ([`three_d::run`]), otherwise the labels
/// on an input plane ([`plane::run`]).
pub fn run(a: Args) -> Result<()> {
    match a.three_d {
        true => three_d::run(a),
        false => plane::run(a),
    }
}
