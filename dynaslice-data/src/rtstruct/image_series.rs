//! The slices of an image series (a planning CT) that RT Structure Sets are drawn on: their
//! SOP UIDs, planes and pixel grids, read from the headers of a folder of DICOM files.
//!
//! Every regular file of the folder is read up to its Pixel Data (never the pixels). Files that
//! are not DICOM, and DICOM files without an image plane (an RT Structure Set beside the CT),
//! are skipped with a warning. It is an error, naming the folder, when the images belong to
//! more than one series or frame of reference, when an image lacks SOP Class or Instance UID,
//! Image Position or Orientation (Patient), Pixel Spacing, Rows or Columns, or when no image is
//! left.

use std::path::{Path, PathBuf};

use dicom_dictionary_std::tags;
use dicom_object::InMemDicomObject;

use super::write::{ImageRef, ImageSeries};
use super::{dicom, get_text, read_object_file};
use dynaslice_sequence::error::{DataError, Result};

/// Most files a series folder may hold (a whole-body CT at 0.5 mm has a few thousand).
pub const MAX_FILES: usize = 20_000;

/// SOP Class UID referenced for the study in RT Referenced Study Sequence (Detached Study
/// Management, retired, with the Study Instance UID as instance: what planning systems write).
pub const STUDY_SOP_CLASS_UID: &str = "1.2.840.10008.3.1.2.3.1";

/// One image of the series.
#[derive(Debug, Clone, PartialEq)]
pub struct Slice {
    /// Its SOP UIDs and Image Position (Patient), LPS mm.
    pub image: ImageRef,
    /// Image Orientation (Patient): the direction of the rows (increasing column index) and of
    /// the columns (increasing row index), unit, LPS.
    pub orientation: [[f64; 3]; 2],
    /// Pixel Spacing: between rows, then between columns (mm).
    pub spacing: [f64; 2],
    /// Rows and Columns.
    pub size: [usize; 2],
}

/// An image series as a structure set references it.
#[derive(Debug, Clone, PartialEq)]
pub struct CtSeries {
    /// Frame of Reference UID.
    pub frame_of_reference_uid: String,
    /// Study Instance UID.
    pub study_uid: String,
    /// The study, series and images, as written into a structure set.
    pub series: ImageSeries,
    /// The slices, ordered along their normal.
    pub slices: Vec<Slice>,
}

/// Reads the series in folder `dir`. See the [module docs](self) for what is an error.
pub fn read(dir: &Path) -> Result<CtSeries> {
    let at = |what: String| dicom(what).in_file(dir);
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| DataError::new(e.into()).in_file(dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .take(MAX_FILES + 1)
        .collect();
    if paths.len() > MAX_FILES {
        return Err(at(format!(
            "more than {MAX_FILES} files in the series folder"
        )));
    }
    paths.sort();
    let mut slices = Vec::new();
    let mut ids: Option<(String, String, String)> = None;
    for path in &paths {
        if !is_dicom(path) {
            log::warn!("{}: not a DICOM file; skipped", path.display());
            continue;
        }
        let obj = read_object_file(path)?;
        if obj.get(tags::IMAGE_POSITION_PATIENT).is_none() {
            log::warn!("{}: no image plane (not an image); skipped", path.display());
            continue;
        }
        let slice = slice(&obj).map_err(|e| e.in_file(path))?;
        let these = (
            text(
                &obj,
                tags::SERIES_INSTANCE_UID,
                "Series Instance UID (0020,000E)",
            )
            .map_err(|e| e.in_file(path))?,
            text(
                &obj,
                tags::FRAME_OF_REFERENCE_UID,
                "Frame of Reference UID (0020,0052)",
            )
            .map_err(|e| e.in_file(path))?,
            text(
                &obj,
                tags::STUDY_INSTANCE_UID,
                "Study Instance UID (0020,000D)",
            )
            .map_err(|e| e.in_file(path))?,
        );
        match &ids {
            None => ids = Some(these),
            Some(first) if *first != these => {
                return Err(at(format!(
                    "the folder holds images of more than one series or frame of reference \
                     ({} has series {} in frame {}, others series {} in frame {}); give the \
                     folder of one series",
                    path.display(),
                    these.0,
                    these.1,
                    first.0,
                    first.1
                )))
            }
            Some(_) => {}
        }
        slices.push(slice);
    }
    let Some((series_uid, frame_of_reference_uid, study_uid)) = ids else {
        return Err(at("no DICOM image in the folder".into()));
    };
    let n = normal(&slices[0].orientation);
    slices.sort_by(|a, b| dot(a.image.point, n).total_cmp(&dot(b.image.point, n)));
    Ok(CtSeries {
        series: ImageSeries {
            study: Some((STUDY_SOP_CLASS_UID.to_string(), study_uid.clone())),
            series_uid: Some(series_uid),
            images: slices.iter().map(|s| s.image.clone()).collect(),
        },
        frame_of_reference_uid,
        study_uid,
        slices,
    })
}

/// Whether the file starts like DICOM Part 10 (preamble and `DICM`).
fn is_dicom(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 132];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| &head[128..] == b"DICM")
}

