//! A static model (trained on one timestep, ω_t^max = 0) is treated as static by every command:
//! `info` shows no time axis, and `mesh`, `labels`, `eval volume` and `picture` do their work
//! once whatever times they are asked for, with a note saying why.

use dynaslice_data::nifti::read_volume;
use dynaslice_test_support::fixtures::{succeeded, two_organ_model};
use std::path::Path;
use std::process::{Command, Output};

fn run(dir: &Path, line: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(shlex::split(line).unwrap())
        .current_dir(dir)
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Writes the static and the moving two-organ model as s.dsm and m.dsm in `dir`.
fn models(dir: &Path) {
    std::fs::write(dir.join("s.dsm"), two_organ_model(false)).unwrap();
    std::fs::write(dir.join("m.dsm"), two_organ_model(true)).unwrap();
}

#[test]
fn info_shows_a_time_axis_for_moving_models_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    models(d);
    let s = succeeded(&run(d, "info s.dsm"));
    assert!(
        s.contains("static model") && !s.contains("time range"),
        "{s}"
    );
    let m = succeeded(&run(d, "info m.dsm"));
    assert!(
        m.contains("time range   0 .. 0.8") && !m.contains("static"),
        "{m}"
    );
}

#[test]
fn a_static_model_is_meshed_once_for_a_series() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    models(d);
    std::fs::create_dir(d.join("s")).unwrap();
    let out = run(d, "mesh s.dsm --times 0:1:10 --resolution 8 -o s");
    succeeded(&out);
    let err = stderr(&out);
    assert!(
        err.contains("note:") && err.contains("static") && err.contains("10 time(s) of --times"),
        "{err}"
    );
    let mut files: Vec<String> = std::fs::read_dir(d.join("s"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "class1_liver_t0000.vtp",
            "class2_spleen_t0000.vtp",
            "series.pvd"
        ],
        "{err}"
    );
    // A moving model still gets every time, and no note.
    std::fs::create_dir(d.join("m")).unwrap();
    let out = run(d, "mesh m.dsm --times 0:0.8:3 --resolution 8 -o m");
    succeeded(&out);
    assert!(!stderr(&out).contains("note:"), "{}", stderr(&out));
    assert_eq!(std::fs::read_dir(d.join("m")).unwrap().count(), 7);
}

#[test]
fn a_static_model_gets_one_label_frame_and_one_volume_row() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    models(d);
    let out = run(
        d,
        "labels s.dsm --times 0:1:5 --spacing 5 -o s.nii.gz --threads 1",
    );
    succeeded(&out);
    let err = stderr(&out);
    assert!(
        err.contains("writing one label frame, not the 5 frames"),
        "{err}"
    );
    // One volume per class, printed once (not "v at t = 0, v at t = 0").
    assert!(!err.contains("at t = 0,"), "{err}");
    let volume = read_volume(&d.join("s.nii.gz")).unwrap();
    assert_eq!(volume.frames, 1);
    // The default series of a static model is one frame too, without a note.
    let out = run(d, "labels s.dsm --spacing 5 -o d.nii.gz");
    succeeded(&out);
    assert!(!stderr(&out).contains("note:"), "{}", stderr(&out));
    assert_eq!(read_volume(&d.join("d.nii.gz")).unwrap().frames, 1);

    let out = run(
        d,
        "eval volume s.dsm --times 0:1:10 --resolution 8 -o v.csv",
    );
    succeeded(&out);
    assert!(stderr(&out).contains("measuring once"), "{}", stderr(&out));
    let csv = std::fs::read_to_string(d.join("v.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
}
