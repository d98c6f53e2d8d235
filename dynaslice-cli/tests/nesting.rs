//! Nested structures and clinical time axes, end to end, on the RT Structure Sets a cardiac
//! contouring tool writes (pydicom, `lab/cases/nested_heart.py`): the endocardium drawn inside
//! the epicardium, two phases at trigger times 287.7 and 709.7 ms. Training finds the nesting
//! and records it; `measure` gives the epicardium whole (wall + cavity) where the label volume
//! keeps the disjoint labels; `rtstruct` writes both structures whole; and `labels --like`
//! (a reference's toffset, or `--times` on its grid), `measure`, `rtstruct` and `report` work
//! at the model's own times.

mod common;

use common::{succeeded, train_command};
use dynaslice_data::nifti::read_volume;
use dynaslice_data::rtstruct::{read, RoiExtent};
use dynaslice_geometry::boolean::{intersection, region_area};
use dynaslice_test_support::python::run_python;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs `lab/cases/nested_heart.py` into `argv[1]/case` (its Simpson volumes on stdout) and
/// writes two reference images at 2 mm over the model's whole domain (centre (0, 0, −2.5),
/// half-width 49.5 mm: where measure meshes, spurious bits of a short training included):
/// `ref.nii.gz`, two frames at toffset
/// 287.7 ms, 422 ms apart (the phases' trigger times), and `ref3d.nii.gz`, one frame, toffset 0.
const FIXTURE: &str = r#"
import os, sys, runpy
import numpy as np, nibabel as nib
out, case = sys.argv[1], sys.argv[2]
sys.argv = ["nested_heart.py", os.path.join(out, "case")]
runpy.run_path(case, run_name="__main__")
aff = np.diag([2.0, 2.0, 2.0, 1.0]); aff[:3, 3] = [-49.0, -49.0, -52.0]
img = nib.Nifti1Image(np.zeros((50, 50, 51, 2), np.uint8), aff)
img.header.set_xyzt_units("mm", "msec")
img.header["pixdim"][4] = 422.0
img.header["toffset"] = 287.7
nib.save(img, os.path.join(out, "ref.nii.gz"))
nib.save(nib.Nifti1Image(np.zeros((50, 50, 51), np.uint8), aff), os.path.join(out, "ref3d.nii.gz"))
"#;

