//! Writer of DICOM RT Structure Sets: planar contours of structures, in the patient, study and
//! frame of reference of an existing RT Structure Set (the template), so that a treatment
//! planning system files them beside it.
//!
//! # What a written file holds
//! - Patient, General Study and Frame of Reference modules copied from the template: Patient's
//!   Name, ID, Birth Date and Sex, Study Instance UID, Date, Time, ID, Referring Physician's
//!   Name, Accession Number, Study Description, Frame of Reference UID, Position Reference
//!   Indicator, and its Specific Character Set. Type 2 attributes the template lacks are
//!   written empty (many exports omit them; the IOD requires them present).
//! - A new RT Series (Series Instance UID, number, description) and a new SOP Instance UID, both
//!   `2.25.<UUID>` ([`new_uid`]); General Equipment names DynaSlice.
//! - Structure Set: label, name, date and time of writing, the template's Frame of Reference UID
//!   with its referenced study and series ([`ImageSeries`]: the template's own references, or
//!   those of a CT series read with [`super::image_series::read`]), and per ROI its number,
//!   name, generation algorithm `AUTOMATIC` and display colour.
//! - ROI Contour: one `CLOSED_PLANAR` contour per closed polygon, its points in patient LPS
//!   millimetres (ContourData as DS of at most 16 characters: 4 decimals, 0.1 µm), each contour
//!   referencing the image of its plane where one is known (Contour Image Sequence).
//! - RT ROI Observations: one per ROI, with the template's RT ROI Interpreted Type where it had
//!   one (else empty) and an empty ROI Interpreter.
//!
//! # Holes
//! RTSTRUCT has no explicit holes. A hole is written as a separate `CLOSED_PLANAR` contour of the
//! same ROI on the same plane, inside its outer boundary; nested contours are read by the
//! even-odd rule (a contour inside an odd number of others is a hole), as Eclipse, RayStation,
//! 3D Slicer (SlicerRT), dicompyler and rt-utils read them, and as [`super::read`] does.
//! Outer boundaries run counter-clockwise and holes clockwise (seen from +z of LPS for axial
//! planes); readers do not rely on it.

use std::path::Path;
use std::time::{SystemTime, UNIX_EPOCH};

use dicom_core::value::{DataSetSequence, PrimitiveValue};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::meta::FileMetaTableBuilder;
use dicom_object::InMemDicomObject;

use super::{dicom, get_items, get_text};
use dynaslice_output::OutputSet;
use dynaslice_sequence::error::Result;

/// SOP Class UID of RT Structure Set Storage.
pub const RT_STRUCTURE_SET_STORAGE: &str = uids::RT_STRUCTURE_SET_STORAGE;

/// Decimals of the ContourData values: 0.1 µm, and at most 16 characters (the DS limit) for any
/// coordinate below 10⁹ mm.
const DECIMALS: usize = 4;

/// The patient's position of a world point: DICOM patient coordinates (LPS: x to the patient's
/// left, y to posterior, z to head, mm) of a point of our world frame (RAS mm, what the readers
/// give: [`super::read`] negates x and y of the LPS it reads). The one place the writer maps
/// world to patient coordinates.
pub fn world_to_patient(p: [f64; 3]) -> [f64; 3] {
    [-p[0], -p[1], p[2]]
}

/// The world point (RAS mm) of a patient position (LPS mm): the inverse of
/// [`world_to_patient`].
pub fn patient_to_world(p: [f64; 3]) -> [f64; 3] {
    [-p[0], -p[1], p[2]]
}

/// A new UID in the `2.25.<UUID>` form (ISO/IEC 9834-8): a random (version 4) UUID as one
/// decimal integer, needing no organisational root.
pub fn new_uid() -> Result<String> {
    let mut b = [0u8; 16];
    getrandom::fill(&mut b)
        .map_err(|e| dicom(format!("cannot draw random bits for a new UID: {e}")))?;
    b[6] = (b[6] & 0x0f) | 0x40; // version 4
    b[8] = (b[8] & 0x3f) | 0x80; // RFC 4122 variant
    Ok(format!("2.25.{}", u128::from_be_bytes(b)))
}

/// An image a contour can reference: its SOP Class and Instance UIDs and where its plane is.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageRef {
    /// Referenced SOP Class UID (e.g. CT Image Storage).
    pub class_uid: String,
    /// Referenced SOP Instance UID.
    pub instance_uid: String,
    /// A point of the image's plane, patient LPS mm (Image Position (Patient), or a point of a
    /// contour that referenced the image).
    pub point: [f64; 3],
}

