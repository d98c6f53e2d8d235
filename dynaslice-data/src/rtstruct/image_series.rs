//! The slices of an image series (a planning CT) that RT Structure Sets are drawn on: their
//! SOP UIDs, planes and pixel grids, read from the headers of a folder of DICOM files.
//!
//! Every regular file of the folder is read up to its Pixel Data (never the pixels). Files that
//! are not DICOM, and DICOM files without an image plane (an RT Structure Set beside the CT),
//! are skipped with a warning. It is an error, naming the folder, when the images belong to
//! more than one series or frame of reference, when an image lacks SOP Class or Instance UID,
//! Image Position or Orientation (Patient), Pixel Spacing, Rows or Columns, when no image is
//! left, or when the images are not one stack: two at one position along the normal (a repeated
//! Image Position (Patient)) or one not parallel to the others, both named.

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

/// Slices closer than this (mm) along the stack's normal are at one position.
const SAME_POSITION_MM: f64 = 1e-3;

/// The most a slice's normal may differ from the first's (the sine of the angle): a series
/// is one stack of parallel images.
const PARALLEL_SINE: f64 = 1e-3;

/// Refuses a series whose slices (`order`: sorted along `n`) are not one stack of parallel
/// images at distinct positions, naming the files: repeated Image Position (Patient) values
/// would put contours of different images on one plane.
fn check_stack(
    slices: &[Slice],
    files: &[&Path],
    order: &[usize],
    n: [f64; 3],
) -> std::result::Result<(), String> {
    for (i, s) in slices.iter().enumerate() {
        let m = normal(&s.orientation);
        let cross = [
            m[1] * n[2] - m[2] * n[1],
            m[2] * n[0] - m[0] * n[2],
            m[0] * n[1] - m[1] * n[0],
        ];
        if dot(cross, cross).sqrt() > PARALLEL_SINE {
            return Err(format!(
                "{}: its Image Orientation (Patient) is not parallel to {}'s; a series is one \
                 stack of parallel images",
                files[i].display(),
                files[0].display()
            ));
        }
    }
    for pair in order.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let gap = dot(slices[b].image.point, n) - dot(slices[a].image.point, n);
        if gap.abs() < SAME_POSITION_MM {
            let repeated = order
                .iter()
                .filter(|&&i| {
                    (dot(slices[i].image.point, n) - dot(slices[a].image.point, n)).abs()
                        < SAME_POSITION_MM
                })
                .count();
            return Err(format!(
                "{} and {} are at one position along the stack ({} slices share Image Position \
                 (Patient) {:?}): the series' slice positions are repeated or inconsistent",
                files[a].display(),
                files[b].display(),
                repeated,
                slices[a].image.point
            ));
        }
    }
    Ok(())
}

/// Reads the series in folder `dir`. See the [module docs](self) for what is an error; slices
/// at one position or not parallel are refused by name.
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
    let mut files: Vec<&Path> = Vec::new();
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
        files.push(path);
    }
    let Some((series_uid, frame_of_reference_uid, study_uid)) = ids else {
        return Err(at("no DICOM image in the folder".into()));
    };
    let n = normal(&slices[0].orientation);
    let mut order: Vec<usize> = (0..slices.len()).collect();
    order.sort_by(|&a, &b| dot(slices[a].image.point, n).total_cmp(&dot(slices[b].image.point, n)));
    check_stack(&slices, &files, &order, n).map_err(at)?;
    let mut slices: Vec<Option<Slice>> = slices.into_iter().map(Some).collect();
    let slices: Vec<Slice> = order
        .iter()
        .map(|&i| slices[i].take().expect("each index once"))
        .collect();
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

#[cfg(test)]
mod tests {
    use super::*;

    fn slice(z: f64, column: [f64; 3]) -> Slice {
        Slice {
            image: ImageRef {
                class_uid: "1.2.840.10008.5.1.4.1.1.2".into(),
                instance_uid: format!("1.2.3.{}", (z * 10.0) as i64),
                point: [0.0, 0.0, z],
            },
            orientation: [[1.0, 0.0, 0.0], column],
            spacing: [1.0, 1.0],
            size: [4, 4],
        }
    }

    #[test]
    fn a_stack_with_repeated_positions_or_tilted_slices_is_refused_by_name() {
        let files = [
            Path::new("ct/a.dcm"),
            Path::new("ct/b.dcm"),
            Path::new("ct/c.dcm"),
        ];
        let n = [0.0, 0.0, 1.0];
        let straight = [0.0, 1.0, 0.0];
        let good = [
            slice(0.0, straight),
            slice(2.0, straight),
            slice(4.0, straight),
        ];
        check_stack(&good, &files, &[0, 1, 2], n).unwrap();
        // Two images at z = 2: their contours would share one plane.
        let repeated = [
            slice(2.0, straight),
            slice(0.0, straight),
            slice(2.0, straight),
        ];
        let e = check_stack(&repeated, &files, &[1, 0, 2], n).unwrap_err();
        assert!(
            e.contains("ct/a.dcm and ct/c.dcm are at one position"),
            "{e}"
        );
        assert!(e.contains("2 slices share"), "{e}");
        let tilted = [
            slice(0.0, straight),
            slice(2.0, [0.0, 0.8, 0.6]),
            slice(4.0, straight),
        ];
        let e = check_stack(&tilted, &files, &[0, 1, 2], n).unwrap_err();
        assert!(
            e.starts_with("ct/b.dcm") && e.contains("not parallel"),
            "{e}"
        );
    }
}
