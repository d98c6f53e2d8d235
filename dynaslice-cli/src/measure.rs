//! `dynaslice measure MODEL [--times A:B:N] [-o table.csv] [--json] [--itv DIR]`: the figures of
//! motion and function (dynaslice_metrics::motion) in the input's units and patient frame, and
//! the ITV (dynaslice_metrics::itv) as label volumes and meshes.

use super::console::{errln, outln};
use super::model::ModelFile;
use super::options::{count, positive_f64, time_series, MAX_MESH_RESOLUTION, MAX_TIMES};
use super::progress::Progress;
use anyhow::{bail, Context, Result};
use dynaslice_core::Model;
use dynaslice_data::color_table::{stage_tables, table_paths};
use dynaslice_data::nifti_stream::{NiftiStream, VolumeHeader};
use dynaslice_data::{manifest, ClassInfo, TimeSeries};
use dynaslice_mesh::io::{self as mesh_io, class_tag, Format, MeshInfo, Space};
use dynaslice_metrics::itv::{itv_masks, itv_meshes};
use dynaslice_metrics::motion::{round, Cycle, Frame, Motion, Units};
use dynaslice_output::write_via;
use dynaslice_output::{Kind, OutputSet, Plan};
use dynaslice_sequence::palette;
use dynaslice_volume::VoxelGrid;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Times measured by default over a moving model's time range.
const DEFAULT_TIMES: usize = 21;

/// Arguments of `dynaslice measure`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Per class and time: the volume (mL where the input was in millimetres: DICOM, NIfTI, NRRD;
the input's plain units³ for .csl and native JSON), the centroid and the bounding box in the
input's patient frame (LPS for DICOM: +x left, +y posterior, +z superior; RAS for NIfTI and
NRRD: +x right, +y anterior, +z superior). Per class over the times: the smallest and largest
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
    /// N times evenly from A to B inclusive (default: the model's time range at 21 times; the
    /// model's time for a static one).
    #[arg(long, value_name = "A:B:N", allow_hyphen_values = true,
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

/// A model measured at its times, with what the numbers mean.
pub struct Measurement {
    /// The figures, in the model's RAS world and units.
    pub motion: Motion,
    /// The input's units.
    pub units: Units,
    /// The input's patient frame.
    pub frame: Frame,
    /// Names, source labels and recorded colours, channel order.
    pub classes: Vec<ClassInfo>,
    /// Display colour per class (recorded or the palette's).
    pub colors: Vec<[u8; 3]>,
}

/// The input's units and patient frame: what the model records (`units = …`, `space = …`,
/// [`dynaslice_model::ModelFile::units`]); for models written before those lines, from the
/// input's file name (`input = PATH[ + PATH…]`, the first path's extension; a manifest's first
/// entry): DICOM is LPS in mm, NIfTI and NRRD RAS in mm, anything else (`.csl`, native JSON)
/// plain units in an unnamed frame. A model without either is taken as plain.
pub fn units_and_frame(model: &Model) -> (Units, Frame) {
    // What the model records of its input (models since the model service): its units and
    // patient frame.
    let recorded = |key: &str| {
        model.metadata().lines().find_map(|l| {
            let (k, v) = l.split_once('=')?;
            (k.trim() == key).then(|| v.trim().to_string())
        })
    };
    let units = recorded(Units::METADATA_KEY).and_then(|v| Units::from_name(&v));
    let space = recorded(Space::METADATA_KEY).and_then(|v| Space::from_name(&v));
    match (units, space) {
        (Some(Units::Plain), _) => return (Units::Plain, Frame::Plain),
        (Some(Units::Millimetres), Some(Space::Lps)) => return (Units::Millimetres, Frame::Lps),
        (Some(Units::Millimetres), Some(Space::Ras)) => return (Units::Millimetres, Frame::Ras),
        _ => {}
    }
    // Older models: from the input's file name.
    let input = model
        .metadata()
        .lines()
        .find_map(|l| l.strip_prefix("input = "))
        .and_then(|v| v.split(" + ").next())
        .map(PathBuf::from);
    let Some(mut path) = input else {
        return (Units::Plain, Frame::Plain);
    };
    let lower = |p: &Path| p.to_string_lossy().to_ascii_lowercase();
    if [".seq", ".cslseq"]
        .iter()
        .any(|e| lower(&path).ends_with(e))
    {
        match manifest::read(&path) {
            Ok(entries) if !entries.is_empty() => path = entries[0].path.clone(),
            _ => {
                log::warn!(
                    "the manifest {} the model was trained on cannot be read; its units and \
                     frame are unknown",
                    path.display()
                );
                return (Units::Plain, Frame::Plain);
            }
        }
    }
    let name = lower(&path);
    if name.ends_with(".dcm") {
        (Units::Millimetres, Frame::Lps)
    } else if [".nii", ".nii.gz", ".nrrd", ".nhdr"]
        .iter()
        .any(|e| name.ends_with(e))
    {
        (Units::Millimetres, Frame::Ras)
    } else {
        (Units::Plain, Frame::Plain)
    }
}

