//! RT Structure Sets written by pydicom: classes, planes, areas, LPS → RAS, both absence modes,
//! the skips, every malformed-input error, robustness to corrupted files, and a structure set
//! contoured from the shared TotalSegmentator label map (nibabel + scikit-image) against its
//! voxels.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use dynaslice_data::rtstruct::{read, RoiExtent, MAX_FILE_BYTES};
use dynaslice_data::{ErrorKind, Plane, Sequence};
use dynaslice_geometry::polygon::signed_area;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;
use serde_json::{json, Value};

/// `write_rtstruct(path, spec)`: a minimal RT Structure Set (Explicit VR Little Endian, Implicit
/// with `implicit: true`, Deflated Explicit with `deflated: true`; Frame of Reference UID
/// `frame`, else a new one) from a spec `{modality?, implicit?, deflated?, frame?, omit?: [sequence names], rois:
/// [{number, name, color?, contours?: [{type, data: [DS strings], npoints?}]}]}`; ROIs without
/// `contours` get no ROIContourSequence item.
/// Value validation is off so the bad-input tests can write NaN and odd counts.
const WRITER: &str = r#"
import json, sys
import pydicom
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import (DeflatedExplicitVRLittleEndian, ExplicitVRLittleEndian,
                         ImplicitVRLittleEndian, generate_uid)

pydicom.config.settings.writing_validation_mode = pydicom.config.IGNORE
pydicom.config.settings.reading_validation_mode = pydicom.config.IGNORE

