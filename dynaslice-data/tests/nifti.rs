//! NIfTI label volumes: exact round trip, world coordinates from sform/qform, the reslicing
//! protocol on analytic shapes, frame/label selection, and every malformed-input error.

use std::path::{Path, PathBuf};

use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::{read, read_volume, write_volume};
use dynaslice_data::reslice::{reslice, ResliceOptions};
use dynaslice_data::{ErrorKind, LabelTable};
use dynaslice_geometry::polygon::signed_area;
use dynaslice_test_support::fixtures::shared_data;
use dynaslice_test_support::python::run_python;
use nifti::NiftiHeader;

/// Anisotropic voxels, rotated 90° about z and shifted: exercises the affine end to end.
const AFFINE: [[f64; 4]; 3] = [
    [0.0, -1.5, 0.0, 10.0],
    [1.0, 0.0, 0.0, -20.0],
    [0.0, 0.0, 2.0, 5.0],
];

/// Three frames: a ball (label 3) whose radius grows, and a ring (label 5, with a hole) beside it.
fn volume() -> LabelVolume {
    let dims = [40, 30, 20];
    let mut labels = Vec::new();
    for f in 0..3 {
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    // World offsets from the ball centre, in millimetres.
                    let w = [
                        (j as f64 - 12.0) * 1.5,
                        (i as f64 - 12.0),
                        (k as f64 - 10.0) * 2.0,
                    ];
                    let r = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
                    let ring = (
                        (i as f64 - 31.0).hypot(j as f64 - 15.0),
                        (k as f64 - 10.0).abs(),
                    );
                    labels.push(if r < 6.0 + f as f64 {
                        3
                    } else if (3.0..7.0).contains(&ring.0) && ring.1 < 4.0 {
                        5
                    } else {
                        0
                    });
                }
            }
        }
    }
    LabelVolume {
        dims,
        frames: 3,
        affine: AFFINE,
        frame_interval: 0.5,
        labels,
    }
}

#[test]
fn round_trips_exactly_plain_and_gzipped() {
    let dir = tempfile::tempdir().unwrap();
    let v = volume();
    for name in ["v.nii", "v.nii.gz"] {
        let path = dir.path().join(name);
        write_volume(&v, &path).unwrap();
        assert_eq!(read_volume(&path).unwrap(), v, "{name}");
    }
}

