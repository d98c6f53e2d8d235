//! NIfTI headers as real exports write them, made with nibabel: an sform of unit spacing beside
//! a `pixdim` (and qform) of 1.56 × 1.56 × 10 mm is read with the sform and a warning naming
//! both, and `--header-spacing` picks the other; a 4D label map's `toffset` places its frames
//! (trigger times in ms), in training input and in a reference grid alike, and its unit is the
//! input's time unit.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, Once};

use dynaslice_data::input::time_unit_of;
use dynaslice_data::input_spec::InputSpec;
use dynaslice_data::nifti::{read_geometry, read_labelled_volume_with, HeaderSpacing};
use dynaslice_data::{ErrorKind, TimeUnit};
use dynaslice_test_support::python::run_python;

/// Warnings logged by the readers (filtered by file name: tests run in parallel).
static LOGS: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        if record.level() <= log::Level::Warn {
            LOGS.lock().unwrap().push(record.args().to_string());
        }
    }
    fn flush(&self) {}
}

fn capture() {
    static INIT: Once = Once::new();
    INIT.call_once(|| {
        log::set_logger(&Capture).unwrap();
        log::set_max_level(log::LevelFilter::Warn);
    });
}

fn warnings_about(file: &Path) -> Vec<String> {
    let name = file.display().to_string();
    LOGS.lock()
        .unwrap()
        .iter()
        .filter(|m| m.contains(&name))
        .cloned()
        .collect()
}

/// Writes, in argv[1]: `disagree.nii.gz` (sform identity, code 1; qform and pixdim 1.56 × 1.56
/// × 10, code 1; RAS axes), `sform_only.nii.gz` (the same without a qform: qform_code 0),
/// `qform_only.nii.gz` (sform_code 0) and `phases.nii.gz` (two frames of a disc, toffset
/// 287.7, pixdim[4] 422: trigger times 287.7 and 709.7 ms).
const HEADERS: &str = r#"
import sys, os
import numpy as np, nibabel as nib
out = sys.argv[1]
lab = np.zeros((12, 12, 4), np.uint8)
yy, xx = np.mgrid[:12, :12]
for k in range(4):
    lab[:, :, k][(xx - 6) ** 2 + (yy - 6) ** 2 <= 12] = 1
q = np.diag([1.56, 1.56, 10.0, 1.0]); q[:3, 3] = [-9.0, -9.0, -15.0]
s = np.eye(4); s[:3, 3] = [-9.0, -9.0, -15.0]
def save(name, sform, qform):
    img = nib.Nifti1Image(lab, None)
    img.header.set_qform(q, code=1 if qform else 0)
    img.header.set_sform(s, code=1 if sform else 0)
    img.header.set_zooms((1.56, 1.56, 10.0))
    nib.save(img, os.path.join(out, name))
save("disagree.nii.gz", True, True)
save("sform_only.nii.gz", True, False)
save("qform_only.nii.gz", False, True)
four = np.stack([lab, lab], axis=-1)
four[:, :, :, 1][(xx - 6) ** 2 + (yy - 6) ** 2 > 6] = 0
img = nib.Nifti1Image(four, q)
img.header.set_xyzt_units("mm", "msec")
img.header["pixdim"][4] = 422.0
img.header["toffset"] = 287.7
nib.save(img, os.path.join(out, "phases.nii.gz"))
h = nib.load(os.path.join(out, "disagree.nii.gz")).header
print(h["sform_code"], h["qform_code"], list(h["pixdim"][1:4]))
"#;

fn spacing(affine: &[[f64; 4]; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|r| affine[r][i].powi(2)).sum::<f64>().sqrt())
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() < 1e-5 * b[i])
}

fn files() -> Option<(tempfile::TempDir, PathBuf)> {
    let dir = tempfile::tempdir().unwrap();
    let out = run_python(&["nibabel", "numpy"], HEADERS, &[dir.path()])?;
    assert!(out.starts_with("1 1 "), "nibabel wrote {out}");
    let path = dir.path().to_path_buf();
    Some((dir, path))
}