def write_rtstruct(path, spec):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.481.3"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = (ImplicitVRLittleEndian if spec.get("implicit")
                              else DeflatedExplicitVRLittleEndian if spec.get("deflated")
                              else ExplicitVRLittleEndian)
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = spec.get("modality", "RTSTRUCT")
    ds.PatientName = "Phantom"
    ds.StructureSetLabel = "test"
    frame = spec.get("frame") or generate_uid()
    defined, contoured = [], []
    for roi in spec["rois"]:
        s = Dataset()
        s.ROINumber = roi["number"]
        s.ROIName = roi["name"]
        s.ReferencedFrameOfReferenceUID = frame
        s.ROIGenerationAlgorithm = "MANUAL"
        defined.append(s)
        if "contours" not in roi:
            continue
        c = Dataset()
        c.ReferencedROINumber = roi["number"]
        if roi.get("color"):
            c.ROIDisplayColor = roi["color"]
        items = []
        for k in roi["contours"]:
            it = Dataset()
            it.ContourGeometricType = k["type"]
            it.NumberOfContourPoints = k.get("npoints", len(k["data"]) // 3)
            it.ContourData = k["data"]
            items.append(it)
        c.ContourSequence = Sequence(items)
        contoured.append(c)
    omit = spec.get("omit", [])
    if "StructureSetROISequence" not in omit:
        ds.StructureSetROISequence = Sequence(defined)
    if "ROIContourSequence" not in omit:
        ds.ROIContourSequence = Sequence(contoured)
    ds.save_as(path, enforce_file_format=True)
"#;

/// Writes `spec` (see [`WRITER`]) as `dir/name.dcm` with pydicom; `None` when pydicom is missing.
fn write(dir: &Path, name: &str, spec: &Value) -> Option<PathBuf> {
    let spec_path = dir.join(format!("{name}.json"));
    std::fs::write(&spec_path, spec.to_string()).unwrap();
    let out = dir.join(format!("{name}.dcm"));
    let script = format!("{WRITER}\nwrite_rtstruct(sys.argv[2], json.load(open(sys.argv[1])))\n");
    run_python(&["pydicom"], &script, &[&spec_path, &out])?;
    Some(out)
}

/// ContourData values as DS strings (6 decimals: well inside the readers' tolerances).
fn ds(points: &[[f64; 3]]) -> Vec<String> {
    points
        .iter()
        .flatten()
        .map(|v| {
            if v.is_finite() {
                format!("{v:.6}")
            } else {
                format!("{v}")
            }
        })
        .collect()
}

fn closed(points: &[[f64; 3]]) -> Value {
    json!({"type": "CLOSED_PLANAR", "data": ds(points)})
}

/// A regular `n`-gon of radius `r` about (cx, cy) at height z (patient LPS), counter-clockwise.
fn circle(cx: f64, cy: f64, z: f64, r: f64, n: usize) -> Vec<[f64; 3]> {
    (0..n)
        .map(|j| {
            let a = std::f64::consts::TAU * j as f64 / n as f64;
            [cx + r * a.cos(), cy + r * a.sin(), z]
        })
        .collect()
}

/// Area of the regular `n`-gon of circumradius `r`.
fn ngon_area(r: f64, n: usize) -> f64 {
    0.5 * n as f64 * r * r * (std::f64::consts::TAU / n as f64).sin()
}

const SIDES: usize = 64;
/// GTV: a ball of radius 20 mm about LPS (30, −40, 50), contoured on z = 35, 40, …, 65.
const GTV_CENTRE: [f64; 3] = [30.0, -40.0, 50.0];
const GTV_RADIUS: f64 = 20.0;
/// Lung: a ring (outer radius 30, hole radius 15) about LPS (−60, 10) on z = 20, 25, …, 80 and
/// on the extra plane z = 52.5, inside the GTV's extent, where the GTV has no contour.
const LUNG_CENTRE: [f64; 2] = [-60.0, 10.0];
const EXTRA_Z: f64 = 52.5;

fn gtv_zs() -> Vec<f64> {
    (-3..=3).map(|k| GTV_CENTRE[2] + 5.0 * k as f64).collect()
}

fn lung_zs() -> Vec<f64> {
    let mut zs: Vec<f64> = (0..13).map(|k| 20.0 + 5.0 * k as f64).collect();
    zs.push(EXTRA_Z);
    zs
}

fn gtv_radius(z: f64) -> f64 {
    (GTV_RADIUS * GTV_RADIUS - (z - GTV_CENTRE[2]).powi(2)).sqrt()
}

/// The phantom: GTV (number 3), the isocentre as a POINT ROI (number 2), Lung (number 1, written
/// last, both of its contours counter-clockwise: orientation must come from nesting), and a
/// defined ROI without contours (number 4).
fn phantom_spec() -> Value {
    let gtv: Vec<Value> = gtv_zs()
        .into_iter()
        .map(|z| {
            closed(&circle(
                GTV_CENTRE[0],
                GTV_CENTRE[1],
                z,
                gtv_radius(z),
                SIDES,
            ))
        })
        .collect();
    let lung: Vec<Value> = lung_zs()
        .into_iter()
        .flat_map(|z| {
            [
                closed(&circle(LUNG_CENTRE[0], LUNG_CENTRE[1], z, 30.0, SIDES)),
                closed(&circle(LUNG_CENTRE[0], LUNG_CENTRE[1], z, 15.0, SIDES)),
            ]
        })
        .collect();
    json!({"rois": [
        {"number": 3, "name": "GTV", "color": [255, 0, 0], "contours": gtv},
        {"number": 2, "name": "Isocenter", "color": [255, 255, 0],
         "contours": [{"type": "POINT", "data": ds(&[GTV_CENTRE])}]},
        {"number": 1, "name": "Lung", "color": [0, 128, 255], "contours": lung},
        {"number": 4, "name": "Empty"},
    ]})
}

static LOGGER: Capture = Capture;
static LOG: Mutex<Vec<String>> = Mutex::new(Vec::new());
static INIT: Once = Once::new();

/// Records every log message, so tests can check the reader's warnings.
struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        LOG.lock().unwrap().push(record.args().to_string());
    }
    fn flush(&self) {}
}

fn capture_warnings() {
    INIT.call_once(|| {
        log::set_logger(&LOGGER).unwrap();
        log::set_max_level(log::LevelFilter::Warn);
    });
}

/// The warnings that name `path` (tests run in parallel, all logging here).
fn warnings_about(path: &Path) -> Vec<String> {
    let name = path.display().to_string();
    LOG.lock()
        .unwrap()
        .iter()
        .filter(|m| m.contains(&name))
        .cloned()
        .collect()
}

fn z_of(plane: &Plane) -> f64 {
    plane.origin[2]
}

/// Region area of one annotation: outer boundaries count positive, holes negative.
fn region_area(plane: &Plane, class: usize) -> Option<f64> {
    plane
        .annotation(class)
        .map(|a| a.polygons.iter().map(|p| signed_area(p)).sum())
}

fn plane_at(seq: &Sequence, z: f64) -> &Plane {
    seq.frames()[0]
        .planes
        .iter()
        .find(|p| (z_of(p) - z).abs() < 1e-6)
        .unwrap_or_else(|| panic!("no plane at z = {z}"))
}

