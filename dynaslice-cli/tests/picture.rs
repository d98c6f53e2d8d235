//! `dynaslice picture` on a model trained by the test: a PNG of the right size, and errors.

mod common;

use common::{succeeded, train_command, write_sequence};
use std::process::Command;

#[test]
fn draws_labels_and_contours() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_sequence(dir.path());
    let model = dir.path().join("m.dsm");
    let out = train_command(&input, &model, &["--steps", "50"])
        .output()
        .unwrap();
    succeeded(&out);
    let picture = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_dynaslice"))
            .args(["picture", model.to_str().unwrap(), input.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap()
    };
    let png = dir.path().join("fig.png");
    let out = picture(&["-o", png.to_str().unwrap(), "--frame", "1"]);
    succeeded(&out);
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    // Two panels (frame 1 and halfway to frame 2) of at most 480 px plus margins and the
    // class legend.
    let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    assert!(width > 2 * 100 && width <= 2 * 480 + 200, "width {width}");

    let out = picture(&["-o", png.to_str().unwrap(), "--frame", "9"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--frame 9") && err.contains("3 frames"),
        "{err}"
    );
}
