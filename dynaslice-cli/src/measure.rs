//! `dynaslice measure MODEL [--times A:B:N] [-o table.csv] [--json] [--itv DIR]`: the figures of
//! motion and function (dynaslice_metrics::motion) in the input's units and patient frame, and
//! the ITV (dynaslice_metrics::itv) as label volumes and meshes.

use super::console::{errln, outln};
use super::options::{count, positive_f64, time_series, MAX_MESH_RESOLUTION, MAX_TIMES};
use super::progress::Progress;
use super::times::times_option;
use anyhow::{bail, Context, Result};
use dynaslice_data::color_table::{stage_tables, table_paths};
use dynaslice_data::nifti_stream::{NiftiStream, VolumeHeader};
use dynaslice_data::{ClassInfo, TimeSeries};
use dynaslice_mesh::io::{self as mesh_io, class_tag, Format, MeshInfo, Space};
use dynaslice_metrics::itv::{itv_masks, itv_meshes};
use dynaslice_metrics::measurement::{Described, Measurement};
use dynaslice_metrics::motion::{round, Frame, Units};
use dynaslice_model::ModelFile;
use dynaslice_output::write_via;
use dynaslice_output::{Kind, OutputSet, Plan};
use dynaslice_volume::VoxelGrid;
use std::path::{Path, PathBuf};

/// Times measured by default over a moving model's time range.
const DEFAULT_TIMES: usize = 21;

/// Arguments of `dynaslice measure`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Per class and time: the volume (mL where the input was in millimetres: DICOM, NIfTI, NRRD;
the input's plain units³ for .csl and native JSON), the centroid and the bounding box in the
input's patient frame as the model records it (LPS for DICOM and NRRD: +x left, +y posterior,
+z superior; RAS for NIfTI: +x right, +y anterior, +z superior; a model that records no units,
trained before they were recorded, is measured in plain units along x, y, z). Per class over the times: the smallest and largest
volume and their times (ESV and EDV for a ventricle), the stroke volume, the ejection fraction
(max − min) / max, and the centroid's peak-to-peak amplitude along left–right, anterior–
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
    /// time range at 21 times; the
    /// model's time for a static one).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Meshing lattice cells along the longest axis of the model's domain.
    #[arg(long, default_value_t = 128, value_parser = count(1, MAX_MESH_RESOLUTION))]
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

/// The input's units and patient frame, as the model's run record says
/// ([`dynaslice_model::RunRecord`]: plain units and LPS where it records none).
pub fn units_and_frame(file: &ModelFile) -> (Units, Frame) {
    let units = file.units();
    (units, Frame::of(units, file.space()))
}

/// `times`, checked against the model's range, or the default: 21 times over a moving
/// model's range, its start for a static one.
pub fn times_of(file: &ModelFile, times: Option<TimeSeries>) -> Result<Vec<f64>> {
    let option = times_option(times.as_ref());
    let times = match times {
        Some(series) => series.times(),
        None if file.is_static() => vec![f64::from(file.time("--times", None)?)],
        None => {
            let (t0, t1) = file.model().domain().time_range();
            TimeSeries::across(t0, t1, DEFAULT_TIMES)
                .map_err(anyhow::Error::msg)?
                .times()
        }
    };
    for &t in &times {
        file.check_time(&option, t as f32)?;
    }
    Ok(times)
}

/// Measures every class of `file` at `times` with meshes of `resolution` cells, in the units
/// and frame its run record gives.
pub fn measure(file: &ModelFile, times: &[f64], resolution: u32) -> Result<Measurement> {
    let progress = Progress::new("measuring: time", times.len() as u64);
    let (units, frame) = units_and_frame(file);
    let m = Measurement::measure(
        &file.model(),
        times,
        resolution,
        Described {
            units,
            frame,
            classes: file.classes(),
            colors: file.class_colors(),
        },
        || progress.inc(),
    )?;
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
    let times = times_of(&file, a.times)?;
    // Every ITV file is checked before any work.
    let itv_files = match &a.itv {
        Some(dir) => {
            plan.directory("--itv", dir)?;
            let files: Vec<(PathBuf, PathBuf)> = file
                .classes()
                .iter()
                .enumerate()
                .map(|(k, c)| {
                    let tag = class_tag(k, &c.name);
                    (
                        dir.join(format!("{tag}.itv.nii.gz")),
                        dir.join(format!("{tag}.itv.ply")),
                    )
                })
                .collect();
            // A folder still to be made holds no file to replace and no input.
            for (volume, mesh) in files.iter().filter(|_| dir.is_dir()) {
                plan.file("--itv", volume, Kind::LabelVolume)?;
                let (ctbl, label) = table_paths(volume);
                for p in [mesh, &ctbl, &label] {
                    plan.beside(p)?;
                }
            }
            files
        }
        None => Vec::new(),
    };
    // The ITV masks' grid, checked before any work (a spacing that makes no mask, or more
    // memory than there is, fails here, not after the measuring).
    let itv_grid = match &a.itv {
        Some(_) => Some(itv_grid(&file, a.itv_spacing, times[0])?),
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
    print_summary(&m);
    if let (Some(dir), Some(grid)) = (&a.itv, &itv_grid) {
        write_itv(&file, &m, &times, a.resolution, dir, grid, &itv_files)?;
    }
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&m.to_json(&a.model))?)?;
    }
    Ok(())
}