#[test]
fn reads_classes_planes_areas_and_lps_to_ras() {
    capture_warnings();
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = write(dir.path(), "phantom", &phantom_spec()) else {
        return;
    };
    let seq = read(&path, RoiExtent::default()).unwrap();

    // Classes by ROI Number; the POINT ROI and the ROI without contours are skipped.
    let classes: Vec<_> = seq
        .classes()
        .iter()
        .map(|c| (c.name.as_str(), c.label, c.color))
        .collect();
    assert_eq!(
        classes,
        [
            ("Lung", 1, Some([0, 128, 255])),
            ("GTV", 3, Some([255, 0, 0]))
        ]
    );
    let warnings = warnings_about(&path);
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("\"Isocenter\"") && w.contains("POINT")),
        "{warnings:?}"
    );
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("\"Empty\"") && w.contains("no contour")),
        "{warnings:?}"
    );

    // One timestep at t = 0; one axial plane per contour z, in increasing z, u = x, v = y.
    assert_eq!(seq.frames().len(), 1);
    assert_eq!(seq.frames()[0].time, 0.0);
    let planes = &seq.frames()[0].planes;
    let mut zs = lung_zs();
    zs.sort_by(f64::total_cmp);
    let got: Vec<f64> = planes.iter().map(z_of).collect();
    assert_eq!(got.len(), zs.len());
    for (g, w) in got.iter().zip(&zs) {
        assert!((g - w).abs() < 1e-9, "plane z {got:?}, want {zs:?}");
    }
    for p in planes {
        assert_eq!((p.u, p.v), ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]));
        assert_eq!((p.origin[0], p.origin[1]), (0.0, 0.0));
        // The file's box, RAS x ∈ [−50, 90], y ∈ [−40, 60], z ∈ [20, 80], grown by
        // max(5 % of its diagonal (9.1), 10) mm.
        for (got, want) in [p.roi.min, p.roi.max]
            .iter()
            .zip([[-60.0, -50.0], [100.0, 70.0]])
        {
            assert!(
                (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
                "roi {:?}",
                p.roi
            );
        }
    }

    // Areas against the regular polygons; the ring's hole is a hole.
    let ring = ngon_area(30.0, SIDES) - ngon_area(15.0, SIDES);
    for z in lung_zs() {
        let a = region_area(plane_at(&seq, z), 0).unwrap();
        assert!((a - ring).abs() < 1e-3, "Lung at z = {z}: {a} vs {ring}");
        let polys = &plane_at(&seq, z).annotation(0).unwrap().polygons;
        assert_eq!(polys.len(), 2);
        assert!(signed_area(&polys[0]) > 0.0 && signed_area(&polys[1]) < 0.0);
    }
    for z in gtv_zs() {
        let want = ngon_area(gtv_radius(z), SIDES);
        let a = region_area(plane_at(&seq, z), 1).unwrap();
        assert!((a - want).abs() < 1e-3, "GTV at z = {z}: {a} vs {want}");
    }

    // LPS → RAS: x and y negated, z kept.
    let centroid = |poly: &[[f64; 2]]| {
        let n = poly.len() as f64;
        [
            poly.iter().map(|p| p[0]).sum::<f64>() / n,
            poly.iter().map(|p| p[1]).sum::<f64>() / n,
        ]
    };
    let mid = plane_at(&seq, GTV_CENTRE[2]);
    let c = centroid(&mid.annotation(1).unwrap().polygons[0]);
    assert!((c[0] + GTV_CENTRE[0]).abs() < 1e-6 && (c[1] + GTV_CENTRE[1]).abs() < 1e-6);
    let c = centroid(&mid.annotation(0).unwrap().polygons[0]);
    assert!((c[0] + LUNG_CENTRE[0]).abs() < 1e-6 && (c[1] + LUNG_CENTRE[1]).abs() < 1e-6);
    let w = mid.to_world([c[0], c[1]]);
    assert!((w[0] - 60.0).abs() < 1e-6 && (w[1] + 10.0).abs() < 1e-6 && w[2] == 50.0);
}