/// The time axis's name for `frame`'s inputs: NIfTI frames are seconds apart
/// (`pixdim[4]`), a DICOM manifest's times are its own (often % of the breathing cycle).
pub fn time_axis(frame: Frame) -> &'static str {
    match frame {
        Frame::Ras => "time (s)",
        Frame::Lps => "time (manifest)",
        Frame::Plain => "time",
    }
}

/// `times`, checked against the model's range, or the default: 21 times over a moving
/// model's range, its start for a static one.
pub fn times_of(file: &ModelFile, times: Option<TimeSeries>) -> Result<Vec<f64>> {
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
        file.check_time("--times", t as f32)?;
    }
    Ok(times)
}

/// Measures every class of `file` at `times` with meshes of `resolution` cells.
pub fn measure(file: &ModelFile, times: &[f64], resolution: u32) -> Result<Measurement> {
    let model = file.model();
    let progress = Progress::new("measuring: time", times.len() as u64);
    let motion = Motion::measure(&model, times, resolution, || progress.inc())?;
    progress.finish();
    let (units, frame) = units_and_frame(&model);
    Ok(Measurement {
        motion,
        units,
        frame,
        classes: file.classes(),
        colors: file.class_colors(),
    })
}

impl Measurement {
    /// Source labels, channel order.
    pub fn labels(&self) -> Vec<i32> {
        self.classes.iter().map(|c| c.label).collect()
    }

    /// The per-time CSV table.
    pub fn to_csv(&self) -> String {
        self.motion.to_csv(&self.labels(), self.units, self.frame)
    }

    /// Class `k`'s figures over the times.
    pub fn cycle(&self, k: usize) -> Cycle {
        self.motion.cycle(k)
    }

    /// A world volume in the reported unit, rounded as every output prints it.
    pub fn volume(&self, v: f64) -> f64 {
        round(self.units.from_world_volume(v))
    }

    /// Everything as one JSON object (`classes[k]`: `name`, `label`, `color`, `volume_ml` per
    /// time, `amplitude_mm` {`lr`, `ap`, `si`}, `ejection_fraction`, …), numbers rounded as in
    /// the CSV. Where the units are not millimetres, `volume_ml` and `amplitude_mm` are null and
    /// `volume` and `amplitude` hold the plain values.
    pub fn to_json(&self, model: &Path) -> Value {
        let m = &self.motion;
        let mm = self.units == Units::Millimetres;
        let point = |p: Option<[f64; 3]>| p.map(|p| self.frame.from_world(p).map(round));
        let classes: Vec<Value> = self
            .classes
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let cycle = m.cycle(k);
                let volumes: Vec<f64> = m.shapes.iter().map(|s| self.volume(s[k].volume)).collect();
                let amplitude = cycle.amplitude.map(|a| a.map(round));
                let anatomical = amplitude
                    .filter(|_| self.frame.is_anatomical())
                    .map(|[lr, ap, si]| json!({"lr": lr, "ap": ap, "si": si}));
                let boxes: Vec<Option<Value>> = m
                    .shapes
                    .iter()
                    .map(|s| {
                        s[k].bounds.map(|(lo, hi)| {
                            let (a, b) = (self.frame.from_world(lo), self.frame.from_world(hi));
                            let min: [f64; 3] = std::array::from_fn(|i| round(a[i].min(b[i])));
                            let max: [f64; 3] = std::array::from_fn(|i| round(a[i].max(b[i])));
                            json!({"min": min, "max": max})
                        })
                    })
                    .collect();
                let centroids: Vec<Option<[f64; 3]>> =
                    m.shapes.iter().map(|s| point(s[k].centroid)).collect();
                json!({
                    "name": c.name,
                    "label": c.label,
                    "color": palette::to_hex(self.colors[k]),
                    "volume": volumes,
                    "volume_ml": if mm { json!(volumes) } else { Value::Null },
                    "centroid": centroids,
                    "bounding_box": boxes,
                    "min_volume": {"volume": self.volume(cycle.min.volume), "time": cycle.min.time},
                    "max_volume": {"volume": self.volume(cycle.max.volume), "time": cycle.max.time},
                    "stroke_volume": self.volume(cycle.stroke_volume),
                    "ejection_fraction": cycle.ejection_fraction.map(round),
                    "amplitude": amplitude.map(|[x, y, z]| json!({"x": x, "y": y, "z": z})),
                    "amplitude_mm": if mm { anatomical.unwrap_or(Value::Null) } else { Value::Null },
                })
            })
            .collect();
        json!({
            "model": model.display().to_string(),
            "units": {
                "length": self.units.length(),
                "volume": self.units.volume(),
                "time": time_axis(self.frame),
            },
            "frame": {
                "name": self.frame.name(),
                "positive": self.frame.positive(),
            },
            "times": m.times,
            "classes": classes,
        })
    }
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
    let masks = itv_masks(&model, grid, times)?;
    let options = dynaslice_mesh::Options {
        resolution,
        ..dynaslice_mesh::Options::default()
    };
    let meshes = itv_meshes(&model, model.domain().bounds(), times, &options)?;
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