#[test]
fn reslices_with_the_protocol_and_sub_voxel_contours() {
    let v = volume();
    let opts = ResliceOptions {
        rotated: 6,
        axial_step: 3,
        ..Default::default()
    };
    let names = LabelTable::parse("3 ball\n").unwrap();
    let seq = reslice(&v, &opts, &names).unwrap();
    let labels: Vec<(String, i32)> = seq
        .classes()
        .iter()
        .map(|c| (c.name.clone(), c.label))
        .collect();
    assert_eq!(labels, [("ball".into(), 3), ("label 5".into(), 5)]);
    let times: Vec<f64> = seq.frames().iter().map(|f| f.time).collect();
    assert_eq!(times, [0.0, 0.5, 1.0]);
    // 6 rotated planes, axial slices 7, 10, 13 over the labelled z range 7..=13 of ball ∪ ring.
    let frame = &seq.frames()[2];
    assert_eq!(frame.planes.len(), 6 + 3);
    let z_axis = [0.0, 0.0, 1.0];
    for (pi, plane) in frame.planes.iter().enumerate() {
        assert_eq!(
            plane.annotations.len(),
            2,
            "every plane annotates every class"
        );
        let n = plane.normal();
        let along_z = (n[0] * z_axis[0] + n[1] * z_axis[1] + n[2] * z_axis[2]).abs();
        assert!(if pi < 6 {
            along_z < 1e-9
        } else {
            (along_z - 1.0).abs() < 1e-9
        });
    }
    // Alone, the ball's labelled box is centred on it, so the rotated planes contain its centre
    // and its sections are discs of radius ≈ 8 mm in the last frame. Voxelisation blurs the
    // boundary by at most about one voxel.
    let ball_only = ResliceOptions {
        labels: Some(vec![3]),
        ..opts.clone()
    };
    let ball_seq = reslice(&v, &ball_only, &names).unwrap();
    let centre = v.to_world([12.0, 12.0, 10.0]);
    let mut checked = 0;
    for plane in &ball_seq.frames()[2].planes[..6] {
        let ball = plane.annotation(0).unwrap();
        assert_eq!(ball.polygons.len(), 1);
        assert!(signed_area(&ball.polygons[0]) > 0.0);
        for p in &ball.polygons[0] {
            let w = plane.to_world(*p);
            let r = (0..3)
                .map(|k| (w[k] - centre[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!((r - 8.0).abs() < 1.6, "radius {r}");
            checked += 1;
        }
    }
    assert!(checked > 100);
    // An axial slice through the ring shows it with its hole.
    let through_ring = frame.planes[6..]
        .iter()
        .find(|p| p.annotation(1).unwrap().polygons.len() == 2)
        .expect("an axial slice crosses the ring");
    let areas: Vec<f64> = through_ring
        .annotation(1)
        .unwrap()
        .polygons
        .iter()
        .map(|p| signed_area(p))
        .collect();
    assert!(
        areas.iter().any(|&a| a > 0.0) && areas.iter().any(|&a| a < 0.0),
        "{areas:?}"
    );
}

#[test]
fn frames_and_labels_are_selectable() {
    let v = volume();
    let opts = ResliceOptions {
        rotated: 4,
        axial_step: 0,
        frames: "1:3:2".parse().unwrap(),
        labels: Some(vec![5]),
        pixel: Some(1.0),
    };
    let seq = reslice(&v, &opts, &LabelTable::default()).unwrap();
    assert_eq!(seq.frames().len(), 1);
    assert_eq!(seq.frames()[0].time, 0.5);
    assert_eq!(seq.classes().len(), 1);
    let e = reslice(
        &v,
        &ResliceOptions {
            labels: Some(vec![5, 9]),
            ..opts.clone()
        },
        &LabelTable::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::LabelAbsent { label: 9, .. }),
        "{e}"
    );
    // The message lists the labels that are there.
    assert!(
        e.to_string()
            .contains("label 9 is absent from every selected frame; the labels there are 3, 5"),
        "{e}"
    );
    let e = reslice(
        &v,
        &ResliceOptions {
            frames: "7:9".parse().unwrap(),
            ..opts
        },
        &LabelTable::default(),
    )
    .unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Option(_)), "{e}");
}

fn write_with(
    dir: &Path,
    name: &str,
    header: &NiftiHeader,
    data: &ndarray::Array3<f32>,
) -> PathBuf {
    let path = dir.join(name);
    nifti::writer::WriterOptions::new(&path)
        .reference_header(header)
        .write_nifti(data)
        .unwrap();
    path
}

#[test]
fn malformed_volumes_are_rejected_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let data = ndarray::Array3::<f32>::zeros((4, 4, 4));
    let path = write_with(dir.path(), "float.nii", &NiftiHeader::default(), &data);
    let e = read_volume(&path).unwrap_err();
    assert!(
        e.to_string().contains("float.nii") && e.to_string().contains("not an integer"),
        "{e}"
    );

    let good = dir.path().join("good.nii.gz");
    write_volume(&volume(), &good).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.path().join("cut.nii.gz");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = read_volume(&cut).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::Nifti(_)) && e.to_string().contains("cut.nii.gz"),
        "{e}"
    );
    let plain = dir.path().join("good.nii");
    write_volume(&volume(), &plain).unwrap();
    let bytes = std::fs::read(&plain).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() - 10]).unwrap();
    assert!(matches!(
        read_volume(&cut).unwrap_err().kind,
        ErrorKind::Nifti(_)
    ));
    std::fs::write(&cut, b"not a nifti file").unwrap();
    assert!(matches!(
        read_volume(&cut).unwrap_err().kind,
        ErrorKind::Nifti(_)
    ));
    assert!(matches!(
        read_volume(&dir.path().join("none.nii")).unwrap_err().kind,
        ErrorKind::Io(_)
    ));

    let scaled = NiftiHeader {
        scl_slope: 2.0,
        ..NiftiHeader::default()
    };
    let labels = ndarray::Array3::<u8>::zeros((4, 4, 4));
    let path = dir.path().join("scaled.nii");
    nifti::writer::WriterOptions::new(&path)
        .reference_header(&scaled)
        .write_nifti(&labels)
        .unwrap();
    // The writer resets the slope; patch it in the file (offset 112, little endian).
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[112..116].copy_from_slice(&2.0f32.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    let e = read_volume(&path).unwrap_err();
    assert!(e.to_string().contains("scaling"), "{e}");

    // All background: nothing to reslice.
    let empty = LabelVolume {
        labels: vec![0; 40 * 30 * 20 * 3],
        ..volume()
    };
    let e = reslice(&empty, &ResliceOptions::default(), &LabelTable::default()).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
}

