//! Reader for DICOM RT Structure Sets (RTSTRUCT): the planar contours a radiotherapy planning
//! system stores per structure (ROI), as one static timestep.
//!
//! A 4D CT contoured per breathing phase gives one RTSTRUCT per phase; [`read`] returns one
//! timestep at time 0 and a sequence manifest places each file in time.
//!
//! # Coordinates
//! DICOM patient coordinates are LPS (x to the patient's left, y to posterior, z to head) in
//! millimetres; our world frame is RAS, NIfTI's. The reader negates x and y, so an RTSTRUCT and a
//! NIfTI of the same patient (same scanner frame of reference) land in the same place. z is
//! unchanged, so the `z = …` a message reports is the slice position the planning system shows.
//!
//! # Structures and classes
//! Each ROI of the StructureSetROISequence (3006,0020) whose ROIContourSequence (3006,0039)
//! item (matched by Referenced ROI Number) holds `CLOSED_PLANAR` contours becomes a class: ROI
//! Name as name (`ROI <number>` when empty), ROI Number as label, ROI Display Color (3006,002A)
//! as colour. Classes are ordered by ROI Number. `CLOSEDPLANAR_XOR` contours (DICOM 2020) are read
//! like `CLOSED_PLANAR`, since the even-odd rule below is exactly their XOR.
//!
//! # Planes
//! Contours that share a plane form one [`Plane`]: same normal within [`NORMAL_TOLERANCE_RAD`]
//! and same offset along it within [`PLANE_TOLERANCE_MM`] (from the plane's lowest contour). The
//! normal of an orientation is the area-weighted mean of its contours' normals, with its largest
//! component positive; u is the world axis least aligned with it, made orthogonal and unit, and
//! v = n × u (the `.csl` reader's rule). For axial contours that gives u = x, v = y, n = z of
//! RAS, and the origin is the point of the plane nearest the world origin, so plane coordinates
//! are the RAS x and y in millimetres. Planes are ordered by orientation (in order of first
//! appearance), then by offset.
//!
//! Several contours of one ROI on one plane are outer boundaries, holes and islands by the
//! even-odd rule (RTSTRUCT has no explicit holes; rt-utils and dicompyler read it this way): a
//! contour inside an odd number of the ROI's other contours on that plane is a hole.
//! [`Sequence::new`] orients them by that nesting. Contours of one ROI that cross or touch (other
//! than at a shared vertex, which it separates) are an error naming the ROI, the plane's position
//! and the contour items involved.
//!
//! # Regions of interest
//! As in the `.csl` reader, every plane's region of interest is the projection of the bounding
//! box of all the file's contour points, grown on each side by [`ROI_MARGIN_FRACTION`] of its
//! diagonal but at least [`MIN_ROI_MARGIN_MM`]. An RTSTRUCT contour is a complete cross-section
//! of its structure, so "absent from this plane" holds across the whole contoured field, not
//! only near the other contours of that plane.
//!
//! # Absence
//! A plane annotates an ROI with no contour as absent; [`RoiExtent`] decides on which planes:
//! - [`RoiExtent::File`] (default): every ROI is taken as completely contoured, so it is absent
//!   on every plane of the file where it has no contour (among the planes of the orientations it
//!   is contoured in: an ROI contoured only axially says nothing about sagittal planes).
//! - [`RoiExtent::Own`]: only on the planes between its own first and last contour plane along
//!   each normal, so a short structure (a GTV contoured on a few slices) is not claimed absent
//!   far away, where it may simply not have been contoured.
//!
//! # Bad input: errors and skips
//! Errors ([`ErrorKind::Dicom`], naming the file, and where they concern one the ROI as class and
//! its contour item, counted from 1 in its ContourSequence):
//! - not a readable DICOM file (Part 10, with or without preamble; the file meta group ends
//!   where group 0002 does), an unknown transfer syntax or one whose data set is compressed
//!   (deflated), Modality (0008,0060) other than `RTSTRUCT`, no StructureSetROISequence or
//!   ROIContourSequence;
//! - a file over [`MAX_FILE_BYTES`], an element or item declaring more bytes than are left in
//!   the file (refused where the parser decodes its header, so no value ever takes more memory
//!   than the file's size), sequences nested more than [`MAX_NESTING`] deep, more than
//!   [`MAX_CONTOURS`] contours, [`MAX_ORIENTATIONS`] plane orientations or [`MAX_ANNOTATIONS`]
//!   plane × ROI annotations;
//! - a missing or repeated ROI Number, a ROIContourSequence item naming an undefined ROI or one
//!   already given;
//! - an `OPEN_PLANAR` or `OPEN_NONPLANAR` contour (a curve bounds no region), a missing or
//!   unknown Contour Geometric Type;
//! - ContourData missing, not numbers, with a count that is not a multiple of 3 or disagrees
//!   with Number of Contour Points, a NaN or infinite coordinate, fewer than 3 points;
//! - a contour of zero area (its points collinear or repeated), a contour whose points are not
//!   coplanar within [`PLANE_TOLERANCE_MM`];
//! - no ROI with a closed contour, and everything [`Sequence::new`] rejects (crossing contours,
//!   two ROIs with one name).
//!
//! Skips and repairs, each a `log::warn!` naming the file and the ROI:
//! - `POINT` contours (isocentres, markers) are skipped; an ROI of only points is skipped;
//! - an ROI with no contour at all is skipped;
//! - an ROI Display Color that is not three values in 0–255 is dropped;
//! - an empty ROI Name becomes `ROI <number>`;
//! - repeated consecutive points of a contour (and a closing point equal to the first) are
//!   dropped; this changes no geometry.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;

