//! Helpers shared by the command-line tests.

// Each test file uses some of them.
#![allow(dead_code, unused_imports)]

pub use dynaslice_test_support::fixtures::{succeeded, write_sequence};
use std::path::Path;
use std::process::Command;

pub fn train_command(input: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dynaslice"));
    c.args([
        "train",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ])
    .args([
        "--widths",
        "32,32",
        "--contour-samples",
        "256",
        "--plane-samples",
        "256",
    ])
    .args(["--space-samples", "256", "--threads", "2", "--seed", "7"])
    .args(extra);
    c
}
