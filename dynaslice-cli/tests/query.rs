//! `dynaslice info` and `dynaslice query` on a model the test writes, and their errors.

use dynaslice_core::ModelBytes;
use dynaslice_test_support::fixtures::two_organ_model;
use std::process::Command;

fn dynaslice(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .expect("run dynaslice");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn info_and_query_report_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.dsm");
    let bytes = two_organ_model(true);
    std::fs::write(&path, &bytes).unwrap();
    let p = path.to_str().unwrap();

    let (ok, out, _) = dynaslice(&["info", p]);
    assert!(ok);
    assert!(
        out.contains("\"liver\" (source label 5)") && out.contains("[16, 16]"),
        "{out}"
    );

    let (ok, out, err) = dynaslice(&["query", p, "12.5", "-3", "0", "0.4"]);
    assert!(ok, "{err}");
    let aligned = ModelBytes::copy_from(&bytes);
    let model = aligned.model().unwrap();
    let mut f = [0.0; 2];
    model.eval([12.5, -3.0, 0.0], 0.4, &mut f).unwrap();
    let line = out.lines().find(|l| l.contains("liver")).unwrap();
    let printed: f32 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    assert!((printed - f[0]).abs() < 1e-5, "{printed} vs {}", f[0]);
    assert!(out.contains(&format!("label {}", model.label([12.5, -3.0, 0.0], 0.4))));

    let mut corrupt = bytes.clone();
    corrupt[300] ^= 1;
    std::fs::write(&path, &corrupt).unwrap();
    let (ok, _, err) = dynaslice(&["query", p, "0", "0", "0", "0"]);
    assert!(
        !ok && err.contains("CRC mismatch") && err.contains("m.dsm"),
        "{err}"
    );
    let (ok, _, err) = dynaslice(&["info", dir.path().join("missing.dsm").to_str().unwrap()]);
    assert!(
        !ok && err.contains("cannot read model") && err.contains("missing.dsm"),
        "{err}"
    );
}

#[test]
fn query_prints_a_motion_models_displacement_and_no_other_models() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("motion.dsm");
    let bytes = dynaslice_core::format::ModelWriter::random_motion(&[16, 16], 2, &[8], 7)
        .try_to_bytes()
        .unwrap();
    std::fs::write(&path, &bytes).unwrap();
    let (ok, out, err) = dynaslice(&["query", path.to_str().unwrap(), "0.2", "-0.1", "0.3", "0.4"]);
    assert!(ok, "{err}");
    let aligned = ModelBytes::copy_from(&bytes);
    let model = aligned.model().unwrap();
    let u = model.displacement([0.2, -0.1, 0.3], 0.4).unwrap();
    assert!(u.iter().any(|v| v.abs() > 1e-4), "a moving fixture: {u:?}");
    let line = out
        .lines()
        .find(|l| l.starts_with("displacement"))
        .expect(&out);
    let printed: Vec<f32> = line
        .split_whitespace()
        .skip(1)
        .take(3)
        .map(|v| v.parse().unwrap())
        .collect();
    for (p, v) in printed.iter().zip(u) {
        assert!((p - v).abs() < 1e-5, "{printed:?} vs {u:?}");
    }

    let still = dir.path().join("still.dsm");
    std::fs::write(&still, two_organ_model(true)).unwrap();
    let (ok, out, err) = dynaslice(&["query", still.to_str().unwrap(), "0", "0", "0", "0.4"]);
    assert!(ok && !out.contains("displacement"), "{err}{out}");
}