use dicom_dictionary_std::tags;
use dicom_object::{InMemDicomObject, Tag};

use super::reslice::{normalize, plane_axes};
use dynaslice_geometry::{Point2, Polygon};
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;
use dynaslice_sequence::sequence::{
    cross, dot, Annotation, ClassInfo, Frame, Plane, Rect, Sequence,
};

mod bounded;
pub mod image_series;
pub mod write;

/// Files larger than this (256 MiB) are refused before parsing. Clinical structure sets are
/// tens of megabytes; reading takes about ten times the file size in memory (the parsed decimal
/// strings; measured 160 MB for a 17 MB file). An element or item declaring more bytes than the
/// file has left is refused as its header is decoded, before any of its value is read.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// Most sequences nested in one another (an RT Structure Set nests four: Referenced Frame of
/// Reference, RT Referenced Study, RT Referenced Series, Contour Image). Bounds the parser's
/// recursion, so that no file can overflow the stack.
pub const MAX_NESTING: usize = 32;

/// Most contours (of all ROIs, `POINT` ones included) a file may hold.
pub const MAX_CONTOURS: usize = 1_000_000;

/// Most distinct plane orientations a file may hold (real files have one to three); bounds the
/// orientation matching, which compares each contour with every orientation found so far.
pub const MAX_ORIENTATIONS: usize = 100;

/// Most plane × ROI annotations (absences included) the sequence may get; bounds memory when many
/// ROIs meet many planes.
pub const MAX_ANNOTATIONS: usize = 4_000_000;

/// Distance (mm) within which contour points count as coplanar, and within which two contour
/// planes of one orientation are one plane. Rounding DS values to two decimals moves a point at
/// most 0.009 mm off its plane.
pub const PLANE_TOLERANCE_MM: f64 = 0.01;

/// Angle (radians) within which two contour normals are one orientation.
pub const NORMAL_TOLERANCE_RAD: f64 = 1e-4;

/// Fraction of the file's contour bounding-box diagonal added on each side of it for the planes'
/// regions of interest (the `.csl` reader's margin).
pub const ROI_MARGIN_FRACTION: f64 = 0.05;

/// Smallest margin (mm) around the file's contour bounding box for the regions of interest.
pub const MIN_ROI_MARGIN_MM: f64 = 10.0;