fn dynaslice(dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dynaslice"));
    c.current_dir(dir);
    c
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `dciodvfy` on `path`: its errors, or `None` when it is not installed (a failure where
/// `DYNASLICE_REQUIRE_PYTHON` is set: CI installs dicom3tools).
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
fn nested_contours_train_disjoint_and_come_back_whole_at_the_model_s_own_times() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let case = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../lab/cases/nested_heart.py");
    let Some(simpson) = run_python(&["pydicom", "nibabel", "numpy"], FIXTURE, &[d, &case]) else {
        return;
    };
    let simpson: Value = serde_json::from_str(simpson.trim()).unwrap();
    let model = d.join("lv.dsm");
    let out = train_command(&d.join("case/kept.seq"), &model, &["--steps", "300"])
        .current_dir(d)
        .output()
        .unwrap();
    succeeded(&out);
    let info = dynaslice(d).args(["info", "lv.dsm"]).output().unwrap();
    succeeded(&info);
    let info = String::from_utf8_lossy(&info.stdout).into_owned();
    // Endocardium (ROI 2) inside epicardium (ROI 1), by label; the range in ms.
    assert!(info.contains("nesting = 2:1"), "{info}");

    // measure at the model's own times (its range, 287.7 to 709.7 ms).
    let m = dynaslice(d)
        .args(["measure", "lv.dsm", "--times", "287.7:709.7:2", "--json"])
        .args(["--resolution", "96"])
        .output()
        .unwrap();
    succeeded(&m);
    let m: Value = serde_json::from_slice(&m.stdout).unwrap();
    let volumes = |k: usize| -> Vec<f64> {
        m["classes"][k]["volume_ml"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    assert_eq!(m["classes"][0]["name"], "Epicardium");
    let (epi, endo) = (volumes(0), volumes(1));

    // The label volume on the reference's grid at its frames (toffset 287.7 ms + f × 422 ms):
    // disjoint labels, wall 1 and cavity 2; measure's epicardium holds the cavity. (That its
    // volume is wall + cavity is checked on exact fields in dynaslice-metrics' volume tests:
    // this test's 300-step network leaves spurious bits at the domain's edge, where meshes and
    // voxels differ.)
    succeeded(
        &dynaslice(d)
            .args([
                "labels",
                "lv.dsm",
                "--like",
                "ref.nii.gz",
                "-o",
                "labels.nii.gz",
            ])
            .output()
            .unwrap(),
    );
    let labels = read_volume(&d.join("labels.nii.gz")).unwrap();
    assert_eq!(labels.frames, 2);
    let per_frame: usize = labels.dims.iter().product();
    for f in 0..2 {
        let frame = &labels.labels[f * per_frame..(f + 1) * per_frame];
        let ml = |which: i32| frame.iter().filter(|&&l| l == which).count() as f64 * 8.0 / 1000.0;
        let (wall, cavity) = (ml(1), ml(2));
        let phase = ["ED", "ES"][f];
        println!(
            "{phase}: measure epicardium {:.2} mL, endocardium {:.2} mL; labels wall {wall:.2} + \
             cavity {cavity:.2} mL; Simpson {} / {} mL",
            epi[f],
            endo[f],
            simpson[format!("{phase} Epicardium")]["simpson_mL"],
            simpson[format!("{phase} Endocardium")]["simpson_mL"]
        );
        assert!(
            wall > 0.0 && cavity > 0.0,
            "{phase}: wall {wall}, cavity {cavity}"
        );
        assert!(
            epi[f] > endo[f] && endo[f] > 0.0,
            "{phase}: {} {}",
            epi[f],
            endo[f]
        );
    }

    // A one-frame reference at toffset 0 is outside the range: refused, naming the fix;
    // with --times on its grid it works.
    let refused = dynaslice(d)
        .args([
            "labels",
            "lv.dsm",
            "--like",
            "ref3d.nii.gz",
            "-o",
            "es.nii.gz",
        ])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let e = stderr(&refused);
    assert!(
        e.contains("outside the model's time range") && e.contains("--times"),
        "{e}"
    );
    succeeded(
        &dynaslice(d)
            .args(["labels", "lv.dsm", "--like", "ref3d.nii.gz"])
            .args(["--times", "709.7:709.7:1", "-o", "es.nii.gz"])
            .output()
            .unwrap(),
    );

    // RT Structure Sets at the manifest's times: both structures whole, the endocardium
    // inside the epicardium on every plane both are on.
    succeeded(
        &dynaslice(d)
            .args([
                "rtstruct",
                "lv.dsm",
                "--like",
                "case/all_ED.dcm",
                "-o",
                "rs",
            ])
            .output()
            .unwrap(),
    );
    let manifest = std::fs::read_to_string(d.join("rs/rtstruct.seq")).unwrap();
    assert!(
        manifest.contains("287.7 RS_t000.dcm") && manifest.contains("709.7 RS_t001.dcm"),
        "{manifest}"
    );
    for file in ["RS_t000.dcm", "RS_t001.dcm"] {
        let path = d.join("rs").join(file);
        if let Some(errors) = dciodvfy(&path) {
            assert!(errors.is_empty(), "{file}: {errors:#?}");
        }
        let seq = read(&path, RoiExtent::File).unwrap();
        let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["Epicardium", "Endocardium"]);
        let mut shared_planes = 0;
        for plane in &seq.frames()[0].planes {
            let (Some(outer), Some(inner)) = (plane.annotation(0), plane.annotation(1)) else {
                continue;
            };
            if inner.is_absent() {
                continue;
            }
            shared_planes += 1;
            let inside = intersection(&inner.polygons, &outer.polygons).unwrap();
            let (a, b) = (region_area(&inner.polygons), region_area(&inside));
            assert!(
                (a - b).abs() < 0.03 * a,
                "{file}: the endocardium ({a} mm²) lies inside the written epicardium ({b})"
            );
            assert!(
                region_area(&outer.polygons) > a,
                "{file}: the epicardium is whole"
            );
        }
        assert!(shared_planes > 5, "{file}: {shared_planes} planes");
    }

    // The report at the model's times.
    succeeded(
        &dynaslice(d)
            .args(["report", "lv.dsm", "-o", "lv.html", "--resolution", "48"])
            .output()
            .unwrap(),
    );
    let html = std::fs::read_to_string(d.join("lv.html")).unwrap();
    assert!(
        html.contains("Epicardium") && html.contains("287.7"),
        "report"
    );
}
