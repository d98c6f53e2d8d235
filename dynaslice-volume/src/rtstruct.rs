//! A model's structures as DICOM RT Structure Sets, one per time, for a treatment planning
//! system (docs/tps-import.md; `dynaslice rtstruct` is the command): the Eq. 11 label regions
//! contoured on the planes of a reference geometry (a planning CT's slices, a NIfTI image's
//! slices, or the contour planes of a template structure set), in the template's patient,
//! study and frame of reference.
//!
//! [`StructureSets::prepare`] reads and checks everything (the template, the times, the
//! reference planes, the ROIs) before any contouring; [`StructureSets::write`] contours and puts
//! every file in place at the end, all or none.

use anyhow::{anyhow, bail, Result};
use dynaslice_core::Model;
use dynaslice_data::nifti::read_geometry;
use dynaslice_data::rtstruct::image_series::{self, CtSeries};
use dynaslice_data::rtstruct::write::{
    self as rtwrite, patient_to_world, world_to_patient, ImageSeries, PlanarContour, RoiContours,
    StructureSet, Template,
};
use dynaslice_data::rtstruct::RoiExtent;
use dynaslice_data::{manifest, FrameRange, Plane, Rect};
use dynaslice_mesh::planar::{contour_plane, PlanarOptions, PlaneField, Union, Whole, EVERYWHERE};
use dynaslice_mesh::{LevelSets, Surfaces};
use dynaslice_model::ModelFile;
use dynaslice_output::OutputSet;
use dynaslice_sequence::input_file::require;
use dynaslice_sequence::nesting::whole_structures;
use std::path::{Path, PathBuf};

/// The manifest written beside the structure sets.
pub const MANIFEST: &str = "rtstruct.seq";

/// Distance (mm) within which a plane counts as meeting the model's domain.
const DOMAIN_SLACK_MM: f64 = 1e-6;

/// The planes the structures are contoured on.
#[derive(Clone, Debug)]
pub enum Reference {
    /// Every slice of a planning CT series (a folder of DICOM images); each contour references
    /// its image. Its Frame of Reference must be the template's.
    Ct(PathBuf),
    /// Every slice (k axis) of a NIfTI image of the patient.
    Grid(PathBuf),
    /// Every plane the template structure set has contours on.
    Template,
}

/// What [`StructureSets::prepare`] is asked for.
#[derive(Clone, Debug)]
pub struct StructureOptions {
    /// An RT Structure Set of the patient: the patient, study, frame of reference, referenced
    /// images and ROIs the written files carry.
    pub like: PathBuf,
    /// The planes to contour.
    pub reference: Reference,
    /// The times, one structure set each (`None`: the times of the model's training input).
    pub times: Option<Vec<f64>>,
    /// How the times were asked for, for the time rule's messages (e.g. `--times 0:1:5`).
    pub times_option: String,
    /// Add an ITV per class: the union of its regions over the written times.
    pub itv: bool,
    /// In-plane sampling step (mm) of the contouring grid (`None`: the reference's pixel
    /// spacing, else 1 mm).
    pub step: Option<f64>,
    /// Simplification tolerance (mm, Douglas–Peucker; 0 keeps every vertex).
    pub tolerance: f64,
}

/// One step of [`StructureSets::write`], for progress and its report.
#[derive(Clone, Debug)]
pub enum Contoured<'a> {
    /// The ITVs (the union over every time) are contoured.
    Itv,
    /// One time's structure set is contoured and staged.
    Phase {
        /// Where it goes.
        path: &'a Path,
        /// Its time.
        time: f64,
        /// Its ROIs.
        rois: usize,
        /// Its contours over every ROI.
        contours: usize,
    },
}

/// Structure sets ready to be contoured and written: every input read and checked.
pub struct StructureSets<'m> {
    model: Model<'m>,
    model_path: PathBuf,
    template: Template,
    /// The times, one structure set each.
    pub times: Vec<f64>,
    /// The planes contoured (world RAS, each region within the model's domain).
    pub planes: Vec<Plane>,
    /// The contouring grid's step and the simplification tolerance (mm).
    pub options: PlanarOptions,
    series: ImageSeries,
    rois: Vec<RoiContours>,
    groups: Vec<Vec<usize>>,
    itv: bool,
}