/// On which planes an ROI without a contour there is annotated absent. See the
/// [module docs](self#absence).
///
/// RTSTRUCT does not say whether a structure was contoured on every slice or only where the
/// planner looked; the choice says which is assumed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum RoiExtent {
    /// Every ROI is completely contoured: it is absent on every plane of the file (of the
    /// orientations it is contoured in) where it has no contour.
    #[default]
    File,
    /// An ROI is absent only on the planes between its own first and last contour plane along
    /// the plane normal; elsewhere the plane says nothing about it.
    Own,
}

impl std::fmt::Display for RoiExtent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            RoiExtent::File => "file",
            RoiExtent::Own => "own",
        })
    }
}

impl std::str::FromStr for RoiExtent {
    type Err = String;

    /// `file` or `own`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "file" => Ok(RoiExtent::File),
            "own" => Ok(RoiExtent::Own),
            _ => Err(format!("expected `file` or `own`, found `{s}`")),
        }
    }
}

/// One closed contour as read, in RAS millimetres.
#[derive(Debug)]
struct Contour {
    /// 1-based item of the ROI's ContourSequence, for messages.
    item: usize,
    points: Vec<[f64; 3]>,
    /// Newell's vector: normal × twice the area.
    newell: [f64; 3],
    centroid: [f64; 3],
}

/// One ROI with its closed contours.
#[derive(Debug)]
struct Roi {
    number: i32,
    name: String,
    color: Option<[u8; 3]>,
    contours: Vec<Contour>,
}

fn dicom(what: String) -> DataError {
    DataError::new(ErrorKind::Dicom(what))
}

fn get_items(obj: &InMemDicomObject, tag: Tag) -> Option<&[InMemDicomObject]> {
    obj.get(tag).and_then(|e| e.items())
}

fn get_text(obj: &InMemDicomObject, tag: Tag) -> Option<String> {
    obj.get(tag).and_then(|e| e.to_str().ok()).map(|s| {
        s.trim_matches(|c: char| c.is_whitespace() || c == '\0')
            .to_string()
    })
}

/// Reads an RT Structure Set as a one-timestep sequence at time 0. See the [module docs](self)
/// for coordinates, classes, planes, absence ([`RoiExtent`]) and what is an error.
pub fn read(path: &Path, extent: RoiExtent) -> Result<Sequence> {
    read_with_frame(path, extent).map(|(sequence, _)| sequence)
}

/// [`read`], with the Frame of Reference UID the contours are in (from the Referenced Frame of
/// Reference Sequence (3006,0010), else the ROIs' Referenced Frame of Reference UID
/// (3006,0024)), where the file gives one.
pub fn read_with_frame(path: &Path, extent: RoiExtent) -> Result<(Sequence, Option<String>)> {
    let obj = read_object_file(path)?;
    let rois = parse_rois(&obj, path).map_err(|e| e.in_file(path))?;
    let sequence = build(rois, extent, path).map_err(|e| e.in_file(path))?;
    Ok((sequence, frame_of_reference(&obj)))
}

/// The Frame of Reference UID of the structure set (see [`read_with_frame`]).
fn frame_of_reference(obj: &InMemDicomObject) -> Option<String> {
    let referenced =
        get_items(obj, tags::REFERENCED_FRAME_OF_REFERENCE_SEQUENCE).and_then(|items| {
            items
                .iter()
                .find_map(|i| get_text(i, tags::FRAME_OF_REFERENCE_UID))
        });
    let of_rois = || {
        get_items(obj, tags::STRUCTURE_SET_ROI_SEQUENCE).and_then(|items| {
            items
                .iter()
                .find_map(|i| get_text(i, tags::REFERENCED_FRAME_OF_REFERENCE_UID))
        })
    };
    referenced.or_else(of_rois).filter(|uid| !uid.is_empty())
}

