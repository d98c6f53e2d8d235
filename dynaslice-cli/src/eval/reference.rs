//! `dynaslice eval reference`: one class of a model against a reference mesh.

use crate::console::outln;
use crate::options::{count, finite_f32, MAX_CHAMFER_SAMPLES, MAX_MESH_RESOLUTION};
use crate::times::model_times;
use anyhow::{bail, Result};
use dynaslice_core::format::MAX_CLASSES;
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::chamfer::{self, ReferenceScore, DEFAULT_SAMPLES};
use dynaslice_model::ModelFile;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(super) struct ReferenceArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// Reference surface (.stl, binary or ASCII), in the model's world coordinates.
    reference: PathBuf,
    /// World time of the model's surface, within its time range (default: its start).
    #[arg(long, allow_negative_numbers = true, value_parser = finite_f32)]
    time: Option<f32>,
    /// Class compared with the reference, 1..K.
    #[arg(long, default_value_t = 1, value_parser = count(1, MAX_CLASSES))]
    class: usize,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    mesh_resolution: u32,
    /// Area-uniform samples per surface.
    #[arg(long, default_value_t = DEFAULT_SAMPLES, value_parser = count(1, MAX_CHAMFER_SAMPLES))]
    samples: usize,
}

/// Runs `dynaslice eval reference`.
pub(super) fn reference(a: ReferenceArgs) -> Result<()> {
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    let k = model.num_classes();
    let t = match a.time {
        Some(t) => model_times(&file, "--time", &[t], "scoring its one surface")?[0],
        None => model.domain().time_range().0,
    };
    if !(1..=k).contains(&a.class) {
        bail!(
            "{}: --class {} but the model has classes 1..{k}",
            a.model.display(),
            a.class
        );
    }
    let ReferenceScore { cd, diagonal } = chamfer::reference_score(
        &file,
        a.class,
        t,
        &a.reference,
        a.mesh_resolution,
        a.samples,
    )?;
    let when = if file.is_static() {
        format!("(a static model, the same at every time; its time {t})")
    } else {
        format!("at t = {t}")
    };
    outln!(
        "class {} {:?} {when}: CD×10⁴ = {:.4} (model → reference {:.4}, reference → model \
         {:.4}); {} samples per surface, unit-normalised by the reference's bounding-box \
         diagonal {diagonal:.4}",
        a.class,
        model.class(a.class as u32)?.name,
        cd.scaled(),
        cd.to_reference * 1e4,
        cd.from_reference * 1e4,
        a.samples
    )?;
    Ok(())
}
