//! `dynaslice labels` end to end on a hand-built model of two spheres (closed-form labels):
//! a box grid, the grid of a reference image (oblique, 4D; and a real one from ../shared), and
//! the command's errors.

use dynaslice_core::ModelBytes;
use dynaslice_data::nifti::{read_volume, write_volume, LabelVolume};
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::spheres::{self, Sphere};
use std::path::Path;
use std::process::{Command, Output};

const SPHERES: [Sphere; 2] = [
    Sphere {
        centre: [0.0; 3],
        radius: 0.5,
        rate: 0.1,
    },
    Sphere {
        centre: [0.4, 0.0, 0.0],
        radius: 0.3,
        rate: 0.0,
    },
];

fn write_model(dir: &Path) -> String {
    let path = dir.join("spheres.dsm");
    let bytes = spheres::model(&SPHERES, &[("ball", 3), ("small ball", 12)]);
    std::fs::write(&path, bytes).unwrap();
    path.to_str().unwrap().to_string()
}

fn dynaslice(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

/// Every voxel of `volume` holds the model's own Eq. 11 label at its centre, as a source value.
fn check_against_the_model(volume: &LabelVolume, model_path: &str, times: &[f64]) {
    let bytes = ModelBytes::read(Path::new(model_path)).unwrap();
    let model = bytes.model().unwrap();
    let values = [0, 3, 12];
    let [nx, ny, nz] = volume.dims;
    let mut seen = [0usize; 3];
    for (f, &t) in times.iter().enumerate() {
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let x = volume.to_world([i, j, k].map(|v| v as f64));
                    let want = model.label(x.map(|v| v as f32), t as f32) as usize;
                    let got = volume.label(i as isize, j as isize, k as isize, f);
                    assert_eq!(got, values[want], "voxel {i} {j} {k}, frame {f}");
                    seen[want] += 1;
                }
            }
        }
    }
    assert!(seen.iter().all(|&n| n > 0), "every label occurs: {seen:?}");
}