/// The data set of the DICOM file at `path`, read within the limits of [`read`] (size, declared
/// lengths, nesting); errors name the file. A bare data set (no preamble, `DICM` or meta group)
/// is read with a warning.
fn read_object_file(path: &Path) -> Result<InMemDicomObject> {
    // Read whole (the size is capped), so that the parse can see how many bytes are left.
    let bytes = input_file::read(path, MAX_FILE_BYTES, "an RT Structure Set")?;
    let (obj, layout) =
        in_dicom_rs(|| bounded::read_object(&bytes)).map_err(|e| e.in_file(path))?;
    if let bounded::Layout::Bare(uid) = layout {
        log::warn!(
            "{}: no DICOM preamble, `DICM` marker or file meta group (an older export); read as \
             a bare data set in {}",
            path.display(),
            if uid == dicom_dictionary_std::uids::EXPLICIT_VR_LITTLE_ENDIAN {
                "explicit VR little endian"
            } else {
                "implicit VR little endian"
            }
        );
    }
    Ok(obj)
}

/// The ROI Number (3006,0022) of item `i` (0-based) of the StructureSetROISequence.
fn roi_number(item: &InMemDicomObject, i: usize) -> Result<i32> {
    item.get(tags::ROI_NUMBER)
        .and_then(|e| e.to_int::<i32>().ok())
        .ok_or_else(|| {
            dicom(format!(
                "StructureSetROISequence item {}: no valid ROI Number (3006,0022)",
                i + 1
            ))
        })
}

/// Runs `f`, which calls dicom-rs's parsers: parts of dicom-rs assert structural invariants of
/// the file with panics (dicom-parser 0.10's lazy reader did on an item header outside any
/// sequence); any such panic becomes an error here, so that no input makes the reader panic.
fn in_dicom_rs<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a malformed structure".into());
        Err(dicom(format!(
            "not a readable DICOM file: the DICOM parser stopped on {what}"
        )))
    })
}

/// An error and its sources, `: `-separated (dicom-rs puts the useful part in the sources).
fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text = format!("{text}: {s}");
        source = s.source();
    }
    text
}

fn parse_rois(obj: &InMemDicomObject, path: &Path) -> Result<Vec<Roi>> {
    match get_text(obj, tags::MODALITY) {
        Some(m) if m == "RTSTRUCT" => {}
        Some(m) => {
            return Err(dicom(format!(
                "Modality (0008,0060) is `{m}`, not RTSTRUCT: not an RT Structure Set"
            )))
        }
        None => {
            return Err(dicom(
                "no Modality (0008,0060): not an RT Structure Set".into(),
            ))
        }
    }
    let missing = |name: &str, tag: &str| {
        dicom(format!(
            "no {name} ({tag}): not an RT Structure Set, or one without structures"
        ))
    };
    let defined = get_items(obj, tags::STRUCTURE_SET_ROI_SEQUENCE)
        .ok_or_else(|| missing("StructureSetROISequence", "3006,0020"))?;
    let contoured = get_items(obj, tags::ROI_CONTOUR_SEQUENCE)
        .ok_or_else(|| missing("ROIContourSequence", "3006,0039"))?;

    // ROI Number -> name, from the StructureSetROISequence.
    let mut names: BTreeMap<i32, String> = BTreeMap::new();
    for (i, item) in defined.iter().enumerate() {
        let number = roi_number(item, i)?;
        let mut name = get_text(item, tags::ROI_NAME).unwrap_or_default();
        if name.is_empty() {
            name = format!("ROI {number}");
            log::warn!(
                "{}: ROI number {number} has an empty ROI Name; calling it \"{name}\"",
                path.display()
            );
        }
        if names.insert(number, name).is_some() {
            return Err(dicom(format!(
                "StructureSetROISequence item {}: ROI Number {number} is defined twice",
                i + 1
            )));
        }
    }

    let total: usize = contoured
        .iter()
        .map(|c| get_items(c, tags::CONTOUR_SEQUENCE).map_or(0, <[_]>::len))
        .sum();
    if total > MAX_CONTOURS {
        return Err(dicom(format!(
            "{total} contours, over the limit of {MAX_CONTOURS}"
        )));
    }

    let mut rois: BTreeMap<i32, Roi> = BTreeMap::new();
    let mut seen: HashSet<i32> = HashSet::new();
    for (j, item) in contoured.iter().enumerate() {
        let number = item
            .get(tags::REFERENCED_ROI_NUMBER)
            .and_then(|e| e.to_int::<i32>().ok())
            .ok_or_else(|| {
                dicom(format!(
                    "ROIContourSequence item {}: no valid Referenced ROI Number (3006,0084)",
                    j + 1
                ))
            })?;
        let Some(name) = names.get(&number) else {
            return Err(dicom(format!(
                "ROIContourSequence item {} refers to ROI number {number}, which the \
                 StructureSetROISequence does not define",
                j + 1
            )));
        };
        if !seen.insert(number) {
            return Err(dicom(format!(
                "ROIContourSequence item {}: ROI number {number} already has contours in an \
                 earlier item",
                j + 1
            )));
        }
        let at = |e: DataError| e.for_class(name, number);
        let color = display_color(item, path, name, number);
        let items = get_items(item, tags::CONTOUR_SEQUENCE).unwrap_or(&[]);
        let mut contours = Vec::with_capacity(items.len());
        let mut points_skipped = 0;
        for (k, c) in items.iter().enumerate() {
            match parse_contour(c, k + 1).map_err(at)? {
                Some(contour) => contours.push(contour),
                None => points_skipped += 1,
            }
        }
        let roi = format!("{}: ROI \"{name}\" (number {number})", path.display());
        if contours.is_empty() {
            if points_skipped > 0 {
                log::warn!("{roi} holds only POINT contours (an isocentre or marker); skipped");
            } else {
                log::warn!("{roi} has no contour; skipped");
            }
            continue;
        }
        if points_skipped > 0 {
            log::warn!("{roi}: {points_skipped} POINT contours skipped");
        }
        rois.insert(
            number,
            Roi {
                number,
                name: name.clone(),
                color,
                contours,
            },
        );
    }
    for (number, name) in &names {
        if !seen.contains(number) {
            log::warn!(
                "{}: ROI \"{name}\" (number {number}) has no contour; skipped",
                path.display()
            );
        }
    }
    if rois.is_empty() {
        return Err(dicom(
            "no ROI has a closed planar contour: nothing to reconstruct".into(),
        ));
    }
    Ok(rois.into_values().collect())
}