#[test]
fn absence_follows_the_roi_extent_mode() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = write(dir.path(), "phantom", &phantom_spec()) else {
        return;
    };
    let gtv_absent_at = |seq: &Sequence| -> Vec<f64> {
        let mut zs: Vec<f64> = seq.frames()[0]
            .planes
            .iter()
            .filter(|p| p.annotation(1).is_some_and(|a| a.is_absent()))
            .map(z_of)
            .collect();
        zs.sort_by(f64::total_cmp);
        zs
    };
    let annotated = |seq: &Sequence, class| {
        seq.frames()[0]
            .planes
            .iter()
            .filter(|p| p.annotation(class).is_some())
            .count()
    };

    // File: the GTV is absent on every plane without a GTV contour.
    let file = read(&path, RoiExtent::File).unwrap();
    assert_eq!(
        gtv_absent_at(&file),
        [20.0, 25.0, 30.0, EXTRA_Z, 70.0, 75.0, 80.0]
    );
    assert_eq!(annotated(&file, 1), 14);
    assert_eq!(annotated(&file, 0), 14);

    // Own: only between the GTV's first (35) and last (65) plane.
    let own = read(&path, RoiExtent::Own).unwrap();
    assert_eq!(gtv_absent_at(&own), [EXTRA_Z]);
    assert_eq!(annotated(&own, 1), 8);
    assert_eq!(annotated(&own, 0), 14);
    let gtv_planes: Vec<f64> = own.frames()[0]
        .planes
        .iter()
        .filter(|p| p.annotation(1).is_some())
        .map(z_of)
        .collect();
    assert!(gtv_planes.iter().all(|z| (35.0..=65.0).contains(z)));
}

#[test]
fn implicit_vr_files_read_the_same() {
    let dir = tempfile::tempdir().unwrap();
    let mut spec = phantom_spec();
    let Some(explicit) = write(dir.path(), "explicit", &spec) else {
        return;
    };
    spec["implicit"] = json!(true);
    let implicit = write(dir.path(), "implicit", &spec).unwrap();
    let explicit_contour_data = [0x06, 0x30, 0x50, 0x00, b'D', b'S'];
    let has = |path: &Path| {
        std::fs::read(path)
            .unwrap()
            .windows(6)
            .any(|w| w == explicit_contour_data)
    };
    assert!(
        has(&explicit) && !has(&implicit),
        "pydicom wrote the encodings asked for"
    );
    for extent in [RoiExtent::File, RoiExtent::Own] {
        assert_eq!(
            read(&implicit, extent).unwrap(),
            read(&explicit, extent).unwrap()
        );
    }
}

/// A one-ROI file "Bad" (number 7): a good square on z = 0 as contour item 1, then `bad`.
fn bad_roi(bad: Value) -> Value {
    let square = [
        [0.0, 0.0, 0.0],
        [10.0, 0.0, 0.0],
        [10.0, 10.0, 0.0],
        [0.0, 10.0, 0.0],
    ];
    json!({"rois": [{"number": 7, "name": "Bad", "contours": [closed(&square), bad]}]})
}

/// Reads `spec` and checks the error names the file and contains every part of `expect`.
fn expect_error(name: &str, spec: Value, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = write(dir.path(), name, &spec) else {
        return;
    };
    for extent in [RoiExtent::File, RoiExtent::Own] {
        let err = read(&path, extent).expect_err(name);
        let msg = err.to_string();
        assert!(matches!(err.kind, ErrorKind::Dicom(_)), "{name}: {msg}");
        assert_eq!(err.location.file.as_deref(), Some(path.as_path()), "{msg}");
        assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        for part in expect {
            assert!(msg.contains(part), "{name}: `{msg}` lacks `{part}`");
        }
    }
}

const AT_ITEM_2: &str = "class \"Bad\" (label 7)";

#[test]
fn odd_contour_data_count_is_an_error() {
    let data = ["0", "0", "1", "10", "0", "1", "10"];
    expect_error(
        "odd",
        bad_roi(json!({"type": "CLOSED_PLANAR", "data": data, "npoints": 3})),
        &[AT_ITEM_2, "contour item 2", "7 values, not a multiple of 3"],
    );
}

#[test]
fn number_of_points_disagreeing_is_an_error() {
    let tri = [[0.0, 0.0, 1.0], [5.0, 0.0, 1.0], [0.0, 5.0, 1.0]];
    expect_error(
        "npoints",
        bad_roi(json!({"type": "CLOSED_PLANAR", "data": ds(&tri), "npoints": 4})),
        &[AT_ITEM_2, "contour item 2", "is 4, but ContourData holds 3"],
    );
}