fn text(obj: &InMemDicomObject, tag: dicom_object::Tag, name: &str) -> Result<String> {
    get_text(obj, tag)
        .filter(|s| !s.is_empty())
        .ok_or_else(|| dicom(format!("no {name}")))
}

fn numbers(
    obj: &InMemDicomObject,
    tag: dicom_object::Tag,
    name: &str,
    n: usize,
) -> Result<Vec<f64>> {
    obj.get(tag)
        .and_then(|e| e.to_multi_float64().ok())
        .filter(|v| v.len() == n && v.iter().all(|x| x.is_finite()))
        .ok_or_else(|| dicom(format!("{name} is not {n} numbers")))
}

fn slice(obj: &InMemDicomObject) -> Result<Slice> {
    let p = numbers(
        obj,
        tags::IMAGE_POSITION_PATIENT,
        "Image Position (Patient) (0020,0032)",
        3,
    )?;
    let o = numbers(
        obj,
        tags::IMAGE_ORIENTATION_PATIENT,
        "Image Orientation (Patient) (0020,0037)",
        6,
    )?;
    let s = numbers(obj, tags::PIXEL_SPACING, "Pixel Spacing (0028,0030)", 2)?;
    let size = |tag, name: &str| {
        obj.get(tag)
            .and_then(|e| e.to_int::<u32>().ok())
            .filter(|&v| v > 0)
            .map(|v| v as usize)
            .ok_or_else(|| dicom(format!("no valid {name}")))
    };
    let orientation = [[o[0], o[1], o[2]], [o[3], o[4], o[5]]];
    let norm = |v: [f64; 3]| dot(v, v).sqrt();
    if orientation.iter().any(|v| (norm(*v) - 1.0).abs() > 1e-3)
        || dot(orientation[0], orientation[1]).abs() > 1e-3
    {
        return Err(dicom(
            "Image Orientation (Patient) (0020,0037) is not two orthogonal unit vectors".into(),
        ));
    }
    if s.iter().any(|&v| v <= 0.0) {
        return Err(dicom("Pixel Spacing (0028,0030) is not positive".into()));
    }
    Ok(Slice {
        image: ImageRef {
            class_uid: text(obj, tags::SOP_CLASS_UID, "SOP Class UID (0008,0016)")?,
            instance_uid: text(obj, tags::SOP_INSTANCE_UID, "SOP Instance UID (0008,0018)")?,
            point: [p[0], p[1], p[2]],
        },
        orientation: orientation.map(|v| v.map(|x| x / norm(v))),
        spacing: [s[0], s[1]],
        size: [
            size(tags::ROWS, "Rows (0028,0010)")?,
            size(tags::COLUMNS, "Columns (0028,0011)")?,
        ],
    })
}

/// The unit normal (row × column direction) of an orientation.
pub fn normal(orientation: &[[f64; 3]; 2]) -> [f64; 3] {
    let [a, b] = orientation;
    let c = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let n = dot(c, c).sqrt();
    c.map(|x| x / n)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