fn display_color(item: &InMemDicomObject, path: &Path, name: &str, number: i32) -> Option<[u8; 3]> {
    let element = item.get(tags::ROI_DISPLAY_COLOR)?;
    let rgb = element
        .to_multi_int::<i64>()
        .ok()
        .filter(|v| v.len() == 3 && v.iter().all(|c| (0..=255).contains(c)));
    match rgb {
        Some(v) => Some([v[0] as u8, v[1] as u8, v[2] as u8]),
        None => {
            log::warn!(
                "{}: ROI \"{name}\" (number {number}): ROI Display Color `{}` is not three values \
                 in 0-255; ignored",
                path.display(),
                element.to_str().unwrap_or_default()
            );
            None
        }
    }
}

/// Parses one ContourSequence item; `None` for a `POINT` contour (skipped).
fn parse_contour(c: &InMemDicomObject, item: usize) -> Result<Option<Contour>> {
    let at = |what: String| dicom(format!("contour item {item}: {what}"));
    let kind = get_text(c, tags::CONTOUR_GEOMETRIC_TYPE).unwrap_or_default();
    match kind.as_str() {
        "CLOSED_PLANAR" | "CLOSEDPLANAR_XOR" => {}
        "POINT" => return Ok(None),
        "OPEN_PLANAR" | "OPEN_NONPLANAR" => {
            return Err(at(format!(
                "Contour Geometric Type is {kind}: an open curve bounds no region, and only \
                 CLOSED_PLANAR contours can be read"
            )))
        }
        "" => return Err(at("no Contour Geometric Type (3006,0042)".into())),
        other => {
            return Err(at(format!(
                "unknown Contour Geometric Type `{other}` (expected CLOSED_PLANAR)"
            )))
        }
    }
    let data = c
        .get(tags::CONTOUR_DATA)
        .ok_or_else(|| at("no ContourData (3006,0050)".into()))?
        .to_multi_float64()
        .map_err(|e| at(format!("ContourData is not a list of numbers: {e}")))?;
    if data.len() % 3 != 0 {
        return Err(at(format!(
            "ContourData has {} values, not a multiple of 3 (x, y, z per point)",
            data.len()
        )));
    }
    let n = data.len() / 3;
    if let Some(declared) = c
        .get(tags::NUMBER_OF_CONTOUR_POINTS)
        .and_then(|e| e.to_int::<i64>().ok())
    {
        if declared != n as i64 {
            return Err(at(format!(
                "Number of Contour Points (3006,0046) is {declared}, but ContourData holds {n} \
                 points"
            )));
        }
    }
    if let Some((i, v)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(at(format!(
            "ContourData value {} (point {}, {}) is not finite ({v})",
            i + 1,
            i / 3 + 1,
            ["x", "y", "z"][i % 3]
        )));
    }
    if n < 3 {
        return Err(at(format!("{n} points; a closed contour needs at least 3")));
    }
    // LPS -> RAS.
    let points: Vec<[f64; 3]> = data.chunks_exact(3).map(|p| [-p[0], -p[1], p[2]]).collect();
    let newell = newell(&points);
    let twice_area = dot(newell, newell).sqrt();
    let (lo, hi) = bounds(points.iter().copied());
    let diag2: f64 = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum();
    // Relative test: rounding leaves a residual area on collinear points.
    if twice_area <= 1e-9 * diag2 {
        return Err(at("zero area: its points are collinear or repeated".into()));
    }
    let normal = newell.map(|x| x / twice_area);
    let centroid: [f64; 3] =
        std::array::from_fn(|k| points.iter().map(|p| p[k]).sum::<f64>() / n as f64);
    let (worst, distance) = points
        .iter()
        .map(|p| dot(normal, std::array::from_fn(|k| p[k] - centroid[k])).abs())
        .enumerate()
        .fold(
            (0, 0.0),
            |best, (i, d)| if d > best.1 { (i, d) } else { best },
        );
    if distance > PLANE_TOLERANCE_MM {
        return Err(at(format!(
            "the points are not coplanar: point {} lies {distance:.4} mm off the contour's \
             plane (tolerance {PLANE_TOLERANCE_MM} mm)",
            worst + 1
        )));
    }
    Ok(Some(Contour {
        item,
        points,
        newell,
        centroid,
    }))
}