#[test]
fn non_finite_coordinates_are_an_error() {
    for (name, v) in [("nan", f64::NAN), ("inf", f64::INFINITY)] {
        let pts = [[0.0, 0.0, 1.0], [5.0, v, 1.0], [0.0, 5.0, 1.0]];
        expect_error(
            name,
            bad_roi(closed(&pts)),
            &[AT_ITEM_2, "contour item 2", "point 2, y) is not finite"],
        );
    }
}

#[test]
fn open_contours_are_an_error() {
    let tri = [[0.0, 0.0, 1.0], [5.0, 0.0, 1.0], [0.0, 5.0, 1.0]];
    for kind in ["OPEN_PLANAR", "OPEN_NONPLANAR"] {
        expect_error(
            kind,
            bad_roi(json!({"type": kind, "data": ds(&tri)})),
            &[AT_ITEM_2, "contour item 2", kind, "bounds no region"],
        );
    }
}

#[test]
fn non_coplanar_points_are_an_error() {
    let pts = [
        [0.0, 0.0, 1.0],
        [5.0, 0.0, 1.0],
        [5.0, 5.0, 2.0],
        [0.0, 5.0, 1.0],
    ];
    expect_error(
        "bent",
        bad_roi(closed(&pts)),
        &[AT_ITEM_2, "contour item 2", "not coplanar", "point 3"],
    );
}

#[test]
fn zero_area_contours_are_an_error() {
    let line = [[0.0, 0.0, 1.0], [5.0, 5.0, 1.0], [10.0, 10.0, 1.0]];
    expect_error(
        "collinear",
        bad_roi(closed(&line)),
        &[AT_ITEM_2, "contour item 2", "zero area"],
    );
    let two = [[0.0, 0.0, 1.0], [5.0, 5.0, 1.0]];
    expect_error(
        "two",
        bad_roi(closed(&two)),
        &[AT_ITEM_2, "contour item 2", "2 points"],
    );
}

#[test]
fn crossing_contours_of_one_roi_are_an_error_naming_the_plane() {
    let a = [
        [0.0, 0.0, 0.0],
        [8.0, 0.0, 0.0],
        [8.0, 8.0, 0.0],
        [0.0, 8.0, 0.0],
    ];
    let b = a.map(|p| [p[0] + 4.0, p[1] + 4.0, 0.0]);
    let dir = tempfile::tempdir().unwrap();
    let spec =
        json!({"rois": [{"number": 7, "name": "Bad", "contours": [closed(&a), closed(&b)]}]});
    let Some(path) = write(dir.path(), "crossing", &spec) else {
        return;
    };
    let err = read(&path, RoiExtent::File).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err.kind, ErrorKind::SelfIntersection(_)), "{msg}");
    for part in [
        path.display().to_string().as_str(),
        AT_ITEM_2,
        "z = 0 mm",
        "contour items [1, 2]",
    ] {
        assert!(msg.contains(part), "`{msg}` lacks `{part}`");
    }
}

#[test]
fn a_file_that_is_not_an_rtstruct_is_an_error() {
    let mut ct = phantom_spec();
    ct["modality"] = json!("CT");
    expect_error("ct", ct, &["Modality (0008,0060) is `CT`, not RTSTRUCT"]);
    let mut bare = phantom_spec();
    bare["omit"] = json!(["ROIContourSequence"]);
    expect_error("bare", bare, &["no ROIContourSequence (3006,0039)"]);
    let mut bare = phantom_spec();
    bare["omit"] = json!(["StructureSetROISequence"]);
    expect_error(
        "undefined",
        bare,
        &["no StructureSetROISequence (3006,0020)"],
    );

    let dir = tempfile::tempdir().unwrap();
    let text = dir.path().join("notes.dcm");
    std::fs::write(&text, "CSLC\n1 1\n").unwrap();
    let msg = read(&text, RoiExtent::File).unwrap_err().to_string();
    assert!(msg.starts_with(&text.display().to_string()), "{msg}");
    assert!(msg.contains("not a readable DICOM file"), "{msg}");
}

#[test]
fn a_file_with_only_points_is_an_error() {
    let spec = json!({"rois": [{"number": 1, "name": "Iso",
        "contours": [{"type": "POINT", "data": ds(&[[1.0, 2.0, 3.0]])}]}]});
    expect_error("points", spec, &["no ROI has a closed planar contour"]);
}

