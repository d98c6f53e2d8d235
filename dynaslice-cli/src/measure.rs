//! `dynaslice measure MODEL [--times A:B:N] [-o table.csv] [--json] [--itv DIR]`: the figures of
//! motion and function (dynaslice_metrics::motion) in the input's units and patient frame, and
//! the ITV (dynaslice_metrics::itv) as label volumes and meshes.

use super::console::{errln, outln};
use super::options::{count, positive_f64, time_series, MAX_MESH_RESOLUTION, MAX_TIMES};
use super::progress::Progress;
use super::times::times_option;
use anyhow::{Context, Result};
use dynaslice_data::color_table::table_paths;
use dynaslice_data::TimeSeries;
use dynaslice_mesh::lattice::{DEFAULT_RESOLUTION, MIN_RESOLUTION};
use dynaslice_metrics::itv::{itv_bytes, itv_files, itv_grid, write_itv};
use dynaslice_metrics::measurement::{times_of, Measurement};
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, Plan};
use std::path::PathBuf;

/// Arguments of `dynaslice measure`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Per class and time: the volume (mL where the input was in millimetres: DICOM, NIfTI, NRRD;
the input's plain units³ for .csl and native JSON), the centroid and the bounding box in the
input's patient frame as the model records it (LPS for DICOM and NRRD: +x left, +y posterior,
+z superior; RAS for NIfTI: +x right, +y anterior, +z superior; a model that records no units,
trained before they were recorded, is measured in plain units along x, y, z). Per class over
the times: the smallest and largest volume and their times (ESV and EDV for a ventricle), the
volume change max − min and its share of the largest, (max − min) / max (the stroke volume and
ejection fraction for a ventricle; a class whose volume changes by less than 5 % is reported as
rigid instead), and the centroid's peak-to-peak amplitude along left–right, anterior–
posterior and superior–inferior. Values come from the closed meshes of the model's label
partition (the classes of `dynaslice labels`), at --resolution cells along the longest axis.

Outputs: -o table.csv (one row per time and class, for spreadsheets), --json (one object on
standard output, for scripts), --itv DIR (per class the union over the times as a NIfTI mask
DIR/classK_NAME.itv.nii.gz with colour tables, for 3D Slicer and planning systems, and its
closed surface DIR/classK_NAME.itv.ply in LPS). A summary is printed on standard error.")]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: the model's
    /// time range at 21 times; the model's time for a static one).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Meshing lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = DEFAULT_RESOLUTION, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION))]
    resolution: u32,
    /// Output CSV (.csv): one row per time and class.
    #[arg(short, long, value_name = "TABLE.csv")]
    output: Option<PathBuf>,
    /// Print every figure as one JSON object on standard output.
    #[arg(long)]
    json: bool,
    /// Write each class's ITV (union over the times) into this folder (created if missing): a
    /// NIfTI mask and a PLY mesh per class.
    #[arg(long, value_name = "DIR")]
    itv: Option<PathBuf>,
    /// Voxel size of the ITV masks (default: 128 voxels along the longest axis of the model's
    /// domain).
    #[arg(long, value_parser = positive_f64, requires = "itv")]
    itv_spacing: Option<f64>,
    /// Replace existing ITV masks.
    #[arg(long)]
    force: bool,
}

/// Measures every class of `file` at `times` ([`Measurement::of_file`]), with a progress bar.
pub fn measure(file: &ModelFile, times: &[f64], resolution: u32) -> Result<Measurement> {
    let progress = Progress::new("measuring: time", times.len() as u64);
    let m = Measurement::of_file(file, times, resolution, || progress.inc())?;
    progress.finish();
    Ok(m)
}

/// Runs `dynaslice measure`.
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new([&a.model], a.force);
    if let Some(out) = &a.output {
        plan.file("-o", out, Kind::Csv)?;
    }
    let file = ModelFile::open(&a.model)?;
    let times = times_of(&file, a.times.as_ref(), &times_option(a.times.as_ref()))?;
    // Every ITV file, the masks' grid and their memory are checked before any work (a
    // spacing that makes no mask, or more memory than there is, fails here, not after the
    // measuring).
    let itv = match &a.itv {
        Some(dir) => {
            plan.directory("--itv", dir)?;
            let files = itv_files(dir, &file.classes());
            // A folder still to be made holds no file to replace and no input.
            for f in files.iter().filter(|_| dir.is_dir()) {
                plan.file("--itv", &f.mask, Kind::LabelVolume)?;
                let (ctbl, label) = table_paths(&f.mask);
                for p in [&f.mesh, &ctbl, &label] {
                    plan.beside(p)?;
                }
            }
            let grid = itv_grid(&file.model(), "--itv-spacing", a.itv_spacing, times[0])?;
            super::memory::check(
                &format!("ITV masks of {:?} voxels", grid.dims),
                itv_bytes(&grid, file.model().num_classes()),
                "use a coarser --itv-spacing",
                super::memory::MemoryArgs::default(),
            )?;
            Some((dir, files, grid))
        }
        None => None,
    };
    let m = measure(&file, &times, a.resolution)?;
    if let Some(out) = &a.output {
        let csv = m.to_csv();
        write_via(out, |tmp| {
            std::fs::write(tmp, &csv).with_context(|| format!("cannot write {}", tmp.display()))
        })?;
        errln!("wrote {}", out.display());
    }
    for line in m.summary() {
        errln!("{line}");
    }
    if let Some((dir, files, grid)) = itv {
        // Labels at every time, then one meshing of the union.
        let progress = Progress::new(
            "ITV: each time's labels, then the union's surfaces: step",
            times.len() as u64 + 1,
        );
        let grid = (&grid, "--itv-spacing");
        let volumes = write_itv(&file.model(), &m, a.resolution, grid, dir, &files, || {
            progress.inc()
        })?;
        progress.finish();
        let unit = m.units.volume();
        for (f, v) in files.iter().zip(volumes) {
            errln!(
                "wrote {} ({} {unit} by voxels) and {} ({} {unit} enclosed)",
                f.mask.display(),
                m.volume(v.by_voxels),
                f.mesh.display(),
                m.volume(v.enclosed),
            );
        }
    }
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&m.to_json(&a.model))?)?;
    }
    Ok(())
}
