//! `dynaslice info`'s extent check on a hand-built model of one ball (radius 10 mm at world
//! (10, −5, 2), `dynaslice_test_support::spheres`): quiet against contours that span the ball,
//! a warning naming the class and the overshoot against contours that span a small part of it,
//! and against the domain alone when no input is given.

use dynaslice_test_support::fixtures::succeeded;
use dynaslice_test_support::spheres::{self, Sphere};
use std::path::Path;
use std::process::{Command, Output};

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// A native JSON input of one class "ball": on each axial plane at height `z`, a square of
/// half-side `r` mm around (10, −5).
fn write_input(path: &Path, planes: &[(f64, f64)]) {
    let planes: Vec<String> = planes
        .iter()
        .map(|&(z, r)| {
            let (x0, x1, y0, y1) = (10.0 - r, 10.0 + r, -5.0 - r, -5.0 + r);
            format!(
                r#"{{"origin": [0.0, 0.0, {z}], "u": [1.0, 0.0, 0.0], "v": [0.0, 1.0, 0.0],
                "roi": {{"min": [-10.0, -25.0], "max": [30.0, 15.0]}},
                "annotations": [{{"class": 0, "polygons": [[[{x0}, {y0}], [{x1}, {y0}],
                [{x1}, {y1}], [{x0}, {y1}]]]}}]}}"#
            )
        })
        .collect();
    let doc = format!(
        r#"{{"format": "dynaslice-sections", "version": 1,
          "classes": [{{"name": "ball", "label": 1}}],
          "frames": [{{"time": 0.0, "planes": [{}]}}]}}"#,
        planes.join(", ")
    );
    std::fs::write(path, doc).unwrap();
}

#[test]
fn info_warns_of_a_class_far_past_its_contours() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bytes = spheres::model(&[Sphere::new([0.0; 3], 0.5, 0.0)], &[("ball", 1)]);
    std::fs::write(d.join("ball.dsm"), bytes).unwrap();
    // Contours spanning the ball (z −8 to 12, 20 mm squares): no warning.
    write_input(
        &d.join("fits.json"),
        &[(-8.0, 10.0), (2.0, 10.0), (12.0, 10.0)],
    );
    let out = run(d, &["info", "ball.dsm", "fits.json"]);
    let stdout = succeeded(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(
        stdout.contains("against their contours in fits.json") && stdout.contains("within them"),
        "{stdout}"
    );
    // One 2 mm square at the centre: the 20 mm ball reaches about 9 mm past a box whose
    // longest side is 2 mm.
    write_input(&d.join("small.json"), &[(2.0, 1.0)]);
    let out = run(d, &["info", "ball.dsm", "small.json"]);
    let stdout = succeeded(&out);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: ball.dsm: class 1 \"ball\": its surface reaches")
            && stderr.contains("past its contours' extent"),
        "{stderr}"
    );
    assert!(stdout.contains("1 warning(s)"), "{stdout}");
    // Without the input: the domain only, and the ball is well inside it.
    let out = run(d, &["info", "ball.dsm"]);
    let stdout = succeeded(&out);
    assert!(
        stdout.contains("the model's domain only") && stdout.contains("within them"),
        "{stdout}"
    );
}

/// The README's first two commands: a model trained on some labels of a label map, then `info`
/// given the same map without `--labels`. The model records how its input was read, and `info`
/// reads it the same way, with a note saying so; options given again win.
#[test]
fn info_reads_the_input_as_the_model_was_trained() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("two.dsm"),
        dynaslice_test_support::fixtures::two_organ_model(false),
    )
    .unwrap();
    // A two-label map to train on.
    succeeded(&run(
        d,
        &["labels", "two.dsm", "--spacing", "4", "-o", "seg.nii.gz"],
    ));
    succeeded(&run(
        d,
        &[
            "train",
            "seg.nii.gz",
            "--labels",
            "5",
            "--steps",
            "2",
            "--widths",
            "8,8",
            "--threads",
            "1",
            "-o",
            "one.dsm",
        ],
    ));
    let out = run(d, &["info", "one.dsm", "seg.nii.gz"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("note: reading seg.nii.gz as one.dsm was trained") && err.contains("labels=5"),
        "{err}"
    );
    let stdout = succeeded(&out);
    assert!(stdout.contains("reading = labels=5"), "{stdout}");
    // Given again otherwise, the options win: both labels do not fit the one-class model.
    let out = run(d, &["info", "one.dsm", "seg.nii.gz", "--labels", "1,5"]);
    assert!(!out.status.success());
}

/// A motion model (a version-2 file): `info` names its motion network's widths and ω_t^max
/// and counts both networks' weights, and `query` answers it like any model.
#[test]
fn info_shows_a_motion_network() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let w = dynaslice_core::format::ModelWriter::random_motion(&[16, 16], 2, &[12, 8], 3);
    std::fs::write(d.join("moving.dsm"), w.to_bytes()).unwrap();
    let out = run(d, &["info", "moving.dsm"]);
    let stdout = succeeded(&out);
    assert!(
        stdout.contains(
            "motion       sine layers [12, 8], ω_t^max 12.566371 (normalised time): \
             f = g(x + u(x, t), t)"
        ),
        "{stdout}"
    );
    assert!(stdout.contains("motion weights, f32)"), "{stdout}");
    assert!(stdout.contains("time range   0 .. 1"), "{stdout}");
    let out = run(d, &["query", "moving.dsm", "0.1", "0.2", "0.3", "0.5"]);
    succeeded(&out);
}
