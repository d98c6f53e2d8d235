//! `dynaslice-lab torch-step --check-only` on a tiny network: PyTorch (lab/pytorch/step.py)
//! recomputes the trainer's loss terms and gradient and agrees; and the check is shown able to
//! fail, on the same files with the expected loss or gradient moved by 0.1 %.
//!
//! Needs PyTorch, which CI does not install: without `import torch` the test skips with a
//! notice, whether or not DYNASLICE_REQUIRE_PYTHON is set (that variable covers the libraries
//! CI installs, and torch is not one of them).

use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/pytorch/step.py");

fn torch_installed() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import torch"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        println!(
            "SKIPPED: `python3 -c 'import torch'` fails (pip install torch; CI does not install it)"
        );
    }
    ok
}

fn text(o: &Output) -> String {
    format!(
        "{}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `step.py check` on `path`, with `edit` applied to a copy of it first.
fn check_edited(path: &Path, edit: impl FnOnce(&mut Value)) -> Output {
    let mut v: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    edit(&mut v);
    let edited = path.with_extension("edited.json");
    std::fs::write(&edited, serde_json::to_vec(&v).unwrap()).unwrap();
    Command::new("python3")
        .args([SCRIPT, "check", edited.to_str().unwrap()])
        .output()
        .unwrap()
}

#[test]
fn pytorch_agrees_with_the_trainer_and_the_check_can_fail() {
    if !torch_installed() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for grad in ["loop", "batched"] {
        let run = Command::new(env!("CARGO_BIN_EXE_dynaslice-lab"))
            .args(["torch-step", "--check-only", "--classes", "1,3"])
            .args([
                "--widths",
                "16,16",
                "--check-samples",
                "12",
                "--threads",
                "1",
            ])
            .args(["--torch-grad", grad, "--keep-checks"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(run.status.success(), "--torch-grad {grad}: {}", text(&run));
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(stderr.matches("agreement check").count(), 2, "{stderr}");
    }

    // K = 1 uses reverse over reverse, K = 3 forward tangents: both files must be exact enough
    // that a 0.1 % change of the expected total, or of the whole gradient, is caught.
    for k in [1, 3] {
        let path = dir.path().join(format!("check-k{k}.json"));
        let same = check_edited(&path, |_| {});
        assert!(same.status.success(), "unedited K = {k}: {}", text(&same));

        let total = check_edited(&path, |v| {
            let t = &mut v["expected"]["terms"]["total"];
            *t = (t.as_f64().unwrap() * 1.001).into();
        });
        assert_eq!(
            total.status.code(),
            Some(3),
            "total moved, K = {k}: {}",
            text(&total)
        );
        let report: Value = serde_json::from_slice(&total.stdout).unwrap();
        assert_eq!(report["agree"], false);

        let gradient = check_edited(&path, |v| {
            for g in v["expected"]["gradient"].as_array_mut().unwrap() {
                *g = (g.as_f64().unwrap() * 1.001).into();
            }
        });
        assert_eq!(
            gradient.status.code(),
            Some(3),
            "gradient moved, K = {k}: {}",
            text(&gradient)
        );
    }
}