/// The images a structure set is drawn on: the RT Referenced Study / Series of its Referenced
/// Frame of Reference Sequence.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ImageSeries {
    /// Referenced SOP Class and Instance UIDs of the study (RT Referenced Study Sequence), where
    /// known.
    pub study: Option<(String, String)>,
    /// Series Instance UID of the images, where known.
    pub series_uid: Option<String>,
    /// The series' images.
    pub images: Vec<ImageRef>,
}

impl ImageSeries {
    /// The image whose plane holds `point` (patient LPS) within `tolerance` mm along `normal`
    /// (unit, LPS), if any.
    pub fn image_at(&self, point: [f64; 3], normal: [f64; 3], tolerance: f64) -> Option<&ImageRef> {
        self.images.iter().find(|im| {
            let d: f64 = (0..3).map(|k| (im.point[k] - point[k]) * normal[k]).sum();
            d.abs() <= tolerance
        })
    }
}

/// A structure of the template: what a written ROI carries over.
#[derive(Debug, Clone, PartialEq)]
pub struct TemplateRoi {
    /// ROI Number.
    pub number: i32,
    /// ROI Name.
    pub name: String,
    /// ROI Display Color, where the template gives a valid one.
    pub color: Option<[u8; 3]>,
    /// RT ROI Interpreted Type (ORGAN, GTV, …), where given.
    pub interpreted_type: Option<String>,
}

/// An RT Structure Set read as a template: the patient, study, frame of reference, images and
/// structures that written files carry over.
#[derive(Debug, Clone)]
pub struct Template {
    /// The Patient and General Study attributes found (tag, value).
    identity: Vec<(Tag, String)>,
    /// Specific Character Set, where given.
    charset: Option<String>,
    /// Frame of Reference UID.
    pub frame_of_reference_uid: String,
    /// Study Instance UID.
    pub study_uid: String,
    /// The images the template's structures were drawn on.
    pub series: ImageSeries,
    /// The template's structures, in StructureSetROISequence order.
    pub rois: Vec<TemplateRoi>,
}

/// Patient, General Study and Frame of Reference attributes copied from the template (Type 2
/// ones written empty where absent; Study Description, Type 3, only where present).
const IDENTITY: [(Tag, VR, bool); 11] = [
    (tags::PATIENT_NAME, VR::PN, true),
    (tags::PATIENT_ID, VR::LO, true),
    (tags::PATIENT_BIRTH_DATE, VR::DA, true),
    (tags::PATIENT_SEX, VR::CS, true),
    (tags::STUDY_DATE, VR::DA, true),
    (tags::STUDY_TIME, VR::TM, true),
    (tags::REFERRING_PHYSICIAN_NAME, VR::PN, true),
    (tags::STUDY_ID, VR::SH, true),
    (tags::ACCESSION_NUMBER, VR::SH, true),
    (tags::STUDY_DESCRIPTION, VR::LO, false),
    (tags::POSITION_REFERENCE_INDICATOR, VR::LO, true),
];

impl Template {
    /// Reads the RT Structure Set at `path` as a template. Errors name the file: not an RT
    /// Structure Set, no Frame of Reference UID (neither in its Referenced Frame of Reference
    /// Sequence nor in its ROIs), no Study Instance UID, no structure.
    pub fn read(path: &Path) -> Result<Template> {
        let obj = super::read_object_file(path)?;
        Template::from_object(&obj).map_err(|e| e.in_file(path))
    }

