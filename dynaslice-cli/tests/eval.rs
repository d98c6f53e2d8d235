//! `dynaslice eval` end to end on hand-built sphere models with closed-form answers: held-out
//! slices of a .csl sequence, volumes over time, Chamfer distance to a reference STL, and the
//! synthetic benchmark's chambers at frame 0.

mod common;

use dynaslice_core::Domain;
use dynaslice_mesh::io::{write, Format, MeshInfo, Space};
use dynaslice_mesh::Mesh;
use dynaslice_test_support::spheres::{self, Sphere};
use std::path::Path;
use std::process::{Command, Output};

/// The ball of `common::write_sequence` (centre 0, radius 10 + 2t mm over t ∈ [0, 2] s) in
/// [`BALL_DOMAIN`]: R = 0.5 and r² = R² + 2RV·t/2 with V = 0.2, i.e. radius 10 mm at t = 0,
/// √(0.35)·20 ≈ 11.8 mm at t = 1 (the ball: 12).
const BALL: Sphere = Sphere {
    centre: [0.0; 3],
    radius: 0.5,
    rate: 0.2,
};

/// 20 mm about the origin, 2 s: the spheres' scales (their `world_radius` and `world_volume`
/// hold), centred on the ball.
const BALL_DOMAIN: Domain = Domain {
    center: [0.0; 3],
    scale: [20.0; 3],
    time_origin: 0.0,
    time_span: 2.0,
    output_scale: 20.0,
};

fn ball_model(spheres: &[Sphere], classes: &[(&str, i32)]) -> Vec<u8> {
    spheres::model_in(BALL_DOMAIN, spheres, classes)
}

fn dynaslice(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs `dynaslice args`, which must fail with `want` in its error output.
fn fails_with(args: &[&str], want: &str) {
    let out = dynaslice(args);
    assert!(!out.status.success(), "{args:?} succeeded");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(want), "{args:?}: {err}");
}

fn write_model(path: &Path, bytes: &[u8]) -> String {
    std::fs::write(path, bytes).unwrap();
    path.to_str().unwrap().to_string()
}

/// The IoU column of a row of `eval heldout`'s table.
fn row_mean(table: &str, row: &str) -> f64 {
    let line = table
        .lines()
        .find(|l| l.starts_with(&format!("| {row} |")))
        .unwrap_or_else(|| panic!("no row {row:?} in\n{table}"));
    line.split('|').nth(3).unwrap().trim().parse().unwrap()
}

#[test]
fn held_out_slices_of_a_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::write_sequence(dir.path());
    let input = input.to_str().unwrap();
    let train = dir.path().join("train.json");
    let split = ["--holdout-frames", "1", "--holdout-planes", "1::2"];
    let mut args = vec!["eval", "split", input];
    args.extend(split);
    args.extend(["-o", train.to_str().unwrap()]);
    let log = dynaslice(&args);
    common::succeeded(&log);
    assert!(
        String::from_utf8_lossy(&log.stderr).contains("2 of 3 frames, 6 of 15 planes"),
        "{}",
        String::from_utf8_lossy(&log.stderr)
    );
    // The workflow: train on the split's input, score on what it withheld.
    let trained = dir.path().join("trained.dsm");
    let run = common::train_command(&train, &trained, &["--steps", "30"])
        .output()
        .unwrap();
    common::succeeded(&run);
    let mut args = vec!["eval", "heldout", trained.to_str().unwrap(), input];
    args.extend(split);
    let table = common::succeeded(&dynaslice(&args));
    for row in ["spatial", "temporal", "spatio-temporal"] {
        let iou = row_mean(&table, row);
        assert!((0.0..=1.0).contains(&iou), "{row}: {iou}\n{table}");
    }
    // The exact ball scores ≈ 1 everywhere.
    let model = write_model(
        &dir.path().join("ball.dsm"),
        &ball_model(&[BALL], &[("ball", 1)]),
    );
    let mut args = vec!["eval", "heldout", model.as_str(), input];
    args.extend(split);
    args.extend(["--pixels", "200"]);
    let table = common::succeeded(&dynaslice(&args));
    // The model's radius is exact at t = 0, 4 % small at t = 2 (disc IoU ≈ 0.92 there) and
    // 1.4 % small at the withheld t = 1 (≈ 0.97).
    for row in ["spatial", "temporal", "spatio-temporal"] {
        let iou = row_mean(&table, row);
        assert!(iou > 0.9, "{row}: {iou}\n{table}");
    }
    // A model of another input is refused by name.
    let two = write_model(
        &dir.path().join("two.dsm"),
        &ball_model(&[BALL, BALL], &[("a", 1), ("b", 2)]),
    );
    let mut args = vec!["eval", "heldout", two.as_str(), input];
    args.extend(split);
    fails_with(&args, "2 classes and the input 1");
}