#[test]
fn an_sform_that_disagrees_with_pixdim_is_used_with_a_warning_naming_both() {
    capture();
    let Some((_dir, at)) = files() else { return };
    let disagree = at.join("disagree.nii.gz");
    let volume = read_labelled_volume_with(&disagree, HeaderSpacing::Auto)
        .unwrap()
        .volume;
    assert!(close(spacing(&volume.affine), [1.0, 1.0, 1.0]));
    let warned = warnings_about(&disagree);
    assert_eq!(warned.len(), 1, "{warned:?}");
    let w = &warned[0];
    for part in [
        "sform (sform_code 1)",
        "1 × 1 × 1",
        "pixdim says 1.56 × 1.56 × 10",
        "using the sform",
        "--header-spacing pixdim",
        "--header-spacing qform",
    ] {
        assert!(w.contains(part), "{part:?} missing from: {w}");
    }
    // pixdim: the sform's orientation and origin, pixdim's spacing.
    let volume = read_labelled_volume_with(&disagree, HeaderSpacing::Pixdim)
        .unwrap()
        .volume;
    assert!(close(spacing(&volume.affine), [1.56, 1.56, 10.0]));
    assert_eq!(volume.affine[2][3], -15.0);
    let volume = read_labelled_volume_with(&disagree, HeaderSpacing::Qform)
        .unwrap()
        .volume;
    assert!(close(spacing(&volume.affine), [1.56, 1.56, 10.0]));
    let volume = read_labelled_volume_with(&disagree, HeaderSpacing::Sform)
        .unwrap()
        .volume;
    assert!(close(spacing(&volume.affine), [1.0, 1.0, 1.0]));
    // Through the input options, as `--header-spacing pixdim` gives them: 10 mm planes.
    let spec = InputSpec {
        inputs: vec![disagree.clone()],
        header_spacing: Some(HeaderSpacing::Pixdim),
        planes: Some("slices".parse().unwrap()),
        ..InputSpec::default()
    };
    let seq = spec.read().unwrap();
    let z: Vec<f64> = seq.frames()[0].planes.iter().map(|p| p.origin[2]).collect();
    assert!((z[1] - z[0] - 10.0).abs() < 1e-4, "{z:?}");
    // Without a qform the warning does not offer one; an absent form cannot be chosen.
    let sform_only = at.join("sform_only.nii.gz");
    read_labelled_volume_with(&sform_only, HeaderSpacing::Auto).unwrap();
    let w = warnings_about(&sform_only);
    assert!(
        w.len() == 1 && w[0].contains("qform_code is 0") && !w[0].contains("qform uses"),
        "{w:?}"
    );
    let e = read_labelled_volume_with(&sform_only, HeaderSpacing::Qform).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::Nifti(ref m) if m.contains("no qform")),
        "{e}"
    );
    let qform_only = at.join("qform_only.nii.gz");
    let volume = read_labelled_volume_with(&qform_only, HeaderSpacing::Auto)
        .unwrap()
        .volume;
    assert!(close(spacing(&volume.affine), [1.56, 1.56, 10.0]));
    assert!(warnings_about(&qform_only).is_empty());
    let e = read_labelled_volume_with(&qform_only, HeaderSpacing::Sform).unwrap_err();
    assert!(e.to_string().contains("no sform"), "{e}");
    assert_eq!("pixdim".parse::<HeaderSpacing>(), Ok(HeaderSpacing::Pixdim));
    assert!("best"
        .parse::<HeaderSpacing>()
        .unwrap_err()
        .contains("sform"));
}

#[test]
fn toffset_places_a_label_map_s_frames_in_training_and_as_a_reference() {
    let Some((_dir, at)) = files() else { return };
    let phases = at.join("phases.nii.gz");
    let g = read_geometry(&phases).unwrap();
    assert_eq!(g.frames, 2);
    assert!((g.time_origin - 287.7).abs() < 1e-4, "{}", g.time_origin);
    assert_eq!(g.frame_interval, 422.0);
    let spec = InputSpec {
        inputs: vec![phases.clone()],
        planes: Some("slices".parse().unwrap()),
        ..InputSpec::default()
    };
    // The unit the header states (xyzt_units: msec) is the one the model will record; a
    // manifest's times are its own.
    assert_eq!(spec.time_unit().unwrap(), TimeUnit::Milliseconds);
    let manifest = at.join("phases.seq");
    std::fs::write(&manifest, format!("0 {}\n", phases.display())).unwrap();
    assert_eq!(time_unit_of(&[manifest]).unwrap(), TimeUnit::Manifest);
    let times: Vec<f64> = spec
        .read()
        .unwrap()
        .frames()
        .iter()
        .map(|f| f.time)
        .collect();
    assert!(
        (times[0] - 287.7).abs() < 1e-4 && (times[1] - 709.7).abs() < 1e-4,
        "{times:?}"
    );
}
