//! The one input entry point: kinds by file name, `.seq` manifests of single-timestep inputs of
//! any kind, and several inputs as views of one subject.

use std::path::{Path, PathBuf};

use dynaslice_data::input::{read, InputOptions};
use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti::write_volume;
use dynaslice_data::LabelTable;
use dynaslice_test_support::fixtures::write_sequence;

/// A ball of label `label` (radius 5 + frame voxels) at voxel centre `c` of a 24³ volume with
/// 1 mm voxels, `frames` frames `interval` apart.
fn ball(label: i32, c: [f64; 3], frames: usize, interval: f64) -> LabelVolume {
    let n = 24;
    let mut labels = Vec::with_capacity(n * n * n * frames);
    for f in 0..frames {
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let d = [i as f64 - c[0], j as f64 - c[1], k as f64 - c[2]];
                    let inside = d.iter().map(|x| x * x).sum::<f64>().sqrt() < 5.0 + f as f64;
                    labels.push(if inside { label } else { 0 });
                }
            }
        }
    }
    LabelVolume {
        dims: [n; 3],
        frames,
        affine: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
        frame_interval: interval,
        labels,
    }
}

fn write(dir: &Path, name: &str, v: &LabelVolume) -> PathBuf {
    let p = dir.join(name);
    write_volume(v, &p).unwrap();
    p
}

#[test]
fn seq_manifest_mixes_kinds_and_cslseq_is_an_alias() {
    let dir = tempfile::tempdir().unwrap();
    // The ball .csl sequence (3 timesteps), read through its `.cslseq` and a `.seq` copy.
    let cslseq = write_sequence(dir.path());
    let seq = read(std::slice::from_ref(&cslseq), &InputOptions::default()).unwrap();
    assert_eq!(seq.frames().len(), 3);
    let as_seq = dir.path().join("ball.seq");
    std::fs::copy(&cslseq, &as_seq).unwrap();
    assert_eq!(read(&[as_seq], &InputOptions::default()).unwrap(), seq);

    // A manifest of a .csl timestep and a 3D label map timestep: their unnamed "label 1"
    // classes are unrelated (two classes) unless the user names them.
    write(
        dir.path(),
        "ball3d.nii.gz",
        &ball(1, [12.0, 12.0, 12.0], 1, 1.0),
    );
    let mixed = dir.path().join("mixed.seq");
    std::fs::write(&mixed, "# two kinds\n0 ball_0.csl\n2.5 ball3d.nii.gz\n").unwrap();
    let seq = read(std::slice::from_ref(&mixed), &InputOptions::default()).unwrap();
    let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["label 1", "label 1 (ball3d.nii.gz)"]);
    let mut named = InputOptions::default();
    named.table.insert(1, "ball");
    let seq = read(&[mixed], &named).unwrap();
    assert_eq!(seq.classes().len(), 1);
    assert_eq!(seq.classes()[0].name, "ball");
    let times: Vec<f64> = seq.frames().iter().map(|f| f.time).collect();
    assert_eq!(times, [0.0, 2.5]);

    // Phases of one label-map series: their unnamed label 1 is one class.
    write(
        dir.path(),
        "ball3d_b.nii.gz",
        &ball(1, [12.0, 12.0, 12.0], 1, 1.0),
    );
    let phases = dir.path().join("phases.seq");
    std::fs::write(&phases, "0 ball3d.nii.gz\n1 ball3d_b.nii.gz\n").unwrap();
    let seq = read(&[phases], &InputOptions::default()).unwrap();
    assert_eq!(seq.classes().len(), 1);
    assert_eq!(seq.classes()[0].name, "label 1");
}

#[test]
fn manifest_errors_name_the_manifest_line_or_the_entry() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path());
    write(dir.path(), "cine.nii.gz", &ball(1, [12.0; 3], 2, 0.5));
    let m = dir.path().join("m.seq");
    let cases = [
        (
            "0 ball_0.csl\n1 cine.nii.gz\n",
            "cine.nii.gz holds 2 timesteps",
        ),
        ("0 ball_0.csl\n1 m.seq\n", "cannot list a manifest"),
        (
            "0 ball_0.csl\n1 notes.txt\n",
            "not a kind of input DynaSlice reads",
        ),
        // An entry that cannot be opened: the manifest's line and the entry.
        ("0 ball_0.csl\n1 gone.csl\n", "m.seq, line 2: "),
        (
            "0 ball_0.csl\n1 gone.csl\n",
            "gone.csl: i/o error: No such file",
        ),
        ("0 ball_0.csl\n1 .\n", "m.seq, line 2: "),
        (
            "1 ball_0.csl\n0 ball_1.csl\n",
            "earlier than the previous entry",
        ),
    ];
    for (text, what) in cases {
        std::fs::write(&m, text).unwrap();
        let e = read(std::slice::from_ref(&m), &InputOptions::default()).unwrap_err();
        let message = e.to_string();
        assert!(message.contains(what), "{text:?}: {message}");
        assert!(
            message.contains("m.seq") || message.contains("gone.csl"),
            "{text:?}: {message}"
        );
    }
}