/// Newell's vector of a closed polygon in 3D: its normal times twice its area.
fn newell(points: &[[f64; 3]]) -> [f64; 3] {
    // Relative to the first point, so large patient offsets do not cancel digits.
    let o = points[0];
    let mut n = [0.0; 3];
    for i in 0..points.len() {
        let p: [f64; 3] = std::array::from_fn(|k| points[i][k] - o[k]);
        let q: [f64; 3] = std::array::from_fn(|k| points[(i + 1) % points.len()][k] - o[k]);
        let c = cross(p, q);
        n = std::array::from_fn(|k| n[k] + c[k]);
    }
    n
}

fn bounds(points: impl Iterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    points.fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        },
    )
}

/// One plane being built: its frame, position and the (ROI, contour) pairs on it.
struct PlaneDraft {
    orientation: usize,
    /// Index of the plane among its orientation's planes (by offset).
    rank: usize,
    normal: [f64; 3],
    offset: f64,
    members: Vec<(usize, usize)>,
}

impl PlaneDraft {
    /// The plane's position for messages.
    fn position(&self) -> String {
        if self.normal[2] > 1.0 - 1e-9 {
            format!("z = {} mm", self.offset)
        } else {
            let n = self.normal;
            format!(
                "offset {} mm along the normal ({:.4}, {:.4}, {:.4})",
                self.offset, n[0], n[1], n[2]
            )
        }
    }
}