#[test]
fn files_over_the_size_cap_are_refused_before_parsing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.dcm");
    // Sparse: no data is written.
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(MAX_FILE_BYTES + 1).unwrap();
    let msg = read(&path, RoiExtent::File).unwrap_err().to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    assert!(msg.contains("over the"), "{msg}");
}

/// A ContourData element rewritten to declare 2 GiB (as VR UN, 4-byte length): refused as its
/// header is decoded, before dicom-rs would allocate the declared length.
#[test]
fn declared_lengths_beyond_the_file_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = write(dir.path(), "phantom", &phantom_spec()) else {
        return;
    };
    let mut bytes = std::fs::read(&path).unwrap();
    let header = [0x06, 0x30, 0x50, 0x00, b'D', b'S'];
    let at = bytes
        .windows(header.len())
        .position(|w| w == header)
        .expect("a ContourData element in explicit VR little endian");
    bytes[at + 4..at + 12].copy_from_slice(&[b'U', b'N', 0, 0, 0xf0, 0xff, 0xff, 0x7f]);
    let bad = dir.path().join("huge_length.dcm");
    std::fs::write(&bad, &bytes).unwrap();
    let msg = read(&bad, RoiExtent::File).unwrap_err().to_string();
    assert!(msg.starts_with(&bad.display().to_string()), "{msg}");
    assert!(
        msg.contains("element (3006,0050) declares 2147483632 bytes at byte ")
            && msg.contains("bytes left in the file"),
        "{msg}"
    );
}

/// Corrupted files (flipped bytes, truncations) give an error or a sequence, never a panic.
#[test]
fn corrupted_files_do_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = write(dir.path(), "phantom", &phantom_spec()) else {
        return;
    };
    let bytes = std::fs::read(&path).unwrap();
    let out = dir.path().join("bad.dcm");
    // A fixed linear congruential generator: reproducible positions and values.
    let mut state: u64 = 0x2545_f491_4f6c_dd1d;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 33) as usize
    };
    let (mut errors, mut reads) = (0, 0);
    for round in 0..300 {
        let mut b = bytes.clone();
        if round % 3 == 0 {
            b.truncate(next() % b.len());
        } else {
            for _ in 0..1 + round % 4 {
                let at = next() % b.len();
                b[at] = (next() & 0xff) as u8;
            }
        }
        std::fs::write(&out, &b).unwrap();
        match read(&out, RoiExtent::File) {
            Ok(_) => reads += 1,
            Err(e) => {
                assert!(e.to_string().starts_with(&out.display().to_string()));
                errors += 1;
            }
        }
    }
    assert!(errors > 0 && errors + reads == 300);
}