/// The per-class figures over the cycle, on standard error.
fn print_summary(m: &Measurement) {
    let (v, l) = (m.units.volume(), m.units.length());
    errln!(
        "{} times from {} to {}; {} in {v}, positions in {l} ({}: +x {}, +y {}, +z {})",
        m.motion.times.len(),
        m.motion.times[0],
        m.motion.times[m.motion.times.len() - 1],
        if m.units == Units::Plain {
            "plain input units (the input names none)"
        } else {
            "volumes"
        },
        m.frame.name(),
        m.frame.positive()[0],
        m.frame.positive()[1],
        m.frame.positive()[2],
    );
    let axes = if m.frame.is_anatomical() {
        ["LR", "AP", "SI"]
    } else {
        ["x", "y", "z"]
    };
    for (k, c) in m.classes.iter().enumerate() {
        let cycle = m.cycle(k);
        let amplitude = cycle
            .amplitude
            .map(|a| {
                format!(
                    "{} {} / {} {} / {} {} {l}",
                    axes[0],
                    round(a[0]),
                    axes[1],
                    round(a[1]),
                    axes[2],
                    round(a[2])
                )
            })
            .unwrap_or_else(|| "absent at every time".into());
        errln!(
            "  {:?}: volume {} {v} (t = {}) to {} {v} (t = {}), stroke {} {v}, EF {}; \
             peak-to-peak {amplitude}",
            c.name,
            m.volume(cycle.min.volume),
            cycle.min.time,
            m.volume(cycle.max.volume),
            cycle.max.time,
            m.volume(cycle.stroke_volume),
            cycle
                .ejection_fraction
                .map_or("-".into(), |e| format!("{:.1} %", 100.0 * e)),
        );
    }
}

/// The ITV masks' grid over the model's domain: `spacing` (default 128 voxels along the
/// longest side) checked against the domain ([`VoxelGrid::for_mask`]) and the masks' memory
/// (a byte per voxel and class, and the written frame's 4 bytes per voxel) against what is
/// available.
fn itv_grid(file: &ModelFile, spacing: Option<f64>, time: f64) -> Result<VoxelGrid> {
    let model = file.model();
    let (lo, hi) = model.domain().bounds();
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    let spacing = spacing.unwrap_or_else(|| {
        let longest = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        longest / 128.0
    });
    let grid = VoxelGrid::for_mask("--itv-spacing", lo, hi, spacing, time)?;
    let voxels = grid.voxels_per_frame() as f64;
    super::memory::check(
        &format!("ITV masks of {:?} voxels", grid.dims),
        voxels * (model.num_classes() as f64 + 4.0),
        "use a coarser --itv-spacing",
        super::memory::MemoryArgs::default(),
    )?;
    Ok(grid)
}

/// Writes each class's ITV mask (NIfTI, its colour tables beside it) and mesh (PLY, LPS) into
/// `dir`, all files or none ([`OutputSet`]).
fn write_itv(
    file: &ModelFile,
    m: &Measurement,
    times: &[f64],
    resolution: u32,
    dir: &Path,
    grid: &VoxelGrid,
    files: &[(PathBuf, PathBuf)],
) -> Result<()> {
    let model = file.model();
    let mut set = OutputSet::new();
    set.create_dir(dir)?;
    // Labels at every time, then one meshing of the union: a minute or more on a busy machine.
    let progress = Progress::new(
        "ITV: each time's labels, then the union's surfaces: step",
        times.len() as u64 + 1,
    );
    let masks = itv_masks(&model, grid, times, || progress.inc())?;
    let options = dynaslice_mesh::Options {
        resolution,
        ..dynaslice_mesh::Options::default()
    };
    let meshes = itv_meshes(&model, model.domain().bounds(), times, &options)?;
    progress.inc();
    progress.finish();
    for (k, c) in m.classes.iter().enumerate() {
        let (volume_path, mesh_path) = &files[k];
        let header = VolumeHeader {
            dims: grid.dims,
            frames: 1,
            affine: grid.affine,
            frame_interval: 1.0,
            time_offset: times[0],
            label_range: (0.min(c.label), 0.max(c.label)),
            description: "dynaslice ITV (union over the measured times)".into(),
        };
        let labels: Vec<i32> = masks[k]
            .iter()
            .map(|&i| if i { c.label } else { 0 })
            .collect();
        let voxels = labels.iter().filter(|&&l| l != 0).count();
        if voxels == 0 {
            bail!(
                "{}: class {:?} is in no voxel of the ITV mask at --itv-spacing {}; nothing \
                 written",
                volume_path.display(),
                c.name,
                grid.affine[0][0]
            );
        }
        let mut stream = NiftiStream::create(volume_path, &header)?;
        stream.write_frame(&labels)?;
        stream.finish_into(&mut set)?;
        let (ctbl, label) = table_paths(volume_path);
        stage_tables(
            &mut set,
            &ctbl,
            &label,
            std::slice::from_ref(&ClassInfo {
                color: Some(m.colors[k]),
                ..c.clone()
            }),
        )?;
        let info = MeshInfo::new(&c.name, Space::Lps)
            .with_label(c.label)
            .with_color(m.colors[k]);
        let bytes = mesh_io::encode(&meshes[k], Format::Ply, &info)?;
        set.write(mesh_path, &bytes)?;
        let voxels = voxels as f64;
        errln!(
            "wrote {} ({} {} by voxels) and {} ({} {} enclosed)",
            volume_path.display(),
            m.volume(voxels * grid.voxel_volume()),
            m.units.volume(),
            mesh_path.display(),
            m.volume(meshes[k].enclosed_volume()),
            m.units.volume(),
        );
    }
    set.commit()
}
