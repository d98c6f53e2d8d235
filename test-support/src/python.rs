//! Running Python scripts that use the libraries our users use (nibabel, pydicom, pynrrd, …) to
//! make test inputs and to read our outputs.
//!
//! On a developer's machine without those libraries the tests skip with a notice. CI installs
//! them and sets `DYNASLICE_REQUIRE_PYTHON`, so there a missing module is a failure, not a skip.

use std::path::Path;
use std::process::Command;

/// Runs `script` with `python3 -c script args…` when every module of `modules` imports, and
/// returns its stdout; `None`, after printing why, when one does not. Panics (failing the test)
/// when the script fails, showing its stderr, or when a module is missing while
/// `DYNASLICE_REQUIRE_PYTHON` is set.
pub fn run_python(modules: &[&str], script: &str, args: &[&Path]) -> Option<String> {
    let probe = modules
        .iter()
        .map(|m| format!("import {m}"))
        .collect::<Vec<_>>()
        .join("; ");
    let importable = Command::new("python3")
        .args(["-c", &probe])
        .output()
        .is_ok_and(|o| o.status.success());
    if !importable {
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_PYTHON").is_none(),
            "`python3 -c '{probe}'` fails but DYNASLICE_REQUIRE_PYTHON is set"
        );
        println!(
            "SKIPPED: `python3 -c '{probe}'` fails (pip install {})",
            modules.join(" ")
        );
        return None;
    }
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "python script failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).expect("python prints UTF-8"))
}