/// Contours the shared TotalSegmentator label map on its axial slices for its three largest
/// labels (scikit-image's marching squares at level 0.5 on the zero-padded mask, through the
/// NIfTI affine into LPS) and compares our polygons on every slice with the voxels there.
///
/// The level-0.5 contour of a voxel mask cuts each convex corner of the voxel boundary by 1/8
/// voxel and adds 1/8 at each concave one; a closed boundary has four more convex corners than
/// concave ones, a hole four fewer. So the region is exactly
/// (voxels − (outer boundaries − holes) / 2) voxel areas, and ours must match it to 0.01 mm²
/// (the 6-decimal DS rounding moves it by ~10⁻⁴ mm²); that also checks which contours the
/// even-odd rule made holes.
#[test]
fn contours_of_a_label_map_cover_its_voxels() {
    let Some(nifti) = shared_data("nifti/example_seg.nii.gz") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("seg_rtstruct.dcm");
    let script = format!(
        "{WRITER}\n{}",
        r#"
import nibabel as nib, numpy as np
from skimage.measure import find_contours
img = nib.load(sys.argv[1])
data = np.asarray(img.dataobj).astype(np.int32)
A = img.affine
labels, counts = np.unique(data[data > 0], return_counts=True)
chosen = [int(l) for l in labels[np.argsort(counts)[::-1][:3]]]
rois = []
for number, label in enumerate(chosen, start=1):
    contours = []
    for k in range(data.shape[2]):
        mask = np.pad(data[:, :, k] == label, 1).astype(float)
        for c in find_contours(mask, 0.5):
            ij = c - 1.0
            ras = A @ np.c_[ij, np.full(len(ij), k), np.ones(len(ij))].T
            lps = np.c_[-ras[0], -ras[1], ras[2]]
            contours.append({"type": "CLOSED_PLANAR", "data": [f"{v:.6f}" for v in lps.ravel()]})
    rois.append({"number": number, "name": f"label {label}", "contours": contours})
write_rtstruct(sys.argv[2], {"rois": rois})
widest = int(np.argmax((data == chosen[0]).sum(axis=(0, 1))))
ii, jj = np.nonzero(data[:, :, widest] == chosen[0])
centre = A @ np.array([ii.mean(), jj.mean(), widest, 1.0])
print(json.dumps({
    "labels": chosen,
    "zs": [float((A @ np.array([0, 0, k, 1.0]))[2]) for k in range(data.shape[2])],
    "voxels": [[int((data[:, :, k] == l).sum()) for l in chosen] for k in range(data.shape[2])],
    "voxel_area": float(abs(np.linalg.det(A[:2, :2]))),
    "widest": widest,
    "centre": [float(v) for v in centre[:3]],
}))
"#
    );
    let Some(text) = run_python(&["pydicom", "nibabel", "skimage"], &script, &[&nifti, &out])
    else {
        return;
    };
    let info: Value = serde_json::from_str(&text).unwrap();
    let seq = read(&out, RoiExtent::File).unwrap();
    let labels = info["labels"].as_array().unwrap();
    let names: Vec<String> = labels.iter().map(|l| format!("label {l}")).collect();
    let got: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(got, names);
    let voxel_area = info["voxel_area"].as_f64().unwrap();
    let zs: Vec<f64> = serde_json::from_value(info["zs"].clone()).unwrap();
    let voxels: Vec<Vec<f64>> = serde_json::from_value(info["voxels"].clone()).unwrap();
    let planes = &seq.frames()[0].planes;
    let mut compared = 0;
    for (z, counts) in zs.iter().zip(&voxels) {
        let Some(plane) = planes.iter().find(|p| (z_of(p) - z).abs() < 1e-6) else {
            assert!(counts.iter().all(|&c| c == 0.0), "no plane at z = {z}");
            continue;
        };
        assert_eq!(plane.normal(), [0.0, 0.0, 1.0]);
        for (k, &count) in counts.iter().enumerate() {
            // Every label is contoured on every slice of the file: absent where it has no voxel.
            let ann = plane.annotation(k).expect("File mode annotates every ROI");
            if count == 0.0 {
                assert!(ann.is_absent(), "{} at z = {z}", names[k]);
                continue;
            }
            let area: f64 = ann.polygons.iter().map(|p| signed_area(p)).sum();
            let (outer, holes) = ann.polygons.iter().fold((0.0, 0.0), |(o, h), p| {
                if signed_area(p) > 0.0 {
                    (o + 1.0, h)
                } else {
                    (o, h + 1.0)
                }
            });
            let want = (count - 0.5 * (outer - holes)) * voxel_area;
            assert!(
                (area - want).abs() < 0.01,
                "{} at z = {z}: contours {area} mm², voxels {want} mm²",
                names[k]
            );
            compared += 1;
        }
    }
    assert!(compared > 30, "only {compared} slices compared");

    // The same place as the NIfTI: the largest label's voxel centroid (RAS) on its widest slice
    // vs the centroid of our region there.
    let widest = info["widest"].as_u64().unwrap() as usize;
    let plane = plane_at(&seq, zs[widest]);
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for p in &plane.annotation(0).unwrap().polygons {
        let n = p.len();
        for i in 0..n {
            let (s, t) = (p[i], p[(i + 1) % n]);
            let w = s[0] * t[1] - t[0] * s[1];
            a += w;
            cx += (s[0] + t[0]) * w;
            cy += (s[1] + t[1]) * w;
        }
    }
    let centre = plane.to_world([cx / (3.0 * a), cy / (3.0 * a)]);
    let want: Vec<f64> = serde_json::from_value(info["centre"].clone()).unwrap();
    for axis in 0..3 {
        assert!(
            (centre[axis] - want[axis]).abs() < 1.0,
            "centroid {centre:?} vs voxels {want:?}"
        );
    }
}