#[test]
fn qform_gives_world_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    // 90° about z: quaternion (a, b, c, d) = (cos 45°, 0, 0, sin 45°).
    let h = NiftiHeader {
        sform_code: 0,
        qform_code: 1,
        quatern_d: std::f32::consts::FRAC_1_SQRT_2,
        quatern_x: 1.0,
        quatern_y: 2.0,
        quatern_z: 3.0,
        pixdim: [1.0, 2.0, 3.0, 4.0, 0.0, 1.0, 1.0, 1.0],
        ..NiftiHeader::default()
    };
    let path = dir.path().join("q.nii");
    let labels = ndarray::Array3::<u8>::ones((2, 2, 2));
    nifti::writer::WriterOptions::new(&path)
        .reference_header(&h)
        .write_nifti(&labels)
        .unwrap();
    let v = read_volume(&path).unwrap();
    let w = v.to_world([1.0, 1.0, 1.0]);
    let want = [1.0 - 3.0, 2.0 + 2.0, 3.0 + 4.0];
    for k in 0..3 {
        assert!((w[k] - want[k]).abs() < 1e-6, "{w:?}");
    }
    assert_eq!(v.frame_interval, 1.0, "pixdim[4] = 0 means 1");
}

#[test]
fn reads_the_shared_totalsegmentator_volume() {
    let Some(path) = shared_data("nifti/example_seg.nii.gz") else {
        return;
    };
    let v = read_volume(&path).unwrap();
    assert_eq!((v.dims, v.frames), ([122, 101, 30], 1));
    let seq = read(&path, &ResliceOptions::default(), &LabelTable::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(seq.classes().len(), 41);
    // 20 rotated, 15 axial (every second of 30), and one through a label thinner than the step.
    assert_eq!(seq.frames()[0].planes.len(), 20 + 15 + 1);
}

/// nibabel, the reference NIfTI implementation of the Python imaging world, reads our files
/// with the same voxels, affine and frame interval, and we read its files (qform only, 4D,
/// int16, gzipped) with the same labels and world map.
#[test]
fn nibabel_reads_our_files_and_we_read_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let v = volume();
    let ours = dir.path().join("ours.nii.gz");
    write_volume(&v, &ours).unwrap();
    let read_ours = r#"
import sys, json, numpy as np, nibabel as nib
img = nib.load(sys.argv[1])
print(json.dumps({
    "shape": list(img.shape),
    "affine": img.affine[:3].tolist(),
    "sform_code": int(img.header["sform_code"]),
    "dt": float(img.header["pixdim"][4]),
    "labels": np.asarray(img.dataobj).ravel(order="F").astype(int).tolist(),
}))
"#;
    let Some(text) = run_python(&["nibabel"], read_ours, &[&ours]) else {
        return;
    };
    let seen: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(seen["shape"], serde_json::json!([40, 30, 20, 3]));
    assert_eq!(seen["sform_code"], 2);
    assert_eq!(seen["dt"], 0.5);
    for (r, row) in AFFINE.iter().enumerate() {
        for (c, &want) in row.iter().enumerate() {
            assert_eq!(
                seen["affine"][r][c].as_f64().unwrap(),
                want,
                "affine[{r}][{c}]"
            );
        }
    }
    let labels: Vec<i32> = serde_json::from_value(seen["labels"].clone()).unwrap();
    assert_eq!(
        labels, v.labels,
        "voxels in NIfTI order (x fastest, then y, z, t)"
    );

    // nibabel writes: a 30° rotation about z with anisotropic voxels, as the qform only.
    let theirs = dir.path().join("theirs.nii.gz");
    let write_theirs = r#"
import sys, numpy as np, nibabel as nib
c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
affine = np.array([[1.5 * c, -s, 0, 10], [1.5 * s, c, 0, -20], [0, 0, 2, 5], [0, 0, 0, 1]])
i, j, k, f = np.indices((6, 5, 4, 2))
data = ((7 * i + 3 * j + k + f) % 5).astype(np.int16)
img = nib.Nifti1Image(data, None)
img.set_qform(affine, code=1)
img.set_sform(None, code=0)
img.header.set_xyzt_units("mm", "sec")
img.header["pixdim"][4] = 0.25
nib.save(img, sys.argv[1])
"#;
    run_python(&["nibabel"], write_theirs, &[&theirs]).unwrap();
    let back = read_volume(&theirs).unwrap();
    assert_eq!((back.dims, back.frames), ([6, 5, 4], 2));
    assert_eq!(back.frame_interval, 0.25);
    let (c, s) = (
        std::f64::consts::FRAC_PI_6.cos(),
        std::f64::consts::FRAC_PI_6.sin(),
    );
    let want = [
        [1.5 * c, -s, 0.0, 10.0],
        [1.5 * s, c, 0.0, -20.0],
        [0.0, 0.0, 2.0, 5.0],
    ];
    for (r, (got, want)) in back.affine.iter().zip(&want).enumerate() {
        for (col, (g, w)) in got.iter().zip(want).enumerate() {
            // The qform stores a quaternion and offsets in f32.
            assert!((g - w).abs() < 1e-5, "affine[{r}][{col}]: {g} vs {w}");
        }
    }
    for f in 0..2 {
        for k in 0..4 {
            for j in 0..5 {
                for i in 0..6 {
                    let want = ((7 * i + 3 * j + k + f) % 5) as i32;
                    assert_eq!(back.label(i as isize, j as isize, k as isize, f), want);
                }
            }
        }
    }
}

