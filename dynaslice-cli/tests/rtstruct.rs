//! `dynaslice rtstruct` on a 4D-CT-like case made with pydicom (two lungs breathing, a tumour
//! moving 10 mm superior–inferior inside the right lung, one RT Structure Set per phase, the
//! structure sets lacking the Type 2 attributes many exports omit, and a planning CT series):
//! a model trained on the phases is written back as RT Structure Sets on the CT's slices, and
//! every file passes `dciodvfy`, reads in pydicom with the input's UIDs, names and colours, and
//! reads back through our reader to the model's Eq. 11 labels (IoU ≥ 0.98 per class).

mod common;

use common::{succeeded, train_command, write_sequence};
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::rtstruct::{read, RoiExtent};
use dynaslice_geometry::polygon::contains_even_odd;
use dynaslice_test_support::fixtures::two_organ_model;
use dynaslice_test_support::python::run_python;
use std::path::Path;
use std::process::Command;

/// Writes, into the folder `sys.argv[1]`: `ct/CT_KK.dcm` (a 96×96 CT series at 3 mm pixels,
/// slices every 4 mm), `RS_pPP.dcm` for phases 0, 25, 50, 75 (% of the cycle) and `phases.seq`
/// listing them. The structure sets hold only what the reader needs and the Frame of Reference
/// and Study UIDs (no Patient ID, Study Date, …: Type 2 attributes missing, as in many
/// exports). Prints the study, frame of reference and CT series UIDs, then the CT images', one
/// per line.
const FIXTURE: &str = r#"
import os, sys
import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

out = sys.argv[1]
os.makedirs(os.path.join(out, "ct"), exist_ok=True)
study, frame, ct_series = generate_uid(), generate_uid(), generate_uid()
zs = np.arange(-76.0, 76.1, 4.0)

def base(path, sop_class):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.StudyInstanceUID = study
    return ds

ct_uids = []
for k, z in enumerate(zs):
    path = os.path.join(out, "ct", "CT_%02d.dcm" % k)
    ds = base(path, "1.2.840.10008.5.1.4.1.1.2")
    ds.Modality = "CT"
    ds.PatientName = "Phantom^Lung"
    ds.PatientID = "DS-4DCT"
    ds.SeriesInstanceUID = ct_series
    ds.FrameOfReferenceUID = frame
    ds.ImagePositionPatient = [-142.5, -142.5, float(z)]
    ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.PixelSpacing = [3.0, 3.0]
    ds.SliceThickness = 4.0
    ds.Rows, ds.Columns = 96, 96
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
    ds.PixelRepresentation, ds.SamplesPerPixel = 1, 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.PixelData = np.zeros((96, 96), np.int16).tobytes()
    ds.save_as(path, enforce_file_format=True)
    ct_uids.append(ds.SOPInstanceUID)

def ring(cx, cy, z, a, b, n=48):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [f"{v:.4f}" for p in zip(cx + a * np.cos(t), cy + b * np.sin(t), np.full(n, z)) for v in p]

def ellipsoid(c, r, z):
    s = 1 - ((z - c[2]) / r[2]) ** 2
    return None if s <= 0.01 else (r[0] * np.sqrt(s), r[1] * np.sqrt(s))