/// The time to read one legal contour of `n` points (a wavy ring, so no two edges are
/// collinear) and one of `n` points on the next plane: prints it for n = 25k, 50k and 200k. A
/// measurement, not a pass/fail limit: `cargo test -p dynaslice-data --profile test --test
/// rtstruct -- --ignored --nocapture time_to_read_long_contours`.
#[test]
#[ignore = "a measurement; run by hand"]
fn time_to_read_long_contours() {
    let dir = tempfile::tempdir().unwrap();
    for n in [25_000, 50_000, 200_000] {
        let ring = |z: f64| -> Vec<[f64; 3]> {
            (0..n)
                .map(|j| {
                    let a = std::f64::consts::TAU * j as f64 / n as f64;
                    let r = 50.0 + 5.0 * (37.0 * a).sin();
                    [r * a.cos(), r * a.sin(), z]
                })
                .collect()
        };
        // Implicit VR: a ContourData of over 64 KiB has no explicit-VR length field.
        let spec = json!({"implicit": true, "rois": [{"number": 1, "name": "long",
            "contours": [closed(&ring(0.0)), closed(&ring(3.0))]}]});
        let Some(path) = write(dir.path(), &format!("long{n}"), &spec) else {
            return;
        };
        let (start, cpu) = (std::time::Instant::now(), thread_cpu_seconds());
        let seq = read(&path, RoiExtent::File).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        let cpu = thread_cpu_seconds() - cpu;
        assert_eq!(seq.frames()[0].planes.len(), 2);
        println!("{n} points per contour: read in {seconds:.2} s ({cpu:.2} s of CPU)");
    }
}

/// This thread's CPU time (Linux's schedstat; 0 elsewhere): the measure that a loaded machine
/// does not inflate.
fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

#[test]
fn files_without_preamble_or_extension_and_deflated_files_read() {
    capture_warnings();
    let dir = tempfile::tempdir().unwrap();
    // pydicom's own rtstruct.dcm: a bare data set, no preamble, `DICM` or file meta group.
    let bare = dir.path().join("bare.dcm");
    let copy = "import shutil, sys\nfrom pydicom.data import get_testdata_file\n\
                shutil.copy(get_testdata_file('rtstruct.dcm'), sys.argv[1])\n";
    if run_python(&["pydicom"], copy, &[&bare]).is_none() {
        return;
    }
    assert_ne!(&std::fs::read(&bare).unwrap()[128..132], b"DICM");
    let seq = read(&bare, RoiExtent::default()).unwrap();
    assert!(
        seq.classes().iter().any(|c| c.name == "patient"),
        "{:?}",
        seq.classes()
    );
    let warned = warnings_about(&bare);
    assert!(
        warned.iter().any(|w| w.contains("no DICOM preamble")),
        "{warned:?}"
    );

    // A deflated file reads as its explicit-VR twin; one without an extension is found by
    // its `DICM` marker.
    let Some(plain) = write(dir.path(), "plain", &phantom_spec()) else {
        return;
    };
    let mut spec = phantom_spec();
    spec["deflated"] = json!(true);
    let deflated = write(dir.path(), "deflated", &spec).unwrap();
    assert_ne!(
        std::fs::read(&deflated).unwrap(),
        std::fs::read(&plain).unwrap()
    );
    let expected = read(&plain, RoiExtent::default()).unwrap();
    assert_eq!(read(&deflated, RoiExtent::default()).unwrap(), expected);
    let bare_name = dir.path().join("RS.1.2.840.113619");
    std::fs::copy(&plain, &bare_name).unwrap();
    let seq = dynaslice_data::input::read(&[bare_name], &Default::default()).unwrap();
    assert_eq!(seq, expected);
}

#[test]
fn phases_in_different_frames_of_reference_are_an_error_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let mut specs = Vec::new();
    for frame in ["1.2.3.4", "1.2.3.4", "1.2.3.5"] {
        let mut spec = phantom_spec();
        spec["frame"] = json!(frame);
        specs.push(spec);
    }
    let Some(a) = write(dir.path(), "phase0", &specs[0]) else {
        return;
    };
    write(dir.path(), "phase1", &specs[1]).unwrap();
    write(dir.path(), "other", &specs[2]).unwrap();
    let manifest = dir.path().join("same.seq");
    std::fs::write(&manifest, "0 phase0.dcm\n1 phase1.dcm\n").unwrap();
    let options = Default::default();
    let seq = dynaslice_data::input::read(&[manifest], &options).unwrap();
    assert_eq!(seq.frames().len(), 2);
    let manifest = dir.path().join("mixed.seq");
    std::fs::write(&manifest, "0 phase0.dcm\n1 other.dcm\n").unwrap();
    let e = dynaslice_data::input::read(&[manifest], &options)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("other.dcm") && e.contains(&a.display().to_string()) && e.contains("1.2.3.5"),
        "{e}"
    );
}
