//! `dynaslice mesh MODEL.dsm --time T -o OUT.ply` (or `--times A:B:N -o DIR`): the zero-level
//! sets of a model's classes as closed triangle meshes in world coordinates. Method, file names
//! and attributes: docs/meshing.md.

use super::console::errln;
use super::memory::{self, MemoryArgs};
use super::options::{
    count, f32_in, finite_f32, time_series, MAX_MESH_RESOLUTION, MAX_NEWTON_STEPS, MAX_SAFETY,
    MAX_THREADS, MAX_TIMES,
};
use super::pool::pool;
use super::progress::Progress;
use super::times::{model_times, times_option};
use anyhow::{anyhow, Result};
use dynaslice_data::TimeSeries;
use dynaslice_mesh::io::{Format, MeshFiles, Space};
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_mesh::model_meshes::planned_paths;
use dynaslice_mesh::{self as mesh, Options, DEFAULT_SAFETY};
use dynaslice_model::ModelFile;
use dynaslice_output::{Kind, Plan};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `dynaslice mesh`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
File names: with --time, one class is written to OUT itself; several classes go beside it as
STEM_classK_NAME.EXT (e.g. -o t.ply writes t_class1_liver.ply, t_class2_spleen.ply), NAME the
class name reduced to letters, digits and '-'. With --times, OUT is a directory of
classK_NAME_tIIII.EXT files (IIII the time's index), plus series.pvd for ParaView (vtp).
A static model (trained on one timestep) needs no --time, and is meshed once whatever --time or
--times asks (its surfaces are the same at every time; a note says so): with --times, OUT gets
one file per class at the model's time.
PLY and VTP vertices carry the class colour (the training input's, else the palette's): PLY
red/green/blue, VTP point data Colors. OBJ and STL carry none.
A motion model's --times series is the first time's mesh of each class carried through the
others (the same vertices and triangles at every time), each vertex with its displacement from
the first time (VTP point data displacement, PLY dx/dy/dz); a class that cannot be carried to
a time (the motion folds there, or the shape changed more than the motion carries) is marched
there instead, without a displacement, and a line says so (docs/meshing.md).")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// World time of the meshes (the model's time units; any time in its range; a static
    /// model's default is its time).
    #[arg(long, allow_negative_numbers = true, value_parser = finite_f32)]
    time: Option<f32>,
    /// Several times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive; -o is then a
    /// directory.
    #[arg(
        long,
        value_name = "TIMES",
        conflicts_with = "time",
        allow_hyphen_values = true,
        value_parser = time_series(MAX_TIMES)
    )]
    times: Option<TimeSeries>,
    /// Class to mesh, by number (1..K) or name; repeat for several. Default: every class.
    #[arg(long = "class", value_name = "K")]
    classes: Vec<String>,
    /// Lattice cells along the longest axis of the model's bounds.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    resolution: u32,
    /// Output: a .ply, .obj, .stl or .vtp file with --time, a directory with --times.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// Replace existing files (the mesh, the per-class meshes beside it, a series' files).
    #[arg(long)]
    force: bool,
    /// File format of a series (ply, obj, stl, vtp); a single file takes its extension's.
    #[arg(long, default_value = "vtp", value_parser = parse_format)]
    format: Format,
    /// Frame of the written vertices, tagged in each file (SPACE=…): lps (x and y negated;
    /// DICOM's patient frame, what 3D Slicer and ITK assume) or ras (NIfTI's). Default: the
    /// frame the model's input came in (`dynaslice info` shows it), so the meshes lie on the
    /// input's own coordinates (a .csl or JSON input's numbers unchanged).
    #[arg(long, value_parser = parse_space)]
    space: Option<Space>,
    /// Non-overlapping surfaces: the boundaries of the Eq. 11 label partition, shared by
    /// neighbouring classes.
    #[arg(long)]
    non_overlapping: bool,
    /// Safety factor s of the distance bound: a cell is skipped when |f| at a corner exceeds
    /// s times the distance it must cover (≥ 1; larger is safer for models far from ‖∇f‖ = 1).
    #[arg(long, default_value_t = DEFAULT_SAFETY, value_parser = f32_in(1.0, MAX_SAFETY),
          allow_negative_numbers = true)]
    safety: f32,
    /// Evaluate the network at every lattice vertex instead (a slow check of the sparse result).
    #[arg(long)]
    dense: bool,
    /// Newton steps per vertex along ∇ₓf (0: linear interpolation on the lattice edges).
    #[arg(long, default_value_t = dynaslice_mesh::DEFAULT_NEWTON_STEPS,
          value_parser = count(0, MAX_NEWTON_STEPS))]
    newton_steps: u32,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = count(1, MAX_THREADS))]
    threads: Option<usize>,
    #[command(flatten)]
    memory: MemoryArgs,
}

