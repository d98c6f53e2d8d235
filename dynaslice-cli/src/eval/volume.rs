//! `dynaslice eval volume`: each class's volume over time, as CSV and a chart.

use crate::console::{errln, outln};
use crate::options::{count, time_series, MAX_MESH_RESOLUTION, MAX_TIMES};
use crate::progress::Progress;
use crate::times::{model_times, times_option};
use anyhow::Result;
use dynaslice_data::TimeSeries;
use dynaslice_figures::plot::volume_chart;
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::volume::{class_volumes, default_times};
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub(super) struct VolumeArgs {
    /// Model file (.dsm).
    model: PathBuf,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: the model's
    /// time range in 20 steps; a
    /// static model, the same at every time, is measured once).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    resolution: u32,
    /// Output CSV (.csv); the chart is written beside it as .png.
    #[arg(short, long)]
    output: PathBuf,
    /// Replace existing files (the CSV and its chart).
    #[arg(long)]
    force: bool,
}

/// Runs `dynaslice eval volume`.
pub(super) fn volume(a: VolumeArgs) -> Result<()> {
    let png = a.output.with_extension("png");
    let mut plan = Plan::new([&a.model], a.force);
    plan.file("-o", &a.output, Kind::Csv)?;
    plan.beside(&png)?;
    let file = ModelFile::open(&a.model)?;
    let option = times_option(a.times.as_ref());
    let requested: Vec<f32> = match a.times {
        // The network takes f32 times.
        Some(series) => series.times().into_iter().map(|t| t as f32).collect(),
        None => default_times(&file)?,
    };
    let times: Vec<f64> = model_times(&file, &option, &requested, "measuring once")?
        .into_iter()
        .map(f64::from)
        .collect();
    let progress = Progress::new("measuring class volumes: time", times.len() as u64);
    let curve = class_volumes(&file, &times, a.resolution, |i| {
        progress.set_position(i as u64)
    })?;
    progress.finish();
    let units = file.units();
    write_via(&a.output, |tmp| curve.write_csv(tmp))?;
    let title = format!("class volumes of {}", a.model.display());
    write_via(&png, |tmp| {
        volume_chart(
            tmp,
            &title,
            units.volume(),
            &curve.classes,
            &[],
            &curve.times,
            &curve.volumes,
        )
    })?;
    errln!("wrote {} and {}", a.output.display(), png.display());
    for (c, (name, (lo, hi))) in curve.classes.iter().zip(curve.ranges()).enumerate() {
        outln!(
            "class {} {name:?}: volume {lo:.6} to {hi:.6} {}",
            c + 1,
            units.volume()
        )?;
    }
    Ok(())
}