#[test]
fn volumes_over_time_follow_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(
        &dir.path().join("ball.dsm"),
        &ball_model(&[BALL], &[("ball", 1)]),
    );
    let csv = dir.path().join("v.csv");
    common::succeeded(&dynaslice(&[
        "eval",
        "volume",
        &model,
        "--times",
        "0:2:5",
        "--resolution",
        "64",
        "-o",
        csv.to_str().unwrap(),
    ]));
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows[0], "time,\"ball\"");
    assert_eq!(rows.len(), 6);
    for row in &rows[1..] {
        let v: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        let want = BALL.world_volume(v[0]);
        assert!(
            (v[1] - want).abs() < 0.01 * want,
            "t = {}: {} vs {want}",
            v[0],
            v[1]
        );
    }
    assert_eq!(
        &std::fs::read(csv.with_extension("png")).unwrap()[1..4],
        b"PNG"
    );
}

#[test]
fn chamfer_distance_to_a_reference_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(
        &dir.path().join("ball.dsm"),
        &ball_model(&[BALL], &[("ball", 1)]),
    );
    // The model's surface at t = 0 is the sphere of radius 10 about the origin; the reference
    // has radius 11, so both directions are 1 mm away: CD = 2·1²/D², D = 22√3.
    let stl = dir.path().join("ref.stl");
    write(
        &stl,
        &Mesh::uv_sphere([0.0; 3], 11.0, 96, 192),
        Format::Stl,
        &MeshInfo::new("ref", Space::Ras),
    )
    .unwrap();
    let out = common::succeeded(&dynaslice(&[
        "eval",
        "reference",
        &model,
        stl.to_str().unwrap(),
        "--time",
        "0",
    ]));
    let cd: f64 = out
        .split("CD×10⁴ = ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .unwrap()
        .parse()
        .unwrap();
    let want = 2.0 / (22.0f64.powi(2) * 3.0) * 1e4;
    assert!((cd - want).abs() < 0.1 * want, "{cd} vs {want}\n{out}");
    fails_with(
        &[
            "eval",
            "reference",
            &model,
            stl.to_str().unwrap(),
            "--class",
            "2",
        ],
        "--class 2 but the model has classes 1..1",
    );
}

#[test]
fn synthetic_chambers_at_their_first_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = spheres::chambers_model(dynaslice_synth::shapes::chambers(0.0), 1.0);
    let model = write_model(&dir.path().join("chambers.dsm"), &bytes);
    let csv = dir.path().join("frames.csv");
    let table = common::succeeded(&dynaslice(&[
        "eval",
        "synthetic",
        &model,
        "--shape",
        "chambers",
        "--resolution",
        "32",
        "--mesh-resolution",
        "32",
        "--truth-resolution",
        "48",
        "--samples",
        "2000",
        "--csv",
        csv.to_str().unwrap(),
    ]));
    for row in [
        "| all frames |",
        "| annotated |",
        "| unannotated |",
        "| class 3 chamber c |",
    ] {
        assert!(table.contains(row), "{row}\n{table}");
    }
    // The static spheres are the chambers at t = 0 exactly: IoU ≈ 1 at frame 0.
    let text = std::fs::read_to_string(&csv).unwrap();
    let frame0: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(&frame0[..3], &["0", "0", "true"]);
    for c in 0..3 {
        let iou: f64 = frame0[3 + 2 * c].parse().unwrap();
        assert!(iou > 0.9, "class {c}: {iou}");
    }
    let one = write_model(
        &dir.path().join("one.dsm"),
        &ball_model(&[BALL], &[("ball", 1)]),
    );
    fails_with(
        &["eval", "synthetic", &one, "--shape", "chambers"],
        "chambers has 3",
    );
}

/// Degenerate scoring sizes are refused by name instead of printing undefined scores.
#[test]
fn degenerate_sizes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(
        &dir.path().join("ball.dsm"),
        &ball_model(&[BALL], &[("ball", 1)]),
    );
    let input = common::write_sequence(dir.path());
    let cases: [(&[&str], &str); 3] = [
        (
            &[
                "eval",
                "heldout",
                &model,
                input.to_str().unwrap(),
                "--holdout-planes",
                "1::2",
                "--pixels",
                "0",
            ],
            "invalid value '0' for '--pixels <PIXELS>'",
        ),
        (
            &["eval", "reference", &model, "missing.stl", "--samples", "0"],
            "invalid value '0' for '--samples <SAMPLES>'",
        ),
        (
            &[
                "eval",
                "synthetic",
                &model,
                "--shape",
                "blob",
                "--resolution",
                "0",
            ],
            "invalid value '0' for '--resolution <RESOLUTION>'",
        ),
    ];
    for (args, want) in cases {
        fails_with(args, want);
    }
}