/// Groups the contours of all ROIs into planes (see the module docs).
fn group_planes(rois: &[Roi]) -> Result<Vec<PlaneDraft>> {
    // Orientation matching: each contour against the representative (first) normal of each
    // orientation found so far; the orientation's normal is then the area-weighted mean.
    let mut reps: Vec<[f64; 3]> = Vec::new();
    let mut sums: Vec<[f64; 3]> = Vec::new();
    let mut assigned: Vec<Vec<(usize, usize)>> = Vec::new();
    for (r, roi) in rois.iter().enumerate() {
        for (c, contour) in roi.contours.iter().enumerate() {
            let m = normalize(contour.newell);
            let found = reps.iter().position(|&g| {
                let x = cross(m, g);
                dot(x, x).sqrt() <= NORMAL_TOLERANCE_RAD
            });
            let o = match found {
                Some(o) => o,
                None => {
                    if reps.len() == MAX_ORIENTATIONS {
                        return Err(dicom(format!(
                            "the contours lie in more than {MAX_ORIENTATIONS} plane orientations"
                        )));
                    }
                    reps.push(m);
                    sums.push([0.0; 3]);
                    assigned.push(Vec::new());
                    reps.len() - 1
                }
            };
            let sign = if dot(m, reps[o]) < 0.0 { -1.0 } else { 1.0 };
            sums[o] = std::array::from_fn(|k| sums[o][k] + sign * contour.newell[k]);
            assigned[o].push((r, c));
        }
    }
    let mut planes = Vec::new();
    for (o, members) in assigned.into_iter().enumerate() {
        let mut n = normalize(sums[o]);
        // Canonical sign: the largest component positive (axial planes get n = +z).
        let largest = (0..3)
            .max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
            .unwrap_or(2);
        if n[largest] < 0.0 {
            n = n.map(|x| -x);
        }
        let mut by_offset: Vec<(f64, (usize, usize))> = members
            .into_iter()
            .map(|(r, c)| (dot(n, rois[r].contours[c].centroid), (r, c)))
            .collect();
        by_offset.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut first = f64::NEG_INFINITY;
        let start = planes.len();
        for (d, member) in by_offset {
            if d - first > PLANE_TOLERANCE_MM {
                first = d;
                planes.push(PlaneDraft {
                    orientation: o,
                    rank: planes.len() - start,
                    normal: n,
                    offset: 0.0,
                    members: Vec::new(),
                });
            }
            let plane = planes.last_mut().expect("a plane was pushed above");
            plane.offset += d;
            plane.members.push(member);
        }
        for plane in &mut planes[start..] {
            plane.offset /= plane.members.len() as f64;
        }
    }
    Ok(planes)
}

