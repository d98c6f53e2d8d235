//! `dynaslice labels` end to end on a hand-built model of two spheres (closed-form labels):
//! a box grid, the grid of a reference image (oblique, 4D; and a real one from ../shared), the
//! colour tables and the 3D Slicer sequence beside the volume, --dense against the pruned
//! default, and the command's errors.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{Model, ModelBytes};
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::{read_volume, write_volume};
use dynaslice_sequence::palette::palette;
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
    // The per-frame files, like the volume, are replaced only with --force.
    let o = dynaslice(&args(&out).iter().map(String::as_str).collect::<Vec<_>>());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("labels_t0.seg.nrrd: the file exists"),
        "{stderr}"
    );
    let mut forced = args(&out);
    forced.push("--force".into());
    run(forced);

    // The frames as one 3D Slicer sequence: read with pynrrd (the NRRD library of Slicer's
    // Python users), a 4D volume whose list axis is the frames, with Slicer's sequence keys;
    // each frame's voxels are the NIfTI volume's.
    let sequence = dir.path().join("labels.seq.nrrd");
    let script = r#"
import sys, nrrd, numpy as np
data, h = nrrd.read(sys.argv[1])
print(data.shape, data.dtype)
print(h["kinds"], h["labels"])
print(h["DataNodeClassName"], h["axis 3 index type"], h["axis 3 index values"])
print(h["Segment0_Name"], h["Segment0_LabelValue"], h["Segment1_Name"], h["Segment1_LabelValue"])
for f in range(data.shape[3]):
    print(" ".join(str(int(v)) for v in data[:, :, :, f].ravel(order="F")))
"#;
    if let Some(text) =
        dynaslice_test_support::python::run_python(&["nrrd", "numpy"], script, &[&sequence])
    {
        let lines: Vec<&str> = text.lines().collect();
        let [nx, ny, nz] = reference.dims;
        assert_eq!(lines[0], format!("({nx}, {ny}, {nz}, 2) uint8"), "{text}");
        assert_eq!(
            lines[1],
            "['domain', 'domain', 'domain', 'list'] ['', '', '', 'time']"
        );
        assert_eq!(lines[2], "vtkMRMLLabelMapVolumeNode numeric 0 2");
        assert_eq!(lines[3], "ball 3 small ball 12");
        for f in 0..2 {
            let want: Vec<String> = reference.labels[f * voxels..(f + 1) * voxels]
                .iter()
                .map(i32::to_string)
                .collect();
            assert_eq!(lines[4 + f], want.join(" "), "frame {f}");
        }
    }
    // Our own reader takes the sequence's list axis as frames at its times, so the sequence
    // trains like the NIfTI volume.
    let (seq_volume, seq_table) = dynaslice_data::nrrd::read_volume(&sequence).unwrap();
    assert_eq!(
        (
            seq_volume.dims,
            seq_volume.frames,
            seq_volume.frame_interval
        ),
        (reference.dims, 2, 2.0)
    );
    assert_eq!(seq_volume.labels, reference.labels);
    assert_eq!(seq_table.name(12), "small ball");
}

/// A model of the two spheres whose file records colours for some classes, as a model trained
/// on an input with colours does (`class_colors` in its metadata).
fn write_coloured_model(dir: &Path, colors: &str) -> String {
    let bytes = spheres::model(&SPHERES, &[("ball", 3), ("small ball", 12)]);
    let mut writer = ModelWriter::from_model(&Model::from_bytes(&bytes).unwrap());
    writer.metadata = format!("trainer = test\nclass_colors = {colors}\n");
    let path = dir.join("coloured.dsm");
    std::fs::write(&path, writer.to_bytes()).unwrap();
    path.to_str().unwrap().to_string()
}

/// Beside a NIfTI volume, the 3D Slicer and ITK-SNAP colour tables, parsed back: every class
/// under its label with its name (Slicer's without spaces) and the colour the model records
/// (or the palette's), and the background first.
#[test]
fn colour_tables_beside_a_nifti_volume() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_coloured_model(dir.path(), "3:#e6194b");
    let out = dir.path().join("heart.nii.gz");
    let args = [
        "labels",
        &model,
        "--spacing",
        "4",
        "--times",
        "0:1:2",
        "-o",
        out.to_str().unwrap(),
    ];
    let o = dynaslice(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    for want in [
        "heart.ctbl (3D Slicer colour table)",
        "heart.label.txt (ITK-SNAP",
    ] {
        assert!(stderr.contains(want), "{want}: {stderr}");
    }
    let small = palette(1);
    assert!(stderr.contains("label 3 \"ball\" #e6194b:"), "{stderr}");
    let hex = format!("#{:02x}{:02x}{:02x}", small[0], small[1], small[2]);
    assert!(
        stderr.contains(&format!("label 12 \"small ball\" {hex}:")),
        "{stderr}"
    );
    let want = [
        (0, "Background", [0, 0, 0], 0),
        (3, "ball", [0xe6, 0x19, 0x4b], 255),
        (12, "small_ball", small, 255),
    ];

    // Slicer: `label name R G B A` after `#` comments.
    let ctbl = std::fs::read_to_string(dir.path().join("heart.ctbl")).unwrap();
    let rows: Vec<(i32, String, [u8; 3], u8)> = ctbl
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(f.len(), 6, "{l}");
            let n = |i: usize| f[i].parse::<u8>().unwrap();
            (
                f[0].parse().unwrap(),
                f[1].to_string(),
                [n(2), n(3), n(4)],
                n(5),
            )
        })
        .collect();
    let want_ctbl: Vec<(i32, String, [u8; 3], u8)> = want
        .iter()
        .map(|&(l, n, c, a)| (l, n.to_string(), c, a))
        .collect();
    assert_eq!(rows, want_ctbl, "{ctbl}");

    // ITK-SNAP: `IDX R G B A VIS MSH "LABEL"`, "Clear Label" for the background.
    let itk = std::fs::read_to_string(dir.path().join("heart.label.txt")).unwrap();
    assert!(itk.contains("# ITK-SnAP Label Description File"), "{itk}");
    let rows: Vec<(i32, String, [u8; 3], String)> = itk
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let (numbers, name) = l.split_once('"').unwrap();
            let f: Vec<&str> = numbers.split_whitespace().collect();
            assert_eq!(f.len(), 7, "{l}");
            let n = |i: usize| f[i].parse::<u8>().unwrap();
            let flags = f[4..].join(" ");
            let name = name.strip_suffix('"').unwrap().to_string();
            (f[0].parse().unwrap(), name, [n(1), n(2), n(3)], flags)
        })
        .collect();
    assert_eq!(
        rows,
        [
            (0, "Clear Label".to_string(), [0, 0, 0], "0 0 0".to_string()),
            (3, "ball".into(), [0xe6, 0x19, 0x4b], "1 1 1".into()),
            (12, "small ball".into(), small, "1 1 1".into()),
        ],
        "{itk}"
    );

    // The tables, like the volume, are replaced only with --force.
    std::fs::remove_file(&out).unwrap();
    let o = dynaslice(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && stderr.contains("heart.ctbl: the file exists"),
        "{stderr}"
    );
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(dynaslice(&forced).status.success());
}