    fn from_object(obj: &InMemDicomObject) -> Result<Template> {
        if get_text(obj, tags::MODALITY).as_deref() != Some("RTSTRUCT") {
            return Err(dicom(
                "Modality (0008,0060) is not RTSTRUCT: not an RT Structure Set".into(),
            ));
        }
        let identity = IDENTITY
            .iter()
            .filter_map(|&(tag, _, _)| get_text(obj, tag).map(|v| (tag, v)))
            .filter(|(_, v)| !v.is_empty())
            .collect();
        let charset = get_text(obj, tags::SPECIFIC_CHARACTER_SET).filter(|s| !s.is_empty());
        let study_uid = get_text(obj, tags::STUDY_INSTANCE_UID)
            .filter(|s| !s.is_empty())
            .ok_or_else(|| dicom("no Study Instance UID (0020,000D)".into()))?;
        let defined = get_items(obj, tags::STRUCTURE_SET_ROI_SEQUENCE).unwrap_or_default();
        let frames =
            get_items(obj, tags::REFERENCED_FRAME_OF_REFERENCE_SEQUENCE).unwrap_or_default();
        let frame_of_reference_uid = frames
            .iter()
            .find_map(|f| get_text(f, tags::FRAME_OF_REFERENCE_UID).filter(|s| !s.is_empty()))
            .or_else(|| {
                defined.iter().find_map(|r| {
                    get_text(r, tags::REFERENCED_FRAME_OF_REFERENCE_UID).filter(|s| !s.is_empty())
                })
            })
            .ok_or_else(|| {
                dicom(
                    "no Frame of Reference UID: neither Referenced Frame of Reference Sequence \
                     (3006,0010) nor the ROIs' Referenced Frame of Reference UID (3006,0024) \
                     give one"
                        .into(),
                )
            })?;
        let mut series = ImageSeries::default();
        for frame in frames {
            for study in get_items(frame, tags::RT_REFERENCED_STUDY_SEQUENCE).unwrap_or_default() {
                let class = get_text(study, tags::REFERENCED_SOP_CLASS_UID);
                let instance = get_text(study, tags::REFERENCED_SOP_INSTANCE_UID);
                if let (Some(c), Some(i)) = (class, instance) {
                    if !c.is_empty() && !i.is_empty() && series.study.is_none() {
                        series.study = Some((c, i));
                    }
                }
                for s in get_items(study, tags::RT_REFERENCED_SERIES_SEQUENCE).unwrap_or_default() {
                    if series.series_uid.is_none() {
                        series.series_uid =
                            get_text(s, tags::SERIES_INSTANCE_UID).filter(|s| !s.is_empty());
                    }
                }
            }
        }
        // The images, with their planes known from the contours that reference them.
        let contoured = get_items(obj, tags::ROI_CONTOUR_SEQUENCE).unwrap_or_default();
        for c in contoured
            .iter()
            .flat_map(|r| get_items(r, tags::CONTOUR_SEQUENCE).unwrap_or_default())
        {
            let Some(point) = c
                .get(tags::CONTOUR_DATA)
                .and_then(|e| e.to_multi_float64().ok())
                .filter(|v| v.len() >= 3 && v[..3].iter().all(|x| x.is_finite()))
                .map(|v| [v[0], v[1], v[2]])
            else {
                continue;
            };
            for im in get_items(c, tags::CONTOUR_IMAGE_SEQUENCE).unwrap_or_default() {
                let class = get_text(im, tags::REFERENCED_SOP_CLASS_UID).unwrap_or_default();
                let instance = get_text(im, tags::REFERENCED_SOP_INSTANCE_UID).unwrap_or_default();
                if class.is_empty()
                    || instance.is_empty()
                    || series.images.iter().any(|i| i.instance_uid == instance)
                {
                    continue;
                }
                series.images.push(ImageRef {
                    class_uid: class,
                    instance_uid: instance,
                    point,
                });
            }
        }
        let interpreted: Vec<(i32, String)> = get_items(obj, tags::RTROI_OBSERVATIONS_SEQUENCE)
            .unwrap_or_default()
            .iter()
            .filter_map(|o| {
                let n = o.get(tags::REFERENCED_ROI_NUMBER)?.to_int::<i32>().ok()?;
                let t = get_text(o, tags::RTROI_INTERPRETED_TYPE).filter(|s| !s.is_empty())?;
                Some((n, t))
            })
            .collect();
        let color_of = |number: i32| {
            contoured
                .iter()
                .find(|c| {
                    c.get(tags::REFERENCED_ROI_NUMBER)
                        .and_then(|e| e.to_int::<i32>().ok())
                        == Some(number)
                })
                .and_then(|c| c.get(tags::ROI_DISPLAY_COLOR))
                .and_then(|e| e.to_multi_int::<i32>().ok())
                .filter(|v| v.len() == 3 && v.iter().all(|x| (0..=255).contains(x)))
                .map(|v| [v[0] as u8, v[1] as u8, v[2] as u8])
        };
        let mut rois = Vec::new();
        for (i, item) in defined.iter().enumerate() {
            let number = super::roi_number(item, i)?;
            rois.push(TemplateRoi {
                number,
                name: get_text(item, tags::ROI_NAME).unwrap_or_default(),
                color: color_of(number),
                interpreted_type: interpreted
                    .iter()
                    .find(|(n, _)| *n == number)
                    .map(|(_, t)| t.clone()),
            });
        }
        Ok(Template {
            identity,
            charset,
            frame_of_reference_uid,
            study_uid,
            series,
            rois,
        })
    }
}