#[test]
fn the_shared_map_names_its_classes_from_its_xml_label_table() {
    let Some(path) = shared_data("nifti/example_seg.nii.gz") else {
        eprintln!("skipped: ../shared/data/nifti/example_seg.nii.gz is absent");
        return;
    };
    let (_, table) = dynaslice_data::nifti::read_labelled_volume(&path).unwrap();
    assert_eq!(table.name(1), "spleen");
    let mut options = dynaslice_data::input::InputOptions::default();
    options.reslice.labels = Some(vec![1, 2, 3]);
    let seq = dynaslice_data::input::read(&[path], &options).unwrap();
    let classes: Vec<(&str, Option<[u8; 3]>)> = seq
        .classes()
        .iter()
        .map(|c| (c.name.as_str(), c.color))
        .collect();
    assert_eq!(
        classes,
        [
            ("spleen", Some([0, 255, 0])),
            ("kidney_right", Some([0, 0, 255])),
            ("kidney_left", Some([255, 255, 0])),
        ]
    );
}

#[test]
fn extensions_without_a_label_table_are_skipped_and_tables_beside_the_map_read() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("commented.nii.gz");
    // nibabel, as a user's script adds a comment (code 6) and an XML label table (code 0).
    let script = r#"
import sys
import numpy as np
import nibabel as nib
data = np.zeros((8, 8, 4), np.uint8)
data[2:6, 2:6, 1:3] = 4
img = nib.Nifti1Image(data, np.eye(4))
img.header.extensions.append(nib.nifti1.Nifti1Extension(6, b"made by a test"))
xml = b'<LabelTable><Label Key="4" Red="1" Green="0" Blue="0.5">liver</Label></LabelTable>'
img.header.extensions.append(nib.nifti1.Nifti1Extension(0, xml))
nib.save(img, sys.argv[1])
"#;
    if run_python(&["nibabel", "numpy"], script, &[&path]).is_none() {
        return;
    }
    let (volume, table) = dynaslice_data::nifti::read_labelled_volume(&path).unwrap();
    assert_eq!(volume.dims, [8, 8, 4]);
    assert_eq!(
        (table.name(4), table.color(4)),
        ("liver".into(), Some([255, 0, 128]))
    );
    // A Slicer colour table beside the map, under its name, wins over the file's own.
    std::fs::write(dir.path().join("commented.ctbl"), "4 hepar 1 2 3 255\n").unwrap();
    let options = dynaslice_data::input::InputOptions::default();
    let seq = dynaslice_data::input::read(&[path], &options).unwrap();
    assert_eq!(seq.classes()[0].name, "hepar");
    assert_eq!(seq.classes()[0].color, Some([1, 2, 3]));
}
