//! `dynaslice mesh --times` on a motion model: one vertex set per class carried through the
//! series, with a `displacement` point array (docs/meshing.md, "Motion models"), read back by
//! the users' libraries: trimesh (watertight at every time, the same faces), VTK (the first
//! mesh warped by `vtkWarpVector` with the displacement at t is the mesh at t). On a hand-made
//! motion model with a known translation, and on a motion model trained in a few seconds, where
//! each time is either carried (and then all of the above holds) or marched and said so.

mod common;

use common::{succeeded, train_command};
use dynaslice_test_support::fixtures::write_ball_sequence;
use dynaslice_test_support::python::read_vtp_series;
use dynaslice_test_support::spheres::{translated, translation_x, Sphere};
use std::path::Path;
use std::process::Command;

fn mesh_series(model: &Path, out: &Path, extra: &[&str]) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .arg("mesh")
        .arg(model)
        .args(["--times", "0:2:5", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    succeeded(&output);
    String::from_utf8(output.stderr).unwrap()
}

#[test]
fn a_known_translation_is_carried_through_the_series_in_lps() {
    let dir = tempfile::tempdir().unwrap();
    let a = 0.2;
    let spheres = [
        Sphere::new([0.1, -0.05, 0.02], 0.3, 0.0),
        Sphere::new([-0.45, 0.3, 0.0], 0.2, 0.01),
    ];
    let model = dir.path().join("moving.dsm");
    let writer = translated(&spheres, &[("ball", 1), ("small ball", 2)], a);
    std::fs::write(&model, writer.to_bytes()).unwrap();
    let series = dir.path().join("series");
    let log = mesh_series(&model, &series, &["--resolution", "48", "--space", "lps"]);
    assert_eq!(
        log.matches("carried 2 of 2 classes").count(),
        4,
        "every later time carried: {log}"
    );
    assert!(!log.contains("not carried"), "{log}");
    let Some(rows) = read_vtp_series(&series) else {
        return;
    };
    assert_eq!(rows.len(), 10, "{rows:?}");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[2..4], ["True", "True"], "{row:?}");
        let error: f64 = row[4].parse().unwrap();
        assert!(error < 0.1, "{row:?}");
        // LPS negates x: the displacement is −translation there, as the points move.
        let t = 0.5 * (i % 5) as f64;
        let dx: f64 = row[5].parse().unwrap();
        let want = -translation_x(a, t);
        assert!((dx - want).abs() < 0.05, "{row:?}: {dx} vs {want}");
        if i % 5 == 4 {
            assert!(dx < -3.0, "{row:?}");
        }
    }
}

/// A motion model trained for a few seconds: whatever its motion network learnt, every time's
/// mesh is watertight, and a time is either carried (the first time's faces, a displacement
/// that warps the first mesh onto it) or marched with a line saying so and no displacement.
#[test]
fn a_trained_motion_model_writes_carried_or_marched_meshes_never_broken_ones() {
    let dir = tempfile::tempdir().unwrap();
    // A ball of radius 10 mm moving 6 mm along x per second.
    let input = write_ball_sequence(dir.path(), 0.0, 6.0);
    let model = dir.path().join("ball.dsm");
    succeeded(
        &train_command(&input, &model, &["--motion", "--steps", "150"])
            .output()
            .unwrap(),
    );
    let series = dir.path().join("series");
    let log = mesh_series(&model, &series, &["--resolution", "32"]);
    let marched: Vec<usize> = (1..5)
        .filter(|i| {
            let t = format!("{}", 0.5 * *i as f32);
            log.contains(&format!("not carried to t = {t}:"))
        })
        .collect();
    let carried = log.matches("carried 1 of 1 classes").count();
    assert_eq!(carried + marched.len(), 4, "{log}");
    println!("{carried} of 4 later times carried; marched: {marched:?}\n{log}");
    let Some(rows) = read_vtp_series(&series) else {
        return;
    };
    assert_eq!(rows.len(), 5, "{rows:?}");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[2], "True", "watertight: {row:?}");
        if marched.contains(&i) {
            assert_eq!(row[4], "none", "{row:?}");
        } else {
            assert_eq!(row[3], "True", "{row:?}");
            let error: f64 = row[4].parse().unwrap();
            assert!(error < 0.1, "{row:?}");
        }
    }
}