#[test]
fn several_images_are_views_with_union_absence() {
    let dir = tempfile::tempdir().unwrap();
    // Two 2-frame images of one subject: one segments label 1, the other label 2 elsewhere.
    let a = write(dir.path(), "a.nii.gz", &ball(1, [8.0, 12.0, 12.0], 2, 0.5));
    let b = write(dir.path(), "b.nii.gz", &ball(2, [16.0, 12.0, 12.0], 2, 0.5));
    let mut options = InputOptions::default();
    options.table.insert(1, "LV");
    options.table.insert(2, "RV");
    let seq = read(&[a.clone(), b.clone()], &options).unwrap();
    let names: Vec<&str> = seq.classes().iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["LV", "RV"]);
    assert_eq!(seq.frames().len(), 2);
    // Every plane annotates both classes; a's planes say RV is absent.
    let alone = read(std::slice::from_ref(&a), &options).unwrap();
    let a_planes = alone.frames()[0].planes.len();
    for (p, plane) in seq.frames()[0].planes.iter().enumerate() {
        assert!(plane.annotation(0).is_some() && plane.annotation(1).is_some());
        if p < a_planes {
            assert!(plane.annotation(1).unwrap().is_absent(), "plane {p}");
        }
    }

    // A different time grid is refused, naming both files and both grids.
    let c = write(
        dir.path(),
        "c.nii.gz",
        &ball(2, [16.0, 12.0, 12.0], 2, 0.04),
    );
    let e = read(&[a.clone(), c], &options).unwrap_err().to_string();
    assert!(
        e.contains("c.nii.gz") && e.contains("a.nii.gz") && e.contains("every 0.04"),
        "{e}"
    );
    let d = write(dir.path(), "d.nii.gz", &ball(2, [16.0, 12.0, 12.0], 3, 0.5));
    let e = read(&[a, d], &options).unwrap_err().to_string();
    assert!(e.contains("3 frames") && e.contains("2 frames"), "{e}");
}

#[test]
fn label_table_names_and_colours_reach_the_classes() {
    let dir = tempfile::tempdir().unwrap();
    let a = write(dir.path(), "a.nii.gz", &ball(4, [12.0; 3], 1, 1.0));
    let mut table = LabelTable::default();
    table.insert(4, "liver");
    table.insert_color(4, [221, 130, 101]);
    let options = InputOptions {
        table,
        ..InputOptions::default()
    };
    let seq = read(&[a], &options).unwrap();
    assert_eq!(seq.classes()[0].name, "liver");
    assert_eq!(seq.classes()[0].color, Some([221, 130, 101]));
}

#[test]
fn options_no_input_reads_are_refused_by_name() {
    use dynaslice_data::input_spec::InputSpec;
    let dir = tempfile::tempdir().unwrap();
    // A .csl manifest: no label map, no RT Structure Set.
    let cslseq = write_sequence(dir.path());
    let spec = |f: &dyn Fn(&mut InputSpec)| {
        let mut s = InputSpec {
            inputs: vec![cslseq.clone()],
            ..InputSpec::default()
        };
        f(&mut s);
        s
    };
    assert_eq!(spec(&|_| {}).read().unwrap().frames().len(), 3);
    for (option, set) in [
        (
            "--labels",
            &(|s: &mut InputSpec| s.labels = Some(vec![1])) as &dyn Fn(&mut InputSpec),
        ),
        ("--rotated-planes", &|s| s.rotated_planes = Some(4)),
        ("--pixel", &|s| s.pixel = Some(0.5)),
        ("--roi-extent", &|s| {
            s.roi_extent = Some("own".parse().unwrap())
        }),
    ] {
        let err = spec(set).read().unwrap_err().to_string();
        assert!(
            err.contains(option) && err.contains("ball.cslseq") && err.contains("leave it out"),
            "{option}: {err}"
        );
    }
    // A manifest listing a label map takes the label-map options.
    let nifti = write(
        dir.path(),
        "ball.nii.gz",
        &ball(1, [12.0, 12.0, 12.0], 1, 1.0),
    );
    let manifest = dir.path().join("mixed.seq");
    std::fs::write(&manifest, format!("0 {}\n", nifti.display())).unwrap();
    let s = InputSpec {
        inputs: vec![manifest],
        labels: Some(vec![1]),
        ..InputSpec::default()
    };
    assert_eq!(s.read().unwrap().classes().len(), 1);
}