fn parse_space(s: &str) -> Result<Space, String> {
    s.parse()
}

fn parse_format(s: &str) -> Result<Format, String> {
    Format::from_name(s).ok_or_else(|| format!("unknown format {s:?}; use ply, obj, stl or vtp"))
}

/// Runs `dynaslice mesh`: the selected classes' surfaces at one time or a series, on `--threads`.
pub fn run(args: Args) -> Result<()> {
    let pool = pool(args.threads)?;
    pool.install(|| mesh_all(&args))
}

fn mesh_all(args: &Args) -> Result<()> {
    let series = args.times.is_some();
    let mut plan = Plan::new([&args.model], args.force);
    match series {
        true => plan.directory("-o", &args.output)?,
        false => plan.file("-o", &args.output, Kind::Mesh)?,
    }
    let file = ModelFile::open(&args.model)?;
    let model = file.model();
    let classes = dynaslice_model::resolve_classes(&model, &args.classes)
        .map_err(|e| anyhow!("{}: {e}", args.model.display()))?;
    let (option, requested) = match (&args.times, args.time) {
        // The network takes f32 times (the f64 series rounded once).
        (Some(series), _) => (
            times_option(Some(series)),
            series.times().into_iter().map(|t| t as f32).collect(),
        ),
        (None, Some(t)) => ("--time".into(), vec![t]),
        (None, None) => ("--time".into(), vec![file.time("--time", None)?]),
    };
    // Checked against the time range (outside it the network extrapolates freely); a static
    // model's surfaces are meshed once.
    let times = model_times(&file, &option, &requested, "writing one mesh per class")?;
    let options = Options::of(
        args.resolution,
        args.dense,
        args.safety,
        args.non_overlapping,
        args.newton_steps,
    );
    if args.dense {
        memory::check(
            &format!("--dense at --resolution {}", args.resolution),
            options.dense_bytes(classes.len()),
            "lower --resolution or drop --dense",
            args.memory,
        )?;
    }
    // Where each (time, class) mesh goes.
    let space = args.space.unwrap_or_else(|| file.space());
    let mut files = match series {
        true => MeshFiles::series(&args.output, args.format, space)?,
        false => MeshFiles::single(&args.output, classes.len(), space)?,
    };
    // Every file the run writes (the per-class files beside -o, a series' meshes and
    // collection), checked before any work.
    for path in planned_paths(&model, &files, times.len(), &classes) {
        if path != args.output {
            plan.beside(&path)?;
        }
    }
    let progress = Progress::new("meshing: time", times.len() as u64);
    let started = Instant::now();
    let colors = file.class_colors();
    let stats = mesh::write_meshes(
        &model,
        &times,
        &classes,
        &colors,
        &options,
        &mut files,
        |step| match step.line() {
            Some(line) => progress.println(line),
            None => progress.inc(),
        },
    )?;
    progress.finish();
    match files.finish()? {
        Some(pvd) => errln!("wrote {}", pvd.display()),
        None if series => {
            errln!("no series.pvd: ParaView collections list VTK XML files only (use --format vtp)")
        }
        None => {}
    }
    if times.len() > 1 {
        let seconds = started.elapsed().as_secs_f64();
        errln!("{} times in {seconds:.1} s: {stats}", times.len());
    }
    Ok(())
}