rois = [(1, "Lung_R", [0, 128, 255]), (2, "Lung_L", [255, 200, 0]), (7, "GTV", [255, 0, 0])]
manifest = []
for phase in (0, 25, 50, 75):
    breath = 0.5 * (1 - np.cos(2 * np.pi * phase / 100))  # 0 at 0 %, 1 at 50 %
    lungs = {1: ([-60.0, 10.0, 0.0], [42.0, 55.0, 62.0 + 8 * breath]),
             2: ([60.0, 10.0, 0.0], [40.0, 55.0, 60.0 + 8 * breath])}
    gtv = ([-60.0, 10.0, -5.0 + 10 * breath], [14.0, 14.0, 14.0])
    path = os.path.join(out, "RS_p%02d.dcm" % phase)
    ds = base(path, "1.2.840.10008.5.1.4.1.1.481.3")
    ds.Modality = "RTSTRUCT"
    ds.StructureSetLabel = "4DCT %d%%" % phase
    ref = Dataset()
    ref.FrameOfReferenceUID = frame
    ds.ReferencedFrameOfReferenceSequence = Sequence([ref])
    defined, contoured = [], []
    for number, name, color in rois:
        s = Dataset()
        s.ROINumber, s.ROIName = number, name
        s.ReferencedFrameOfReferenceUID = frame
        s.ROIGenerationAlgorithm = "MANUAL"
        defined.append(s)
        items = []
        for z in zs:
            rings = []
            if number in lungs:
                e = ellipsoid(*lungs[number], z)
                if e:
                    rings.append(ring(lungs[number][0][0], lungs[number][0][1], z, *e))
                    # The lung minus the tumour: the GTV's cut is a hole (even-odd).
                    g = ellipsoid(*gtv, z) if number == 1 else None
                    if g:
                        rings.append(ring(gtv[0][0], gtv[0][1], z, *g))
            else:
                g = ellipsoid(*gtv, z)
                if g:
                    rings.append(ring(gtv[0][0], gtv[0][1], z, *g))
            for r in rings:
                it = Dataset()
                it.ContourGeometricType = "CLOSED_PLANAR"
                it.NumberOfContourPoints = len(r) // 3
                it.ContourData = r
                items.append(it)
        c = Dataset()
        c.ReferencedROINumber = number
        c.ROIDisplayColor = color
        c.ContourSequence = Sequence(items)
        contoured.append(c)
    ds.StructureSetROISequence = Sequence(defined)
    ds.ROIContourSequence = Sequence(contoured)
    ds.save_as(path, enforce_file_format=True)
    manifest.append("%d RS_p%02d.dcm" % (phase, phase))
open(os.path.join(out, "phases.seq"), "w").write("\n".join(manifest) + "\n")
print("\n".join([study, frame, ct_series] + ct_uids))
"#;

/// Reads every file of the output with pydicom and prints what the test checks: per file a
/// line `FILE sop_class sop series study modality frame ref_series types patient_id`, then per
/// ROI a line `ROI number name r,g,b contours referenced_images` (comma-separated, `-` when
/// none).
const INSPECT: &str = r#"
import sys
import pydicom
for path in sys.argv[1:]:
    ds = pydicom.dcmread(path)
    ref = ds.ReferencedFrameOfReferenceSequence[0]
    types = sorted({i.ContourGeometricType for c in ds.ROIContourSequence
                    for i in c.get("ContourSequence", [])})
    print("FILE", ds.SOPClassUID, ds.SOPInstanceUID, ds.SeriesInstanceUID, ds.StudyInstanceUID,
          ds.Modality, ref.FrameOfReferenceUID,
          ref.RTReferencedStudySequence[0].RTReferencedSeriesSequence[0].SeriesInstanceUID,
          ",".join(types), repr(str(ds.PatientID)))
    names = {r.ROINumber: r.ROIName for r in ds.StructureSetROISequence}
    for c in ds.ROIContourSequence:
        images = sorted({i.ContourImageSequence[0].ReferencedSOPInstanceUID
                         for i in c.get("ContourSequence", []) if "ContourImageSequence" in i})
        print("ROI", c.ReferencedROINumber, names[c.ReferencedROINumber].replace(" ", "_"),
              ",".join(str(int(v)) for v in c.ROIDisplayColor), len(c.get("ContourSequence", [])),
              ",".join(images) or "-")
"#;

fn dynaslice() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
}

/// `dciodvfy` on `path`: its errors (lines with "Error"), or `None` when it is not installed
/// (a failure where `DYNASLICE_REQUIRE_PYTHON` is set: CI installs dicom3tools).
fn dciodvfy(path: &Path) -> Option<Vec<String>> {
    let Ok(out) = Command::new("dciodvfy").arg(path).output() else {
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_PYTHON").is_none(),
            "dciodvfy is missing but DYNASLICE_REQUIRE_PYTHON is set (apt-get install dicom3tools)"
        );
        println!("SKIPPED: dciodvfy is missing (apt-get install dicom3tools)");
        return None;
    };
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    Some(
        text.lines()
            .filter(|l| l.starts_with("Error"))
            .map(str::to_string)
            .collect(),
    )
}