/// A closed contour: the unit normal of its plane and its points (at least 3), patient LPS mm.
pub type PlanarContour = ([f64; 3], Vec<[f64; 3]>);

/// One structure to write: its definition and its closed contours, each a polygon of patient
/// LPS points (mm) on one plane, with the unit normal (LPS) of that plane.
#[derive(Debug, Clone)]
pub struct RoiContours {
    /// ROI Number (unique in the file).
    pub number: i32,
    /// ROI Name.
    pub name: String,
    /// ROI Display Color.
    pub color: [u8; 3],
    /// RT ROI Interpreted Type, where known.
    pub interpreted_type: Option<String>,
    /// ROI Description (Type 3), where wanted (e.g. how an ITV was made).
    pub description: Option<String>,
    /// Closed contours: (plane normal, points), LPS mm, at least 3 points each.
    pub contours: Vec<PlanarContour>,
}

/// A structure set to write.
#[derive(Debug, Clone)]
pub struct StructureSet {
    /// Structure Set Label (at most 16 characters; longer is cut).
    pub label: String,
    /// Structure Set Name and Series Description (at most 64 characters; longer is cut).
    pub name: String,
    /// Series Number.
    pub series_number: i32,
    /// The structures, each with its contours.
    pub rois: Vec<RoiContours>,
}

/// Distance (mm) within which a contour's plane holds an image's plane, for its Contour Image
/// Sequence: half of the thinnest slice spacing in use (0.5 mm).
pub const IMAGE_PLANE_TOLERANCE_MM: f64 = 0.25;

/// Adds `set` as an RT Structure Set at `path` to `files`, which puts it in place with the
/// set's other files (one per time and their manifest, all or none): in `template`'s patient,
/// study and frame of reference, referencing the images of `series`. Returns the new SOP
/// Instance UID. Errors name the file.
pub fn stage(
    files: &mut OutputSet,
    path: &Path,
    template: &Template,
    series: &ImageSeries,
    set: &StructureSet,
) -> anyhow::Result<String> {
    let bytes = encode(template, series, set).map_err(|e| e.in_file(path))?;
    files.write(path, &bytes.1)?;
    Ok(bytes.0)
}

fn text(tag: Tag, vr: VR, value: &str) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, vr, PrimitiveValue::from(value))
}

fn seq(tag: Tag, items: Vec<InMemDicomObject>) -> DataElement<InMemDicomObject> {
    DataElement::new(tag, VR::SQ, DataSetSequence::from(items))
}

fn cut(s: &str, n: usize) -> &str {
    match s.char_indices().nth(n) {
        Some((i, _)) => &s[..i],
        None => s,
    }
}