/// The pruned evaluation (the default) writes the same volume as --dense; --safety is
/// validated.
#[test]
fn dense_and_pruned_write_identical_volumes() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let mut volumes = Vec::new();
    for (name, extra) in [
        ("pruned.nii", &[][..]),
        ("dense.nii", &["--dense"][..]),
        ("safe.nii", &["--safety", "3"][..]),
    ] {
        let out = dir.path().join(name);
        let mut args = vec![
            "labels",
            &model,
            "--bounds=-10,-25,-18,30,15,22",
            "--spacing",
            "0.5",
            "--times",
            "0:2:2",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = dynaslice(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        volumes.push(read_volume(&out).unwrap());
    }
    assert_eq!(volumes[0].labels.len(), 80 * 80 * 80 * 2);
    assert!(volumes[0].labels.contains(&3) && volumes[0].labels.contains(&12));
    assert_eq!(volumes[0], volumes[1]);
    assert_eq!(volumes[0], volumes[2]);
    let out = dir.path().join("x.nii");
    for (extra, want) in [
        (&["--safety", "0.5"][..], "--safety"),
        (&["--safety", "nan"][..], "--safety"),
        (&["--dense", "--safety", "2"][..], "cannot be used with"),
    ] {
        let mut args = vec!["labels", &model, "-o", out.to_str().unwrap()];
        args.extend(extra);
        let o = dynaslice(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && stderr.contains(want),
            "{extra:?}: {stderr}"
        );
    }
}

/// A reference whose header declares a grid far beyond memory (65535³ voxels in a 352-byte
/// file): only its header is read, so the memory check refuses it at once, rather than the
/// file being read whole (or refused for its size) first.
#[cfg(target_os = "linux")]
#[test]
fn like_checks_memory_from_the_header_alone() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let mut header = vec![0u8; 352];
    let mut put = |at: usize, bytes: &[u8]| header[at..at + bytes.len()].copy_from_slice(bytes);
    put(0, &348i32.to_le_bytes());
    for (i, d) in [3u16, 4096, 4096, 1024, 1, 1, 1, 1].iter().enumerate() {
        put(40 + 2 * i, &d.to_le_bytes());
    }
    put(70, &4i16.to_le_bytes()); // int16
    put(72, &16i16.to_le_bytes());
    for (i, p) in [1f32, 1.0, 1.0, 1.0, 0.0].iter().enumerate() {
        put(76 + 4 * i, &p.to_le_bytes());
    }
    put(108, &352f32.to_le_bytes());
    put(344, b"n+1\0");
    let reference = dir.path().join("huge.nii");
    std::fs::write(&reference, &header).unwrap();
    // A sparse file as long as the header promises (32 GiB of zeros that take no disk), so the
    // reader's check that the file holds its voxels passes and the memory check decides.
    let file = std::fs::OpenOptions::new()
        .write(true)
        .open(&reference)
        .unwrap();
    file.set_len(352 + 4096 * 4096 * 1024 * 2).unwrap();
    let out = dir.path().join("out.nii.gz");
    let start = std::time::Instant::now();
    let o = dynaslice(&[
        "labels",
        &model,
        "--like",
        reference.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success()
            && stderr.contains("4096×4096×1024 voxels needs about")
            && stderr.contains("--allow-memory"),
        "{stderr}"
    );
    assert!(start.elapsed().as_secs() < 30, "{:?}", start.elapsed());
    assert!(!out.exists());
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

/// `--like` takes an image's grid: a `.csl` or JSON of cross-sections has none, and the message
/// says what to give instead (not a NIfTI parse error); nothing is written.
#[test]
fn like_without_a_grid_says_what_to_give_instead() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path());
    let csl = dir.path().join("eight_15.csl");
    std::fs::write(&csl, "1\n").unwrap();
    let out = dir.path().join("l.nii.gz");
    let o = dynaslice(&[
        "labels",
        &model,
        "--like",
        csl.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("eight_15.csl: not a NIfTI image") && err.contains("--bounds and --spacing"),
        "{err}"
    );
    assert!(!out.exists());
}
