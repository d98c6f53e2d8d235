//! `dynaslice rtstruct MODEL.dsm --like PHASE.dcm -o DIR` (plus `--ct CT_DIR` or
//! `--like-grid REF.nii.gz`, `--times`, `--itv`): the model's structures as DICOM RT Structure
//! Sets, one per time, on the planes of the reference geometry, for a treatment planning system
//! (docs/tps-import.md).

use super::console::errln;
use super::input::regular_file;
use super::options::{count, f64_in, non_negative_f64_to, time_series, MAX_THREADS, MAX_TIMES};
use super::progress::Progress;
use super::times::times_option;
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::Model;
use dynaslice_data::nesting::whole_structures;
use dynaslice_data::nifti::read_geometry;
use dynaslice_data::rtstruct::image_series::{self, CtSeries};
use dynaslice_data::rtstruct::write::{
    self as rtwrite, patient_to_world, world_to_patient, ImageSeries, PlanarContour, RoiContours,
    StructureSet, Template,
};
use dynaslice_data::rtstruct::RoiExtent;
use dynaslice_data::{manifest, FrameRange, Plane, Rect, TimeSeries};
use dynaslice_geometry::Polygon;
use dynaslice_mesh::planar::{contour_plane, PlanarOptions, PlaneField, Union, Whole, EVERYWHERE};
use dynaslice_mesh::{LevelSets, Surfaces};
use dynaslice_model::ModelFile;
use dynaslice_output::{OutputSet, Plan};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `dynaslice rtstruct`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Files: DIR/RS_tIII.dcm, one RT Structure Set per time (III its index from 000), and
DIR/rtstruct.seq listing them as `<time> <file>` lines (a sequence manifest, readable by
`dynaslice train`). Existing files are replaced only with --force.

Planes: every slice of --ct (the planning CT's images, each contour referencing its image),
else every slice of --like-grid (a NIfTI image of the patient), else every plane that --like
has contours on; only where the plane meets the model's domain. Contours: the Eq. 11 label
regions (what `dynaslice labels` writes), their boundaries placed on the model's zero level set,
simplified to --tolerance; holes as separate contours inside their outer one (even-odd rule). A
class drawn around others (nesting, see `dynaslice train --nesting`) is written whole: its own
region and theirs, as it was drawn.

Each file carries --like's patient, study, frame of reference and referenced series, and each
class its ROI (matched by name): ROI Number, Name, Display Color and RT ROI Interpreted Type.")]
pub struct Args {
    /// Model file (.dsm), trained on RT Structure Sets of this patient (or in their frame).
    model: PathBuf,
    /// An RT Structure Set of the patient (e.g. one phase of the training input): the patient,
    /// study, frame of reference, referenced images and ROIs the written files carry.
    #[arg(long, value_name = "PHASE.dcm")]
    like: PathBuf,
    /// Folder of the planning CT series (DICOM images): contours on its slices, referencing
    /// them.
    #[arg(long, value_name = "CT_DIR", conflicts_with = "like_grid")]
    ct: Option<PathBuf>,
    /// Reference image (NIfTI): contours on its slices (its k axis).
    #[arg(long, value_name = "REF.nii.gz")]
    like_grid: Option<PathBuf>,
    /// Times: a list (0,0.5,1) or A:B:N, N evenly from A to B inclusive (default: the times
    /// of the model's training input,
    /// read from the sequence manifest the model records).
    #[arg(long, value_name = "TIMES", allow_hyphen_values = true,
          value_parser = time_series(MAX_TIMES))]
    times: Option<TimeSeries>,
    /// Add to every file an ITV per class: the union of its regions over the written times,
    /// named "ITV <class>".
    #[arg(long)]
    itv: bool,
    /// In-plane sampling step (mm) of the contouring grid, 0.01 to 100 (default: the
    /// reference's pixel spacing, else 1 mm).
    #[arg(long, value_parser = f64_in(MIN_STEP_MM, MAX_STEP_MM))]
    step: Option<f64>,
    /// Simplification tolerance (mm), 0 to 5: the most a contour may move from the exact zero
    /// level set's vertices (Douglas–Peucker); 0 keeps every vertex.
    #[arg(long, default_value_t = 0.1, value_parser = non_negative_f64_to(MAX_TOLERANCE_MM))]
    tolerance: f64,
    /// Output folder (created where missing).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Replace existing files in the output folder.
    #[arg(long)]
    force: bool,
    /// Worker threads (default: one per core).
    #[arg(long, value_parser = count(1, MAX_THREADS))]
    threads: Option<usize>,
}