#[test]
fn phases_go_back_as_rt_structure_sets_on_the_ct_with_the_model_s_labels() {
    let dir = tempfile::tempdir().unwrap();
    let Some(uids) = run_python(&["pydicom", "numpy"], FIXTURE, &[dir.path()]) else {
        return;
    };
    let uids: Vec<&str> = uids.lines().collect();
    let (study, frame, ct_series, ct) = (uids[0], uids[1], uids[2], &uids[3..]);
    let model = dir.path().join("lungs.dsm");
    succeeded(
        // The test is of the writer, which needs every structure contoured at every phase.
        // The common 2 layers of 32 do not carve the 28 mm GTV's hole out of the lung's channel
        // (at 300 steps and ω₀ = 10 the GTV had contours only because its channel filled the
        // domain's edges, which the extent bound of issue 51 removed); two more layers of 64
        // (`--widths` appends) and 600 steps at the default ω₀ keep it at 8-11 mL of 11.5.
        &train_command(
            &dir.path().join("phases.seq"),
            &model,
            &["--steps", "600", "--widths", "64,64"],
        )
        .current_dir(dir.path())
        .output()
        .unwrap(),
    );
    // Without --times: the times of the training manifest the model records.
    let out = dir.path().join("rs");
    let rtstruct = |more: &[&str]| {
        dynaslice()
            .current_dir(dir.path())
            .args([
                "rtstruct",
                "lungs.dsm",
                "--like",
                "RS_p00.dcm",
                "--ct",
                "ct",
                "-o",
                "rs",
            ])
            .args(more)
            .output()
            .unwrap()
    };
    succeeded(&rtstruct(&["--itv"]));
    let manifest = std::fs::read_to_string(out.join("rtstruct.seq")).unwrap();
    let entries: Vec<(f64, String)> = manifest
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let (t, p) = l.split_once(' ').unwrap();
            (t.parse().unwrap(), p.to_string())
        })
        .collect();
    let times: Vec<f64> = entries.iter().map(|e| e.0).collect();
    assert_eq!(times, [0.0, 25.0, 50.0, 75.0], "{manifest}");
    let files: Vec<_> = entries.iter().map(|e| out.join(&e.1)).collect();

    for f in &files {
        if let Some(errors) = dciodvfy(f) {
            assert!(errors.is_empty(), "{}: {errors:#?}", f.display());
        }
    }

    let paths: Vec<&Path> = files.iter().map(|p| p.as_path()).collect();
    let inspected = run_python(&["pydicom"], INSPECT, &paths).expect("pydicom imported above");
    let mut sops = Vec::new();
    let mut rois: Vec<Vec<String>> = Vec::new();
    let want_rois = [
        "1 Lung_R 0,128,255",
        "2 Lung_L 255,200,0",
        "7 GTV 255,0,0",
        "8 ITV_Lung_R 0,128,255",
        "9 ITV_Lung_L 255,200,0",
        "10 ITV_GTV 255,0,0",
    ];
    let check_rois = |rois: &[Vec<String>]| {
        let summary: Vec<String> = rois.iter().map(|r| r[1..4].join(" ")).collect();
        assert_eq!(summary, want_rois);
        for r in rois {
            assert!(r[4].parse::<usize>().unwrap() > 0, "ROI {r:?} has contours");
            // Every contour references the CT image of its slice.
            assert_ne!(r[5], "-", "ROI {r:?} references no image");
            for uid in r[5].split(',') {
                assert!(ct.contains(&uid), "{uid} is not a CT image");
            }
        }
    };
    for line in inspected.lines() {
        let f: Vec<String> = line.split(' ').map(str::to_string).collect();
        if f[0] == "ROI" {
            rois.push(f);
            continue;
        }
        if !rois.is_empty() {
            check_rois(&rois);
            rois.clear();
        }
        assert_eq!(f[0], "FILE", "{line}");
        assert_eq!(f[1], "1.2.840.10008.5.1.4.1.1.481.3");
        assert_eq!(
            f[4..10],
            [study, "RTSTRUCT", frame, ct_series, "CLOSED_PLANAR", "''"],
            "study, modality, frame, referenced series, contour types, and the Patient ID the \
             input lacks (Type 2) written empty"
        );
        for uid in &f[2..4] {
            assert!(uid.starts_with("2.25.") && uid.len() <= 64, "{uid}");
            sops.push(uid.clone());
        }
    }
    check_rois(&rois);
    sops.sort();
    sops.dedup();
    assert_eq!(sops.len(), 2 * files.len(), "new UIDs per file and series");

    // Our reader reads every file back; on each of its planes the contours' regions are the
    // model's Eq. 11 labels (sampled every 1 mm), and each ITV holds its class's region.
    let bytes = ModelBytes::read(&model).unwrap();
    let model = bytes.model().unwrap();
    for (f, &t) in files.iter().zip(&times) {
        let seq = read(f, RoiExtent::File).unwrap();
        let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names[..3], ["Lung_R", "Lung_L", "GTV"]);
        let (iou, covered) = compare(&model, &seq, t);
        println!("t = {t}: IoU {iou:?}, ITV coverage {covered:?}");
        for k in 0..3 {
            assert!(
                iou[k] >= 0.98,
                "{}: {} IoU {}",
                f.display(),
                names[k],
                iou[k]
            );
            // Both contours are traced on the CT's 3 mm grid; where they run together a 1 mm
            // sample can fall between them (0.9988 of the 28 mm GTV's points at one time).
            assert!(
                covered[k] >= 0.998,
                "{}: ITV of {} covers {}",
                f.display(),
                names[k],
                covered[k]
            );
        }
    }

    // Written again over the set with fewer times (--force), the folder holds the new set
    // only: no RS file of the earlier, longer set is left beside it; the user's file stays.
    std::fs::write(out.join("notes.txt"), b"mine").unwrap();
    succeeded(&rtstruct(&["--times", "0:50:2", "--force"]));
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["RS_t000.dcm", "RS_t001.dcm", "notes.txt", "rtstruct.seq"]
    );
}

