//! `dynaslice query MODEL X Y Z [T]`.

use super::console::outln;
use super::options::finite_f32;
use anyhow::Result;
use dynaslice_core::UNDEFINED_LABEL;
use dynaslice_model::ModelFile;
use std::path::PathBuf;

/// Arguments of `dynaslice query`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Coordinates are in the model's world frame, RAS (NIfTI's: +x toward the patient's right, +y
anterior, +z superior; docs/data-format.md), in the training input's units (mm for NIfTI, DICOM
and 3D Slicer inputs). A motion model (trained with --motion) also prints its displacement u at
the point: f(x, t) = g(x + u, t), g the shape network. A point read in 3D Slicer, ITK or a DICOM viewer is in LPS:
negate its x and y (LPS (10, 20, 30) is RAS (-10, -20, 30)). `dynaslice info` prints the
model's world bounds.")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// World x in the model's RAS frame (+x toward the patient's right, R), in the input's
    /// units (e.g. mm); from LPS (3D Slicer, ITK, DICOM), negate x.
    #[arg(allow_negative_numbers = true, value_parser = finite_f32)]
    x: f32,
    /// World y in the RAS frame (+y anterior, A); from LPS, negate y.
    #[arg(allow_negative_numbers = true, value_parser = finite_f32)]
    y: f32,
    /// World z in the RAS frame (+z superior, S), the same in LPS.
    #[arg(allow_negative_numbers = true, value_parser = finite_f32)]
    z: f32,
    /// World time (the model's time units), within the model's time range; optional for a
    /// static model (trained on one timestep), which is the same at every time.
    #[arg(allow_negative_numbers = true, value_parser = finite_f32)]
    t: Option<f32>,
}

/// Runs `dynaslice query`: prints each class's f, ∇ₓf and ∂f/∂t at the world point and time,
/// then the Eq. 11 label, and for a motion model the displacement u there.
pub fn run(args: Args) -> Result<()> {
    let file = ModelFile::open(&args.model)?;
    let model = file.model();
    // A static model is the same at every time: any T is answered at its one time, with a
    // note, as `mesh` and `eval reference` do (issue 37).
    let t = match args.t {
        Some(t) if file.is_static() => super::times::model_times(&file, "T", &[t], "answering")?[0],
        t => file.time("T", t)?,
    };
    let k = model.num_classes();
    let (mut f, mut grad, mut dfdt) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
    let x = [args.x, args.y, args.z];
    model.eval_jacobian(x, t, &mut f, &mut grad, &mut dfdt)?;
    outln!(
        "{:<5} {:<20} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "class",
        "name",
        "f",
        "df/dx",
        "df/dy",
        "df/dz",
        "df/dt"
    )?;
    for (i, class) in model.classes().enumerate() {
        let g = grad[i];
        outln!(
            "{:<5} {:<20} {:>12.6} {:>12.6} {:>12.6} {:>12.6} {:>12.6}",
            i + 1,
            class.name,
            f[i],
            g[0],
            g[1],
            g[2],
            dfdt[i]
        )?;
    }
    match model.label(x, t) {
        UNDEFINED_LABEL => outln!("label undefined (non-finite query)")?,
        0 => outln!("label 0 (background)")?,
        l => {
            let class = model.class(l)?;
            outln!("label {l} ({}, source label {})", class.name, class.label)?;
        }
    }
    if model.motion().is_some() {
        // f(x, t) = g(x + u(x, t), t): u carries the point to where the shape network reads it.
        let u = model.displacement(x, t)?;
        outln!(
            "displacement {:.6} {:.6} {:.6} (u: x + u is the point's canonical position, world units)",
            u[0],
            u[1],
            u[2]
        )?;
    }
    Ok(())
}