fn build(rois: Vec<Roi>, extent: RoiExtent, path: &Path) -> Result<Sequence> {
    let drafts = group_planes(&rois)?;
    let orientations = drafts.iter().map(|p| p.orientation + 1).max().unwrap_or(0);
    // Per ROI and orientation: the first and last plane rank where the ROI has a contour.
    let mut span: Vec<Vec<Option<(usize, usize)>>> = vec![vec![None; orientations]; rois.len()];
    for plane in &drafts {
        for &(r, _) in &plane.members {
            let s = &mut span[r][plane.orientation];
            *s = Some(match *s {
                None => (plane.rank, plane.rank),
                Some((a, b)) => (a.min(plane.rank), b.max(plane.rank)),
            });
        }
    }
    let annotated = |r: usize, plane: &PlaneDraft| match (extent, span[r][plane.orientation]) {
        (_, None) => false,
        (RoiExtent::File, Some(_)) => true,
        (RoiExtent::Own, Some((a, b))) => (a..=b).contains(&plane.rank),
    };
    let count: usize = drafts
        .iter()
        .map(|p| (0..rois.len()).filter(|&r| annotated(r, p)).count())
        .sum();
    if count > MAX_ANNOTATIONS {
        return Err(dicom(format!(
            "{} planes and {} ROIs make {count} plane annotations, over the limit of \
             {MAX_ANNOTATIONS}",
            drafts.len(),
            rois.len()
        )));
    }

    let (lo, hi) = bounds(
        rois.iter()
            .flat_map(|r| &r.contours)
            .flat_map(|c| c.points.iter().copied()),
    );
    let diag = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let margin = (ROI_MARGIN_FRACTION * diag).max(MIN_ROI_MARGIN_MM);
    let (glo, ghi) = (lo.map(|x| x - margin), hi.map(|x| x + margin));

    let mut planes = Vec::with_capacity(drafts.len());
    // Per plane, per annotation: the contour items of its polygons, for error messages.
    let mut items: Vec<Vec<(usize, Vec<usize>)>> = Vec::with_capacity(drafts.len());
    let mut repeated = vec![0usize; rois.len()];
    for draft in &drafts {
        let n = draft.normal;
        let (u, v) = plane_axes(n);
        let mut plane = Plane {
            origin: n.map(|x| x * draft.offset),
            u,
            v,
            roi: Rect {
                min: [0.0; 2],
                max: [0.0; 2],
            },
            annotations: Vec::new(),
        };
        plane.roi = plane.box_roi(glo, ghi);
        let mut plane_items = Vec::new();
        for (r, roi) in rois.iter().enumerate() {
            if !annotated(r, draft) {
                continue;
            }
            let mut polygons = Vec::new();
            let mut its = Vec::new();
            for &(_, c) in draft.members.iter().filter(|m| m.0 == r) {
                let contour = &roi.contours[c];
                let (poly, dropped) = project(&plane, &contour.points);
                repeated[r] += dropped;
                polygons.push(poly);
                its.push(contour.item);
            }
            plane.annotations.push(Annotation { class: r, polygons });
            plane_items.push((r, its));
        }
        planes.push(plane);
        items.push(plane_items);
    }
    for (roi, &dropped) in rois.iter().zip(&repeated) {
        if dropped > 0 {
            log::warn!(
                "{}: ROI \"{}\" (number {}): {dropped} repeated consecutive contour points \
                 dropped",
                path.display(),
                roi.name,
                roi.number
            );
        }
    }

    let classes: Vec<ClassInfo> = rois
        .iter()
        .map(|r| ClassInfo {
            name: r.name.clone(),
            label: r.number,
            color: r.color,
        })
        .collect();
    Sequence::new(classes.clone(), vec![Frame { time: 0.0, planes }])
        .map_err(|e| explain(e, &drafts, &items, &classes))
}

/// Plane coordinates of a contour, without repeated consecutive points (nor a closing point
/// equal to the first); returns how many were dropped.
fn project(plane: &Plane, points: &[[f64; 3]]) -> (Polygon, usize) {
    let mut poly: Vec<Point2> = Vec::with_capacity(points.len());
    for p in points {
        let q = plane.to_plane(*p);
        if poly.last() != Some(&q) {
            poly.push(q);
        }
    }
    while poly.len() > 1 && poly.first() == poly.last() {
        poly.pop();
    }
    let dropped = points.len() - poly.len();
    // The closing point that repeats the first is a common convention, not a repair to report.
    let closing = usize::from(points.len() > 1 && points.first() == points.last());
    (poly, dropped.saturating_sub(closing))
}

/// Adds the plane's position and the ROI's contour items to a geometry error of
/// [`Sequence::new`], whose plane and polygon indices mean nothing to a planner.
fn explain(
    mut e: DataError,
    drafts: &[PlaneDraft],
    items: &[Vec<(usize, Vec<usize>)>],
    classes: &[ClassInfo],
) -> DataError {
    let (Some(p), Some((_, label))) = (e.location.plane, e.location.class.clone()) else {
        return e;
    };
    let (Some(draft), Some(k)) = (drafts.get(p), classes.iter().position(|c| c.label == label))
    else {
        return e;
    };
    let Some(its) = items
        .get(p)
        .and_then(|plane| plane.iter().find(|(class, _)| *class == k))
        .map(|(_, its)| its)
    else {
        return e;
    };
    let note = format!(
        " (on the plane at {}; the ROI's polygons there are its contour items {its:?}, in order)",
        draft.position()
    );
    e.kind = match e.kind {
        ErrorKind::SelfIntersection(s) => ErrorKind::SelfIntersection(s + &note),
        ErrorKind::Degenerate(s) => ErrorKind::Degenerate(s + &note),
        other => other,
    };
    e
}