/// The finest contouring step (mm): a hundredth of a millimetre is far below any CT's pixel.
const MIN_STEP_MM: f64 = 0.01;
/// The coarsest contouring step (mm).
const MAX_STEP_MM: f64 = 100.0;
/// The largest simplification (mm): half a centimetre, a planning margin's size; beyond it a
/// contour no longer follows the model's surface.
const MAX_TOLERANCE_MM: f64 = 5.0;

/// The manifest written beside the structure sets.
const MANIFEST: &str = "rtstruct.seq";

/// Distance (mm) within which a plane counts as meeting the model's domain.
const DOMAIN_SLACK_MM: f64 = 1e-6;

/// Runs `dynaslice rtstruct`.
pub fn run(a: Args) -> Result<()> {
    let mut plan = Plan::new(
        [Some(&a.model), Some(&a.like), a.like_grid.as_ref()]
            .into_iter()
            .flatten(),
        a.force,
    );
    plan.directory("-o", &a.output)?;
    let file = ModelFile::open(&a.model)?;
    let model = file.model();
    regular_file("RT Structure Set", &a.like)?;
    let template = Template::read(&a.like)?;
    let option = times_option(a.times.as_ref());
    let times = match &a.times {
        Some(series) => series.times(),
        None => input_times(&file, &model, &a.model)?,
    };
    for &t in &times {
        file.check_time(&option, t as f32)?;
    }
    let ct = a.ct.as_deref().map(image_series::read).transpose()?;
    if let Some(ct) = &ct {
        if ct.frame_of_reference_uid != template.frame_of_reference_uid {
            bail!(
                "{}: the CT's Frame of Reference UID {} differs from {}'s {}: they are not in \
                 one patient frame",
                a.ct.as_ref().expect("read above").display(),
                ct.frame_of_reference_uid,
                a.like.display(),
                template.frame_of_reference_uid
            );
        }
    }
    let (planes, default_step, series) = reference_planes(&a, &template, ct.as_ref(), &model)?;
    if planes.is_empty() {
        bail!("no plane of the reference geometry meets the model's domain");
    }
    let options = PlanarOptions {
        step: a.step.unwrap_or(default_step),
        tolerance: a.tolerance,
    };
    let rois = roi_definitions(&file, &template, a.itv);

    let names: Vec<String> = (0..times.len())
        .map(|i| format!("RS_t{i:03}.dcm"))
        .collect();
    // Every file (the structure sets and their manifest) goes in place at the end, all or
    // none; a folder made for them is removed again if the run fails.
    let mut files = OutputSet::new();
    files.create_dir(&a.output)?;
    for name in names.iter().map(String::as_str).chain([MANIFEST]) {
        let path = a.output.join(name);
        plan.beside(&path)?;
        if !a.force && path.exists() {
            bail!(
                "{}: the file exists; add --force to replace it",
                path.display()
            );
        }
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    let start = Instant::now();
    let classes: Vec<usize> = (0..model.num_classes()).collect();
    // Nested classes (trained disjoint) are written whole: an outer ROI is its own region and
    // those nested in it, as drawn.
    let groups = whole_structures(
        &file
            .record()
            .nested(&model)
            .map_err(|e| anyhow!("{}: {e}", a.model.display()))?,
        classes.len(),
    );
    let level_sets = |t: f64| Whole {
        field: LevelSets::new(
            &model,
            t as f32,
            classes.clone(),
            Surfaces::Partition,
            EVERYWHERE,
        ),
        groups: groups.clone(),
    };
    // Each time (and the ITV) contours every plane: tens of seconds on a loaded machine.
    // With --itv the count is of passes (the ITV's union, then each phase), not of phases.
    let progress = Progress::new(
        if a.itv {
            "contouring the ITV, then each phase: pass"
        } else {
            "contouring: phase"
        },
        (times.len() + usize::from(a.itv)) as u64,
    );
    let itv = if a.itv {
        let union = Union(times.iter().map(|&t| level_sets(t)).collect());
        let itv = pool.install(|| contour_planes(&union, &planes, &options))?;
        progress.inc();
        Some(itv)
    } else {
        None
    };
    let mut manifest_text = format!(
        "# RT Structure Sets written by dynaslice rtstruct from {}\n",
        a.model.display()
    );
    for (i, &t) in times.iter().enumerate() {
        let contours = pool.install(|| contour_planes(&level_sets(t), &planes, &options))?;
        let mut set_rois = Vec::new();
        for (k, roi) in rois.iter().enumerate() {
            let source = if k < classes.len() {
                &contours[k]
            } else {
                &itv.as_ref().expect("ITV ROIs only with --itv")[k - classes.len()]
            };
            set_rois.push(RoiContours {
                contours: source.clone(),
                ..roi.clone()
            });
        }
        let set = StructureSet {
            label: format!("DynaSlice {i:03}"),
            name: format!("DynaSlice t = {}", t as f32),
            series_number: i as i32 + 1,
            rois: set_rois,
        };
        let path = a.output.join(&names[i]);
        let count: usize = set.rois.iter().map(|r| r.contours.len()).sum();
        if count == 0 {
            bail!(
                "{} (t = {}): no structure has a contour on any of the {} planes (step {} mm); \
                 nothing written. Check --times, the reference geometry, and --step",
                path.display(),
                t as f32,
                planes.len(),
                options.step
            );
        }
        rtwrite::stage(&mut files, &path, &template, &series, &set)?;
        manifest_text += &format!("{} {}\n", t as f32, names[i]);
        progress.println(format!(
            "contoured {} (t = {}): {} ROIs, {count} contours",
            path.display(),
            t as f32,
            set.rois.len()
        ));
        progress.inc();
    }
    progress.finish();
    files.write(&a.output.join(MANIFEST), manifest_text.as_bytes())?;
    files.commit()?;
    errln!(
        "wrote {} ({} phases) in {:.1} s; {} planes, step {} mm, tolerance {} mm",
        a.output.join(MANIFEST).display(),
        times.len(),
        start.elapsed().as_secs_f64(),
        planes.len(),
        options.step,
        options.tolerance
    );
    Ok(())
}

/// The times of the model's training input: the distinct times of the sequence manifest its
/// metadata records (`input = …`), with its `frames = …` selection. Other inputs record no
/// times the model file keeps; a static model has its one time.
fn input_times(file: &ModelFile, model: &Model, path: &Path) -> Result<Vec<f64>> {
    if file.is_static() {
        return Ok(vec![f64::from(model.domain().time_range().0)]);
    }
    let record = file.record();
    let give_times = "give --times A:B:N";
    let input = record.input.clone().ok_or_else(|| {
        anyhow!(
            "{}: the model records no training input; {give_times}",
            path.display()
        )
    })?;
    let manifest_path = PathBuf::from(&input);
    let is_manifest = [".seq", ".cslseq"]
        .iter()
        .any(|e| input.to_ascii_lowercase().ends_with(e));
    if !is_manifest || !manifest_path.is_file() {
        bail!(
            "{}: the times of the model's input {input} are not known here (only a sequence \
             manifest's are, read again from the path the model records, relative to where \
             it was trained); {give_times}",
            path.display()
        );
    }
    let entries = manifest::read(&manifest_path)?;
    let mut distinct: Vec<f64> = Vec::new();
    for e in entries {
        if distinct.last() != Some(&e.time) {
            distinct.push(e.time);
        }
    }
    let frames: FrameRange = match &record.frames {
        Some(f) => f
            .parse()
            .map_err(|e| anyhow!("{}: recorded frames: {e}", path.display()))?,
        None => FrameRange::ALL,
    };
    Ok(frames
        .indices(distinct.len())
        .into_iter()
        .map(|i| distinct[i])
        .collect())
}

/// The planes to contour (world RAS, each region the reference's extent within the model's
/// domain), the default grid step, and the images the contours reference.
fn reference_planes(
    a: &Args,
    template: &Template,
    ct: Option<&CtSeries>,
    model: &Model,
) -> Result<(Vec<Plane>, f64, ImageSeries)> {
    let (lo, hi) = model.domain().bounds();
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    let mut planes = Vec::new();
    let (step, series) = if let Some(ct) = ct {
        for s in &ct.slices {
            let [row, col] = s.orientation.map(patient_to_world);
            let extent = [
                (s.size[1] - 1) as f64 * s.spacing[1],
                (s.size[0] - 1) as f64 * s.spacing[0],
            ];
            planes.push(plane(
                patient_to_world(s.image.point),
                row,
                col,
                Rect {
                    min: [0.0; 2],
                    max: extent,
                },
            ));
        }
        let step = ct
            .slices
            .iter()
            .flat_map(|s| s.spacing)
            .fold(f64::INFINITY, f64::min);
        (step, ct.series.clone())
    } else if let Some(reference) = &a.like_grid {
        regular_file("reference", reference)?;
        let g = read_geometry(reference)?;
        let column = |k: usize| [g.affine[0][k], g.affine[1][k], g.affine[2][k]];
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let (du, dv) = (norm(column(0)), norm(column(1)));
        let (u, v) = (column(0).map(|x| x / du), column(1).map(|x| x / dv));
        for k in 0..g.dims[2] {
            let origin = std::array::from_fn(|r| g.affine[r][3] + k as f64 * g.affine[r][2]);
            planes.push(plane(
                origin,
                u,
                v,
                Rect {
                    min: [0.0; 2],
                    max: [(g.dims[0] - 1) as f64 * du, (g.dims[1] - 1) as f64 * dv],
                },
            ));
        }
        (du.min(dv), template.series.clone())
    } else {
        let seq = dynaslice_data::rtstruct::read(&a.like, RoiExtent::File)?;
        for p in &seq.frames()[0].planes {
            planes.push(plane(p.origin, p.u, p.v, p.roi));
        }
        (1.0, template.series.clone())
    };
    // Keep each plane's part inside the model's domain.
    let planes = planes
        .into_iter()
        .filter_map(|mut p| {
            let n = p.normal();
            let offsets: Vec<f64> = (0..8)
                .map(|c| {
                    let x: [f64; 3] =
                        std::array::from_fn(|k| if c >> k & 1 == 1 { hi[k] } else { lo[k] });
                    (0..3).map(|k| (x[k] - p.origin[k]) * n[k]).sum()
                })
                .collect();
            let meets = offsets.iter().any(|&d| d <= DOMAIN_SLACK_MM)
                && offsets.iter().any(|&d| d >= -DOMAIN_SLACK_MM);
            let b = p.box_roi(lo, hi);
            let roi = Rect {
                min: [p.roi.min[0].max(b.min[0]), p.roi.min[1].max(b.min[1])],
                max: [p.roi.max[0].min(b.max[0]), p.roi.max[1].min(b.max[1])],
            };
            (meets && roi.max[0] > roi.min[0] && roi.max[1] > roi.min[1]).then(|| {
                p.roi = roi;
                p
            })
        })
        .collect();
    Ok((planes, step, series))
}

fn plane(origin: [f64; 3], u: [f64; 3], v: [f64; 3], roi: Rect) -> Plane {
    Plane {
        origin,
        u,
        v,
        roi,
        annotations: Vec::new(),
    }
}

/// The written ROIs without contours: one per class (the template's ROI of the class's name:
/// its number, name, colour and type; else the class's label and colour), then with `itv` one
/// ITV per class, numbered after the largest number in use.
fn roi_definitions(file: &ModelFile, template: &Template, itv: bool) -> Vec<RoiContours> {
    let colors = file.class_colors();
    let mut rois: Vec<RoiContours> = file
        .classes()
        .iter()
        .zip(&colors)
        .map(|(class, &color)| {
            let roi = template.rois.iter().find(|r| r.name == class.name);
            if roi.is_none() {
                log::warn!(
                    "class \"{}\" has no ROI of that name in the template; writing it as ROI \
                     number {}",
                    class.name,
                    class.label
                );
            }
            RoiContours {
                number: roi.map_or(class.label, |r| r.number),
                name: class.name.clone(),
                color: roi.and_then(|r| r.color).unwrap_or(color),
                interpreted_type: roi.and_then(|r| r.interpreted_type.clone()),
                description: None,
                contours: Vec::new(),
            }
        })
        .collect();
    if itv {
        let mut next = rois.iter().map(|r| r.number).max().unwrap_or(0).max(0);
        let itvs: Vec<RoiContours> = rois
            .iter()
            .map(|r| {
                next += 1;
                RoiContours {
                    number: next,
                    name: format!("ITV {}", r.name),
                    color: r.color,
                    interpreted_type: None,
                    description: Some(format!(
                        "internal target volume of {}: the union of its regions over the \
                         written times (dynaslice rtstruct --itv)",
                        r.name
                    )),
                    contours: Vec::new(),
                }
            })
            .collect();
        rois.extend(itvs);
    }
    rois
}

/// Per channel of `field`, its contours on every plane as (LPS normal, LPS points).
fn contour_planes<F: PlaneField>(
    field: &F,
    planes: &[Plane],
    options: &PlanarOptions,
) -> Result<Vec<Vec<PlanarContour>>> {
    let mut out = vec![Vec::new(); field.channels()];
    for plane in planes {
        let per_channel = contour_plane(field, plane, options)?;
        let normal = world_to_patient(plane.normal());
        for (ch, polys) in per_channel.into_iter().enumerate() {
            out[ch].extend(polys.iter().map(|p: &Polygon| {
                (
                    normal,
                    p.iter()
                        .map(|&q| world_to_patient(plane.to_world(q)))
                        .collect(),
                )
            }));
        }
    }
    Ok(out)
}
