//! `dynaslice-lab results` end to end at a toy size: the synthetic table with two seeds writes one
//! model per (shape, variant, seed), a per-seed line per (shape, variant), and table cells that
//! are the mean of those per-seed figures.

use dynaslice_test_support::fixtures::succeeded;
use std::process::Command;

/// The numbers after "label: " on the line that starts with `prefix`.
fn per_seed(markdown: &str, prefix: &str) -> Vec<f64> {
    let line = markdown
        .lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line {prefix:?} in\n{markdown}"));
    line[prefix.len()..]
        .split(", ")
        .map(|v| v.trim().parse().unwrap())
        .collect()
}

/// The cell of column `col` on the first table row that starts with `row`.
fn cell(markdown: &str, row: &str, col: usize) -> f64 {
    let line = markdown
        .lines()
        .find(|l| l.starts_with(row))
        .unwrap_or_else(|| panic!("no row {row:?} in\n{markdown}"));
    line.split('|')
        .map(str::trim)
        .nth(col + 1)
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn synthetic_table_averages_its_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("results.md");
    let run = Command::new(env!("CARGO_BIN_EXE_dynaslice-lab"))
        .args(["results", "-o", out.to_str().unwrap()])
        .args(["--tables", "synthetic", "--shapes", "blob"])
        .args(["--variants", "siren,full", "--seeds", "2"])
        .args(["--minutes", "0.03", "--widths", "32,32", "--samples", "128"])
        .args(["--resolution", "12", "--mesh-resolution", "12"])
        .args(["--truth-resolution", "16", "--cd-samples", "300"])
        .args(["--threads", "2"])
        .output()
        .unwrap();
    succeeded(&run);
    let md = std::fs::read_to_string(&out).unwrap();
    for variant in ["siren", "full"] {
        for seed in 0..2 {
            let model = dir
                .path()
                .join("results.models")
                .join(format!("blob_{variant}_seed{seed}.dsm"));
            assert!(model.exists(), "{} missing", model.display());
        }
    }
    assert!(md.contains("seeds [0, 1]"), "{md}");
    for (row, label) in [
        ("| 4D SIREN |", "4D SIREN"),
        ("| DynaSlice (full) |", "DynaSlice (full)"),
    ] {
        let seeds = per_seed(&md, &format!("- blob / {label}: "));
        assert_eq!(seeds.len(), 2, "{md}");
        assert!(seeds.iter().all(|v| (0.0..=1.0).contains(v)), "{seeds:?}");
        // The blob column (first data column) of the IoU table is their mean, to its 3 digits.
        let mean = 0.5 * (seeds[0] + seeds[1]);
        assert!((cell(&md, row, 1) - mean).abs() <= 1.5e-3, "{row}: {md}");
    }
}