#[test]
fn box_grid_frames_and_volumes() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("labels.nii.gz");
    let o = dynaslice(&[
        "labels",
        &model,
        "--bounds=-10,-25,-18,30,15,22",
        "--spacing",
        "1",
        "--times",
        "0:2:3",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("40×40×40 voxels × 3 frame(s)"), "{stderr}");
    let v = read_volume(&out).unwrap();
    assert_eq!((v.dims, v.frames, v.frame_interval), ([40; 3], 3, 1.0));
    assert_eq!(v.to_world([0.0; 3]), [-9.5, -24.5, -17.5]);
    check_against_the_model(&v, &model, &[0.0, 1.0, 2.0]);
    // The printed volumes are voxel counts: class 1 loses the lens that the Eq. 11 partition
    // gives class 2, and grows with r(t)² = R² + 2RVt.
    let ball = |t: f64| SPHERES[0].world_volume(t);
    let first = stderr
        .lines()
        .find(|l| l.contains("label 3 \"ball\""))
        .unwrap();
    let v0: f64 = first
        .split(": ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(v0 < ball(0.0) && v0 > 0.8 * ball(0.0), "{first}");
}

/// `-o NAME.seg.nrrd`: a 3D Slicer segmentation per frame (`NAME_tF.seg.nrrd`) with the same
/// voxels and world positions as the NIfTI output, the classes as named segments; slicerio (the
/// library Slicer users script with) reads the names, label values and the LPS geometry.
#[test]
fn slicer_segmentations_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("labels.seg.nrrd");
    let args = |out: &Path| {
        vec![
            "labels".to_string(),
            model.clone(),
            "--bounds=-10,-25,-18,30,15,22".into(),
            "--spacing".into(),
            "2".into(),
            "--times".into(),
            "0:2:2".into(),
            "-o".into(),
            out.to_str().unwrap().to_string(),
        ]
    };
    let run = |a: Vec<String>| {
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let o = dynaslice(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(args(&out));
    let nifti = dir.path().join("labels.nii.gz");
    run(args(&nifti));
    let reference = read_volume(&nifti).unwrap();
    let voxels = reference.labels.len() / 2;
    for f in 0..2 {
        let frame = dir.path().join(format!("labels_t{f}.seg.nrrd"));
        let (v, table) = dynaslice_data::nrrd::read_volume(&frame).unwrap();
        assert_eq!(v.dims, reference.dims);
        assert_eq!(v.labels, reference.labels[f * voxels..(f + 1) * voxels]);
        for (r, s) in v
            .affine
            .iter()
            .flatten()
            .zip(reference.affine.iter().flatten())
        {
            assert!(
                (r - s).abs() < 1e-9,
                "{:?} vs {:?}",
                v.affine,
                reference.affine
            );
        }
        assert_eq!(
            (table.name(3), table.name(12)),
            ("ball".into(), "small ball".into())
        );
    }
    let script = r#"
import sys, slicerio
seg = slicerio.read_segmentation(sys.argv[1])
print("|".join(f"{s['name']}={s['labelValue']}" for s in seg["segments"]))
print(" ".join(f"{float(v):.3f}" for v in seg["ijkToLPS"][:3, 3]))
"#;
    let frame = dir.path().join("labels_t1.seg.nrrd");
    if let Some(text) = dynaslice_test_support::python::run_python(&["slicerio"], script, &[&frame])
    {
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "ball=3|small ball=12", "{text}");
        // Voxel (0,0,0) at RAS (-9, -24, -17) is LPS (9, 24, -17).
        assert_eq!(lines[1], "9.000 24.000 -17.000", "{text}");
    }
}

#[test]
fn reference_grid_is_copied_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let (s, c) = 0.5f64.sin_cos();
    let reference = LabelVolume {
        dims: [30, 24, 20],
        frames: 2,
        // Rotated about z, anisotropic, around the model's domain.
        affine: [
            [1.4 * c, -1.4 * s, 0.0, 0.0],
            [1.4 * s, 1.4 * c, 0.0, -28.0],
            [0.0, 0.0, 2.0, -17.0],
        ],
        frame_interval: 2.0,
        labels: vec![1; 30 * 24 * 20 * 2],
    };
    let ref_path = dir.path().join("ref.nii.gz");
    write_volume(&reference, &ref_path).unwrap();
    let out = dir.path().join("labels.nii");
    let o = dynaslice(&[
        "labels",
        &model,
        "--like",
        ref_path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v = read_volume(&out).unwrap();
    let r = read_volume(&ref_path).unwrap();
    assert_eq!((v.dims, v.frames, v.frame_interval), (r.dims, 2, 2.0));
    assert_eq!(v.affine, r.affine, "the same f32 sform");
    check_against_the_model(&v, &model, &[0.0, 2.0]);
}

/// A real segmentation's grid (122×101×30, 3 mm): only its geometry is used.
#[test]
fn real_reference_from_shared_data() {
    let Some(path) = shared_data("nifti/example_seg.nii.gz") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("seg_labels.nii.gz");
    let o = dynaslice(&[
        "labels",
        &model,
        "--like",
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (v, r) = (read_volume(&out).unwrap(), read_volume(&path).unwrap());
    assert_eq!((v.dims, v.frames), (r.dims, r.frames));
    assert_eq!(v.affine, r.affine);
}

#[test]
fn errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let out = dir.path().join("x.nii.gz");
    let out = out.to_str().unwrap();
    let missing = dir.path().join("missing.nii.gz");
    let cases: [(Vec<&str>, &str); 6] = [
        (
            vec!["labels", &model, "--bounds", "0,0,0,1,1", "-o", out],
            "6 values",
        ),
        (
            vec!["labels", &model, "-o", "x.png"],
            "-o x.png: a label volume must be named *.nii or *.nii.gz",
        ),
        (
            vec![
                "labels",
                &model,
                "--like",
                missing.to_str().unwrap(),
                "-o",
                out,
            ],
            "missing.nii.gz",
        ),
        (
            vec!["labels", &model, "--spacing", "1,2", "-o", out],
            "1 or 3 values",
        ),
        (
            vec!["labels", &model, "--times", "0:1:0", "-o", out],
            "count \"0\"",
        ),
        (
            vec!["labels", "nope.dsm", "-o", out],
            "cannot read model nope.dsm",
        ),
    ];
    for (args, want) in cases {
        let o = dynaslice(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && stderr.contains(want),
            "{args:?}: {stderr}"
        );
    }
    assert!(!Path::new(out).exists());
}
