//! A label map with more classes than a model holds, refused before any contour is traced
//! (issue 50): an image given where its segmentation belongs is said to look like one; a
//! segmentation of many structures gets the `--labels` hint, and with `--labels` trains.

mod common;

use common::succeeded;
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::write_volume;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// How long a refusal may take: a hang limit, not a timing (the refusal takes a fraction of a
/// second; before issue 50 these inputs took minutes).
const REFUSED_WITHIN: Duration = Duration::from_secs(10);

fn train(input: &Path, out: &Path, extra: &[&str]) -> (Output, Duration) {
    let started = Instant::now();
    let output = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .arg("train")
        .arg(input)
        .arg("-o")
        .arg(out)
        .args(["--steps", "3", "--widths", "16,16", "--threads", "2"])
        .args(["--contour-samples", "64", "--plane-samples", "64"])
        .args(["--space-samples", "64"])
        .args(extra)
        .output()
        .unwrap();
    (output, started.elapsed())
}

/// The shared TotalSegmentator map's 41 labels split at the middle of each voxel axis (+100,
/// +200, +400 on the far halves): a segmentation of over a hundred structures, in int16. Prints
/// the number of labels, then the first 40 of them, comma-separated.
const SPLIT: &str = r#"
import sys
import numpy as np, nibabel as nib
img = nib.load(sys.argv[1])
a = np.asarray(img.dataobj).astype(np.int16)
b = a.copy()
for axis, offset in ((0, 100), (1, 200), (2, 400)):
    far = np.zeros(a.shape, bool)
    index = [slice(None)] * 3
    index[axis] = slice(a.shape[axis] // 2, None)
    far[tuple(index)] = True
    b[far & (a > 0)] += offset
nib.save(nib.Nifti1Image(b, img.affine), sys.argv[2])
labels = np.unique(b[b > 0])
print(len(labels))
print(",".join(str(v) for v in labels[:40]))
"#;

#[test]
fn more_structures_than_a_model_holds_are_refused_at_once_and_trained_with_labels() {
    let Some(seg) = shared_data("nifti/example_seg.nii.gz") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let split = dir.path().join("split.nii.gz");
    let Some(printed) = run_python(&["numpy", "nibabel"], SPLIT, &[&seg, &split]) else {
        return;
    };
    let mut lines = printed.lines();
    let count: usize = lines.next().unwrap().parse().unwrap();
    let first40 = lines.next().unwrap();
    assert!(count > 64, "{count} labels");
    let model = dir.path().join("m.dsm");
    let (out, took) = train(&split, &model, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && took < REFUSED_WITHIN,
        "{took:?}: {err}"
    );
    assert!(
        err.contains(&format!("{count} distinct nonzero values (int16 voxels"))
            && err.contains("a model holds at most 64 classes")
            && err.contains("--labels"),
        "{err}"
    );
    assert!(!err.contains("image"), "{err}");
    assert!(!model.exists());
    let (out, _) = train(&split, &model, &["--labels", first40]);
    succeeded(&out);
    let info = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .arg("info")
        .arg(&model)
        .output()
        .unwrap();
    assert!(
        succeeded(&info)
            .lines()
            .any(|l| l.split_whitespace().eq(["classes", "40"])),
        "{}",
        String::from_utf8_lossy(&info.stdout)
    );
}

#[test]
fn an_image_given_for_its_label_map_is_refused_at_once_as_one() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, ny, nz) = (128, 128, 40);
    // CT-like values: -1024 to 3071, scattered as noise (the writer stores them as int16).
    let labels = (0..nx * ny * nz)
        .map(|i: usize| (i.wrapping_mul(2_654_435_761) % 4096) as i32 - 1024)
        .collect();
    let volume = LabelVolume {
        dims: [nx, ny, nz],
        frames: 1,
        affine: [
            [0.8, 0.0, 0.0, 0.0],
            [0.0, 0.8, 0.0, 0.0],
            [0.0, 0.0, 2.5, 0.0],
        ],
        frame_interval: 1.0,
        labels,
    };
    let ct = dir.path().join("ct.nii.gz");
    write_volume(&volume, &ct).unwrap();
    let model = dir.path().join("m.dsm");
    let (out, took) = train(&ct, &model, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && took < REFUSED_WITHIN,
        "{took:?}: {err}"
    );
    assert!(
        err.contains("ct.nii.gz")
            && err.contains("(int16 voxels, -1024 to 3071)")
            && err.contains("seems to be an image, not a segmentation")
            && err.contains("give its label map")
            && err.contains("--labels"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only ct.nii.gz"
    );
}