/// Per class (0..3, the model's channels): the IoU between the regions of `seq`'s contours
/// and the model's Eq. 11 labels at time `t`, and the fraction of the class's drawn region that
/// its ITV (class k + 3) holds, over every plane of `seq`, on a 1 mm grid.
fn compare(model: &Model, seq: &dynaslice_data::Sequence, t: f64) -> ([f64; 3], [f64; 3]) {
    let (mut both, mut either) = ([0usize; 3], [0usize; 3]);
    let (mut drawn_total, mut in_itv) = ([0usize; 3], [0usize; 3]);
    let (lo, hi) = model.domain().bounds();
    for plane in &seq.frames()[0].planes {
        let r = plane.box_roi(lo.map(f64::from), hi.map(f64::from));
        let step = 1.0;
        let (nu, nv) = (
            ((r.max[0] - r.min[0]) / step) as usize,
            ((r.max[1] - r.min[1]) / step) as usize,
        );
        let inside = |k: usize, p| {
            plane
                .annotation(k)
                .is_some_and(|a| contains_even_odd(&a.polygons, p))
        };
        for j in 0..nv {
            for i in 0..nu {
                let p = [
                    r.min[0] + (i as f64 + 0.5) * step,
                    r.min[1] + (j as f64 + 0.5) * step,
                ];
                let x = plane.to_world(p).map(|v| v as f32);
                let label = model.label(x, t as f32) as usize;
                for k in 0..3 {
                    let drawn = inside(k, p);
                    let labelled = label == k + 1;
                    both[k] += usize::from(drawn && labelled);
                    either[k] += usize::from(drawn || labelled);
                    drawn_total[k] += usize::from(drawn);
                    in_itv[k] += usize::from(drawn && inside(k + 3, p));
                }
            }
        }
    }
    let iou = std::array::from_fn(|k| {
        assert!(either[k] > 0, "class {k} is nowhere");
        both[k] as f64 / either[k] as f64
    });
    (
        iou,
        std::array::from_fn(|k| in_itv[k] as f64 / drawn_total[k] as f64),
    )
}

#[test]
fn a_like_file_that_is_not_an_rt_structure_set_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let like = write_sequence(dir.path()).with_file_name("ball_0.csl");
    let model = dir.path().join("m.dsm");
    std::fs::write(&model, two_organ_model(true)).unwrap();
    let out = dir.path().join("rs");
    let run = dynaslice()
        .args([
            "rtstruct",
            model.to_str().unwrap(),
            "--like",
            like.to_str().unwrap(),
        ])
        .args(["--times", "0:0.8:2", "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        err.contains("ball_0.csl") && err.contains("not a readable DICOM file"),
        "{err}"
    );
    assert!(!out.exists(), "no output folder for a refused run");
}