/// A DS value of `x` in at most 16 characters.
fn ds(x: f64) -> Result<String> {
    let s = format!("{x:.DECIMALS$}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    let s = if s == "-0" || s.is_empty() { "0" } else { s };
    if !x.is_finite() || s.len() > 16 {
        return Err(dicom(format!(
            "coordinate {x} mm does not fit a DICOM decimal string"
        )));
    }
    Ok(s.to_string())
}

/// The file's SOP Instance UID and bytes.
fn encode(
    template: &Template,
    series: &ImageSeries,
    set: &StructureSet,
) -> Result<(String, Vec<u8>)> {
    let sop_uid = new_uid()?;
    let (date, time) = now();
    let mut o = InMemDicomObject::new_empty();
    if let Some(cs) = &template.charset {
        o.put(text(tags::SPECIFIC_CHARACTER_SET, VR::CS, cs));
    }
    o.put(text(tags::SOP_CLASS_UID, VR::UI, RT_STRUCTURE_SET_STORAGE));
    o.put(text(tags::SOP_INSTANCE_UID, VR::UI, &sop_uid));
    o.put(text(tags::INSTANCE_CREATION_DATE, VR::DA, &date));
    o.put(text(tags::INSTANCE_CREATION_TIME, VR::TM, &time));
    for (tag, vr, type2) in IDENTITY {
        match template.identity.iter().find(|(t, _)| *t == tag) {
            Some((_, v)) => {
                o.put(text(tag, vr, v));
            }
            None if type2 => {
                o.put(text(tag, vr, ""));
            }
            None => {}
        }
    }
    o.put(text(tags::STUDY_INSTANCE_UID, VR::UI, &template.study_uid));
    // Frame of Reference module (part of the IOD since DICOM 2023).
    o.put(text(
        tags::FRAME_OF_REFERENCE_UID,
        VR::UI,
        &template.frame_of_reference_uid,
    ));
    // RT Series.
    o.put(text(tags::MODALITY, VR::CS, "RTSTRUCT"));
    o.put(text(tags::SERIES_INSTANCE_UID, VR::UI, &new_uid()?));
    o.put(text(
        tags::SERIES_NUMBER,
        VR::IS,
        &set.series_number.to_string(),
    ));
    o.put(text(tags::SERIES_DATE, VR::DA, &date));
    o.put(text(tags::SERIES_TIME, VR::TM, &time));
    o.put(text(tags::SERIES_DESCRIPTION, VR::LO, cut(&set.name, 64)));
    o.put(text(tags::OPERATORS_NAME, VR::PN, ""));
    // General Equipment.
    o.put(text(tags::MANUFACTURER, VR::LO, "DynaSlice"));
    o.put(text(
        tags::SOFTWARE_VERSIONS,
        VR::LO,
        concat!("dynaslice ", env!("CARGO_PKG_VERSION")),
    ));
    // Structure Set.
    o.put(text(tags::STRUCTURE_SET_LABEL, VR::SH, cut(&set.label, 16)));
    o.put(text(tags::STRUCTURE_SET_NAME, VR::LO, cut(&set.name, 64)));
    o.put(text(tags::STRUCTURE_SET_DATE, VR::DA, &date));
    o.put(text(tags::STRUCTURE_SET_TIME, VR::TM, &time));
    let mut frame = InMemDicomObject::new_empty();
    frame.put(text(
        tags::FRAME_OF_REFERENCE_UID,
        VR::UI,
        &template.frame_of_reference_uid,
    ));
    // The referenced study and series, where they are complete (their attributes are Type 1).
    if let (Some((class, instance)), Some(series_uid), false) =
        (&series.study, &series.series_uid, series.images.is_empty())
    {
        let images = series.images.iter().map(image_item).collect::<Vec<_>>();
        let s = InMemDicomObject::from_element_iter([
            text(tags::SERIES_INSTANCE_UID, VR::UI, series_uid),
            seq(tags::CONTOUR_IMAGE_SEQUENCE, images),
        ]);
        let study = InMemDicomObject::from_element_iter([
            text(tags::REFERENCED_SOP_CLASS_UID, VR::UI, class),
            text(tags::REFERENCED_SOP_INSTANCE_UID, VR::UI, instance),
            seq(tags::RT_REFERENCED_SERIES_SEQUENCE, vec![s]),
        ]);
        frame.put(seq(tags::RT_REFERENCED_STUDY_SEQUENCE, vec![study]));
    }
    o.put(seq(
        tags::REFERENCED_FRAME_OF_REFERENCE_SEQUENCE,
        vec![frame],
    ));
    let mut defined = Vec::new();
    let mut contoured = Vec::new();
    let mut observed = Vec::new();
    for (i, roi) in set.rois.iter().enumerate() {
        if set.rois[..i].iter().any(|r| r.number == roi.number) {
            return Err(dicom(format!("ROI Number {} is given twice", roi.number)));
        }
        let mut d = InMemDicomObject::from_element_iter([
            text(tags::ROI_NUMBER, VR::IS, &roi.number.to_string()),
            text(
                tags::REFERENCED_FRAME_OF_REFERENCE_UID,
                VR::UI,
                &template.frame_of_reference_uid,
            ),
            text(tags::ROI_NAME, VR::LO, cut(&roi.name, 64)),
            text(tags::ROI_GENERATION_ALGORITHM, VR::CS, "AUTOMATIC"),
        ]);
        if let Some(description) = &roi.description {
            d.put(text(tags::ROI_DESCRIPTION, VR::ST, description));
        }
        defined.push(d);
        let mut items = Vec::with_capacity(roi.contours.len());
        for (k, (normal, points)) in roi.contours.iter().enumerate() {
            if points.len() < 3 {
                return Err(dicom(format!(
                    "ROI \"{}\": contour {} has {} points; a closed contour needs 3",
                    roi.name,
                    k + 1,
                    points.len()
                )));
            }
            let data = points
                .iter()
                .flatten()
                .map(|&x| ds(x))
                .collect::<Result<Vec<String>>>()?;
            let mut c = InMemDicomObject::new_empty();
            if let Some(im) = series.image_at(points[0], *normal, IMAGE_PLANE_TOLERANCE_MM) {
                c.put(seq(tags::CONTOUR_IMAGE_SEQUENCE, vec![image_item(im)]));
            }
            c.put(text(tags::CONTOUR_GEOMETRIC_TYPE, VR::CS, "CLOSED_PLANAR"));
            c.put(text(
                tags::NUMBER_OF_CONTOUR_POINTS,
                VR::IS,
                &points.len().to_string(),
            ));
            c.put(text(tags::CONTOUR_NUMBER, VR::IS, &(k + 1).to_string()));
            c.put(DataElement::new(
                tags::CONTOUR_DATA,
                VR::DS,
                PrimitiveValue::Strs(data.into()),
            ));
            items.push(c);
        }
        let [r, g, b] = roi.color;
        let mut c = InMemDicomObject::from_element_iter([
            DataElement::new(
                tags::ROI_DISPLAY_COLOR,
                VR::IS,
                PrimitiveValue::Strs([r, g, b].map(|v| v.to_string()).to_vec().into()),
            ),
            text(tags::REFERENCED_ROI_NUMBER, VR::IS, &roi.number.to_string()),
        ]);
        // An ROI with no contour at this time has no Contour Sequence: the attribute is Type 3,
        // but present it needs at least one item (dciodvfy: "1-n Required by Module
        // definition"). The ROI Contour item itself stays, so readers still see the structure.
        if items.is_empty() {
            log::warn!(
                "{} (ROI {}): no contour at this time; written without contours",
                roi.name,
                roi.number
            );
        } else {
            c.put(seq(tags::CONTOUR_SEQUENCE, items));
        }
        contoured.push(c);
        observed.push(InMemDicomObject::from_element_iter([
            text(tags::OBSERVATION_NUMBER, VR::IS, &(i + 1).to_string()),
            text(tags::REFERENCED_ROI_NUMBER, VR::IS, &roi.number.to_string()),
            text(
                tags::RTROI_INTERPRETED_TYPE,
                VR::CS,
                roi.interpreted_type.as_deref().unwrap_or(""),
            ),
            text(tags::ROI_INTERPRETER, VR::PN, ""),
        ]));
    }
    o.put(seq(tags::STRUCTURE_SET_ROI_SEQUENCE, defined));
    o.put(seq(tags::ROI_CONTOUR_SEQUENCE, contoured));
    o.put(seq(tags::RTROI_OBSERVATIONS_SEQUENCE, observed));
    let file = o
        .with_meta(FileMetaTableBuilder::new().transfer_syntax(uids::EXPLICIT_VR_LITTLE_ENDIAN))
        .map_err(|e| dicom(format!("cannot build the file meta group: {e}")))?;
    let mut bytes = Vec::new();
    file.write_all(&mut bytes).map_err(|e| {
        dicom(format!(
            "cannot encode the RT Structure Set: {}",
            super::chain(&e)
        ))
    })?;
    Ok((sop_uid, bytes))
}

fn image_item(im: &ImageRef) -> InMemDicomObject {
    InMemDicomObject::from_element_iter([
        text(tags::REFERENCED_SOP_CLASS_UID, VR::UI, &im.class_uid),
        text(tags::REFERENCED_SOP_INSTANCE_UID, VR::UI, &im.instance_uid),
    ])
}

/// Today's date (YYYYMMDD) and the time (HHMMSS), UTC.
fn now() -> (String, String) {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rest) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (
        format!("{year:04}{month:02}{day:02}"),
        format!("{:02}{:02}{:02}", rest / 3600, rest / 60 % 60, rest % 60),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_strings_fit_sixteen_characters() {
        assert_eq!(ds(-0.00001).unwrap(), "0");
        assert_eq!(ds(12.5).unwrap(), "12.5");
        assert_eq!(ds(-123456.78905).unwrap(), "-123456.7891");
        assert_eq!(ds(1e13).unwrap(), "10000000000000");
        assert!(ds(1e17).is_err());
        assert!(ds(f64::NAN).is_err());
    }

    #[test]
    fn uids_are_2_25_uuids_and_differ() {
        let (a, b) = (new_uid().unwrap(), new_uid().unwrap());
        assert!(a.starts_with("2.25.") && a.len() <= 64 && a != b);
        assert!(a[5..].chars().all(|c| c.is_ascii_digit()) && !a[5..].starts_with('0'));
    }

    #[test]
    fn dates_are_civil() {
        let (d, t) = now();
        assert_eq!((d.len(), t.len()), (8, 6));
        assert!(d.as_str() >= "20250101");
    }
}