impl<'m> StructureSets<'m> {
    /// Reads the template, the times (checked by the model's time rule), the reference planes
    /// within the model's domain and the ROIs (the template's of each class's name, else the
    /// class's label and colour; with `itv`, one ITV per class after them). Errors name the
    /// file at fault.
    pub fn prepare(file: &'m ModelFile, o: &StructureOptions) -> Result<StructureSets<'m>> {
        let model = file.model();
        let model_path = file.path();
        require("RT Structure Set", &o.like).map_err(anyhow::Error::msg)?;
        let template = Template::read(&o.like)?;
        let times = match &o.times {
            Some(times) => times.clone(),
            None => input_times(file, &model, model_path)?,
        };
        for &t in &times {
            file.check_time(&o.times_option, t as f32)?;
        }
        let ct = match &o.reference {
            Reference::Ct(dir) => Some(image_series::read(dir)?),
            _ => None,
        };
        if let (Some(ct), Reference::Ct(dir)) = (&ct, &o.reference) {
            if ct.frame_of_reference_uid != template.frame_of_reference_uid {
                bail!(
                    "{}: the CT's Frame of Reference UID {} differs from {}'s {}: they are not \
                     in one patient frame",
                    dir.display(),
                    ct.frame_of_reference_uid,
                    o.like.display(),
                    template.frame_of_reference_uid
                );
            }
        }
        let (planes, default_step, series) = reference_planes(o, &template, ct.as_ref(), &model)?;
        if planes.is_empty() {
            bail!("no plane of the reference geometry meets the model's domain");
        }
        let options = PlanarOptions {
            step: o.step.unwrap_or(default_step),
            tolerance: o.tolerance,
        };
        let rois = roi_definitions(file, &template, o.itv);
        // Nested classes (trained disjoint) are written whole: an outer ROI is its own region
        // and those nested in it, as drawn.
        let nested = file
            .record()
            .nested(&model)
            .map_err(|e| anyhow!("{}: {e}", model_path.display()))?;
        let groups = whole_structures(&nested, model.num_classes());
        Ok(StructureSets {
            model,
            model_path: model_path.to_path_buf(),
            template,
            times,
            planes,
            options,
            series,
            rois,
            groups,
            itv: o.itv,
        })
    }

    /// The files [`write`](Self::write) puts in `dir`: `RS_tIII.dcm` per time, then the
    /// manifest listing them.
    pub fn files(&self, dir: &Path) -> Vec<PathBuf> {
        (0..self.times.len())
            .map(|i| dir.join(set_name(i)))
            .chain([dir.join(MANIFEST)])
            .collect()
    }

    /// Contours every time (and the ITVs first) on the planes, on the caller's rayon pool, and
    /// writes the structure sets and their manifest into `dir` (created where missing), all or
    /// none; existing files are replaced only with `force`. `step` hears of each step done.
    pub fn write(&self, dir: &Path, force: bool, mut step: impl FnMut(Contoured)) -> Result<()> {
        let mut files = OutputSet::new();
        files.create_dir(dir)?;
        // With --force over a set of more times, the earlier set's extra RS files go too.
        files.supersede(dir, is_set_name);
        if !force {
            if let Some(path) = self.files(dir).into_iter().find(|p| p.exists()) {
                bail!(
                    "{}: the file exists; add --force to replace it",
                    path.display()
                );
            }
        }
        let classes: Vec<usize> = (0..self.model.num_classes()).collect();
        let level_sets = |t: f64| Whole {
            field: LevelSets::new(
                &self.model,
                t as f32,
                classes.clone(),
                Surfaces::Partition,
                EVERYWHERE,
            ),
            groups: self.groups.clone(),
        };
        let itv = if self.itv {
            let union = Union(self.times.iter().map(|&t| level_sets(t)).collect());
            let itv = contour_planes(&union, &self.planes, &self.options)?;
            step(Contoured::Itv);
            Some(itv)
        } else {
            None
        };
        let mut manifest_text = format!(
            "# RT Structure Sets written by dynaslice rtstruct from {}\n",
            self.model_path.display()
        );
        for (i, &t) in self.times.iter().enumerate() {
            let contours = contour_planes(&level_sets(t), &self.planes, &self.options)?;
            let rois = self.rois.iter().enumerate().map(|(k, roi)| {
                let source = match k.checked_sub(classes.len()) {
                    None => &contours[k],
                    Some(j) => &itv.as_ref().expect("ITV ROIs only with an ITV")[j],
                };
                RoiContours {
                    contours: source.clone(),
                    ..roi.clone()
                }
            });
            let set = StructureSet {
                label: format!("DynaSlice {i:03}"),
                name: format!("DynaSlice t = {}", t as f32),
                series_number: i as i32 + 1,
                rois: rois.collect(),
            };
            let name = set_name(i);
            let path = dir.join(&name);
            let count: usize = set.rois.iter().map(|r| r.contours.len()).sum();
            if count == 0 {
                bail!(
                    "{} (t = {}): no structure has a contour on any of the {} planes (step {} \
                     mm); nothing written. Check --times, the reference geometry, and --step",
                    path.display(),
                    t as f32,
                    self.planes.len(),
                    self.options.step
                );
            }
            rtwrite::stage(&mut files, &path, &self.template, &self.series, &set)?;
            manifest_text += &format!("{} {name}\n", t as f32);
            step(Contoured::Phase {
                path: &path,
                time: t,
                rois: set.rois.len(),
                contours: count,
            });
        }
        files.write(&dir.join(MANIFEST), manifest_text.as_bytes())?;
        files.commit()
    }
}

/// The file name of the `i`th time's structure set.
fn set_name(i: usize) -> String {
    format!("RS_t{i:03}.dcm")
}

/// Whether `name` is one of [`set_name`]'s names (any number of digits).
fn is_set_name(name: &str) -> bool {
    name.strip_prefix("RS_t")
        .and_then(|rest| rest.strip_suffix(".dcm"))
        .is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit()))
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
    o: &StructureOptions,
    template: &Template,
    ct: Option<&CtSeries>,
    model: &Model,
) -> Result<(Vec<Plane>, f64, ImageSeries)> {
    let (lo, hi) = model.domain().bounds();
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    let mut planes = Vec::new();
    let (step, series) = match (&o.reference, ct) {
        (_, Some(ct)) => {
            for s in &ct.slices {
                let [row, col] = s.orientation.map(patient_to_world);
                let extent = [
                    (s.size[1] - 1) as f64 * s.spacing[1],
                    (s.size[0] - 1) as f64 * s.spacing[0],
                ];
                planes.push(plane(patient_to_world(s.image.point), row, col, extent));
            }
            let step = ct
                .slices
                .iter()
                .flat_map(|s| s.spacing)
                .fold(f64::INFINITY, f64::min);
            (step, ct.series.clone())
        }
        (Reference::Grid(reference), None) => {
            require("reference", reference).map_err(anyhow::Error::msg)?;
            let g = read_geometry(reference)?;
            let column = |k: usize| [g.affine[0][k], g.affine[1][k], g.affine[2][k]];
            let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let (du, dv) = (norm(column(0)), norm(column(1)));
            let (u, v) = (column(0).map(|x| x / du), column(1).map(|x| x / dv));
            for k in 0..g.dims[2] {
                let origin = std::array::from_fn(|r| g.affine[r][3] + k as f64 * g.affine[r][2]);
                let extent = [(g.dims[0] - 1) as f64 * du, (g.dims[1] - 1) as f64 * dv];
                planes.push(plane(origin, u, v, extent));
            }
            (du.min(dv), template.series.clone())
        }
        _ => {
            let seq = dynaslice_data::rtstruct::read(&o.like, RoiExtent::File)?;
            for p in &seq.frames()[0].planes {
                planes.push(Plane {
                    annotations: Vec::new(),
                    ..*p
                });
            }
            (1.0, template.series.clone())
        }
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

/// A plane without annotations whose region runs from its origin to `extent` along (u, v).
fn plane(origin: [f64; 3], u: [f64; 3], v: [f64; 3], extent: [f64; 2]) -> Plane {
    Plane {
        origin,
        u,
        v,
        roi: Rect {
            min: [0.0; 2],
            max: extent,
        },
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
            out[ch].extend(polys.iter().map(|p| {
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
