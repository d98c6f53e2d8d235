//! `dynaslice demo` end to end at a tiny size: every output it promises exists and is valid.

use dynaslice_core::Model;
use std::process::Command;

#[test]
fn demo_writes_model_meshes_series_labels_and_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let run = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args([
            "demo",
            "-o",
            out.to_str().unwrap(),
            "--steps",
            "3",
            "--resolution",
            "16",
            "--widths",
            "16,16",
        ])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{log}");
    for line in [
        "$ dynaslice synth",
        "$ dynaslice train",
        "$ dynaslice mesh",
        "$ dynaslice picture",
    ] {
        assert!(log.contains(line), "the demo echoes {line:?}");
    }
    let bytes = dynaslice_train::model_file::read_model_bytes(&out.join("model.dsm")).unwrap();
    let model = Model::from_bytes(&bytes).unwrap();
    assert_eq!(model.num_classes(), 3, "the chambers: three classes");
    let pvd = std::fs::read_to_string(out.join("meshes/series.pvd")).unwrap();
    assert_eq!(
        pvd.matches("<DataSet").count(),
        37 * 3,
        "37 frames × 3 classes"
    );
    assert_eq!(
        &std::fs::read(out.join("figure.png")).unwrap()[1..4],
        b"PNG"
    );
    assert_eq!(
        &std::fs::read(out.join("model.dsm.loss.png")).unwrap()[1..4],
        b"PNG"
    );
}
