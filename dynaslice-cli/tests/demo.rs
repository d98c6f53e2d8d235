//! `dynaslice demo` end to end at a tiny size: every output it promises exists and is valid.

use dynaslice_core::ModelBytes;
use dynaslice_data::nifti::read_volume;
use std::process::Command;

/// The demo at a tiny size (`steps` training steps) into `out`.
fn demo(out: &std::path::Path, steps: &str) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args([
            "demo",
            "-o",
            out.to_str().unwrap(),
            "--steps",
            steps,
            "--resolution",
            "16",
            "--widths",
            "16,16",
            "--samples",
            "2000",
        ])
        .output()
        .unwrap()
}

#[test]
fn demo_writes_model_meshes_series_labels_and_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let run = demo(&out, "3");
    let log = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{log}");
    for line in [
        "$ dynaslice synth",
        "$ dynaslice train",
        "$ dynaslice mesh",
        "$ dynaslice labels",
        "$ dynaslice eval volume",
        "$ dynaslice eval synthetic",
        "$ dynaslice picture",
        "$ dynaslice picture --3d",
    ] {
        assert!(log.contains(line), "the demo echoes {line:?}");
    }
    let bytes = ModelBytes::read(&out.join("model.dsm")).unwrap();
    let model = bytes.model().unwrap();
    assert_eq!(model.num_classes(), 3, "the chambers: three classes");
    let pvd = std::fs::read_to_string(out.join("meshes/series.pvd")).unwrap();
    assert_eq!(
        pvd.matches("<DataSet").count(),
        37 * 3,
        "37 frames × 3 classes"
    );
    // The label volume lies on the ground truth's grid, all 37 frames, with the chambers'
    // source labels (a 3-step model still labels something somewhere, but only labels 0..=3).
    let truth = read_volume(&out.join("data/chambers/truth.nii.gz")).unwrap();
    let labels = read_volume(&out.join("labels.nii.gz")).unwrap();
    assert_eq!((labels.dims, labels.frames), (truth.dims, 37));
    assert_eq!(labels.affine, truth.affine);
    assert!(labels.labels.iter().all(|l| (0..=3).contains(l)));
    // One volume row per frame, one column per class.
    let volumes = std::fs::read_to_string(out.join("volumes.csv")).unwrap();
    let rows: Vec<&str> = volumes.lines().collect();
    assert_eq!(rows.len(), 38, "header + 37 frames");
    assert_eq!(rows[1].split(',').count(), 4, "time + 3 classes");
    // The metrics: printed as a table, and per frame in the CSV.
    let stdout = String::from_utf8_lossy(&run.stdout);
    for row in ["| all frames |", "| annotated |", "| unannotated |"] {
        assert!(stdout.contains(row), "the demo prints {row:?}:\n{stdout}");
    }
    let metrics = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    assert_eq!(metrics.lines().count(), 38);
    assert!(
        log.contains(&format!("wrote {}", out.join("surfaces.png").display())),
        "the demo prints where the 3D picture went"
    );
    for png in [
        "figure.png",
        "surfaces.png",
        "model.dsm.loss.png",
        "volumes.png",
    ] {
        assert_eq!(
            &std::fs::read(out.join(png)).unwrap()[1..4],
            b"PNG",
            "{png}"
        );
    }
    // A second run into the folder the first made (and marked) replaces its outputs.
    let model = std::fs::read(out.join("model.dsm")).unwrap();
    let again = demo(&out, "4");
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_ne!(std::fs::read(out.join("model.dsm")).unwrap(), model);
}

/// Issue 37: the demo never writes into a folder of the user's that holds files (it passed
/// --force to its subcommands, replacing a user's model.dsm and labels.nii.gz in `-o .`).
#[test]
fn demo_refuses_a_users_folder_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mine = dir.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("model.dsm"), b"the user's model").unwrap();
    std::fs::write(mine.join("labels.nii.gz"), b"the user's labels").unwrap();
    let run = demo(&mine, "3");
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("labels.nii.gz") && err.contains("--force"),
        "{err}"
    );
    assert!(!err.contains("$ dynaslice synth"), "the demo ran: {err}");
    let mut left: Vec<_> = std::fs::read_dir(&mine)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["labels.nii.gz", "model.dsm"]);
    assert_eq!(
        std::fs::read(mine.join("model.dsm")).unwrap(),
        b"the user's model"
    );
}
