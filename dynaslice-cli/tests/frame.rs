//! The input's frame travels with the model: a model trained on a `.csl` (plain coordinates,
//! no patient frame) records it, `info` says so, and its default mesh lies on the file's own
//! contours, not mirrored into LPS. `--space lps` still gives the mirror, tagged.

use dynaslice_test_support::fixtures::csl_file;
use std::process::Command;

mod common;

use common::{succeeded, train_command};

/// A ball of radius 4 about (20, 10, 0), cut by 3 z-planes: far from the origin in x and y, so
/// a mirror in x and y lands far from it.
fn offset_ball(dir: &std::path::Path) -> std::path::PathBuf {
    let planes: Vec<String> = [-2.0f64, 0.0, 2.0]
        .iter()
        .enumerate()
        .map(|(p, z)| {
            let rc = (16.0 - z * z).sqrt();
            let n = 40;
            let mut plane = format!("{} {n} 1 0 0 1 {}\n\n", p + 1, -z);
            for j in 0..n {
                let a = std::f64::consts::TAU * j as f64 / n as f64;
                plane += &format!("{} {} {z}\n", 20.0 + rc * a.cos(), 10.0 + rc * a.sin());
            }
            plane += &format!(
                "\n{n} 1 {}\n\n",
                (0..n).map(|j| j.to_string()).collect::<Vec<_>>().join(" ")
            );
            plane
        })
        .collect();
    let path = dir.join("ball.csl");
    std::fs::write(&path, csl_file(1, &planes)).unwrap();
    path
}

/// The mean of a PLY file's vertices (binary little-endian, x y z first as floats).
fn ply_centroid(path: &std::path::Path) -> ([f64; 3], String) {
    let bytes = std::fs::read(path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = String::from_utf8_lossy(&bytes[..end]).to_string();
    let count: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    // The vertex's size from its properties (x y z first, floats; then normals, velocity,
    // colours).
    let stride: usize = header
        .lines()
        .skip_while(|l| !l.starts_with("element vertex"))
        .skip(1)
        .take_while(|l| l.starts_with("property"))
        .map(|l| {
            if l.starts_with("property float") {
                4
            } else {
                1
            }
        })
        .sum();
    let mut sum = [0.0f64; 3];
    for v in 0..count {
        for (i, s) in sum.iter_mut().enumerate() {
            let at = end + v * stride + 4 * i;
            *s += f64::from(f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()));
        }
    }
    (sum.map(|s| s / count as f64), header)
}

#[test]
fn a_csl_models_default_mesh_lies_on_its_contours() {
    let dir = tempfile::tempdir().unwrap();
    let input = offset_ball(dir.path());
    let model = dir.path().join("ball.dsm");
    succeeded(
        &train_command(&input, &model, &["--steps", "300"])
            .output()
            .unwrap(),
    );
    let dynaslice = env!("CARGO_BIN_EXE_dynaslice");
    let info = succeeded(
        &Command::new(dynaslice)
            .arg("info")
            .arg(&model)
            .output()
            .unwrap(),
    );
    assert!(
        info.contains("space = RAS") && info.contains("units = none"),
        "{info}"
    );

    let mesh = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        succeeded(
            &Command::new(dynaslice)
                .arg("mesh")
                .arg(&model)
                .args(["--resolution", "48", "-o"])
                .arg(&out)
                .args(extra)
                .output()
                .unwrap(),
        );
        ply_centroid(&out)
    };
    let (c, header) = mesh("default.ply", &[]);
    assert!(
        (c[0] - 20.0).abs() < 1.5 && (c[1] - 10.0).abs() < 1.5 && c[2].abs() < 1.5,
        "the default mesh's centre {c:?} is not the contours' (20, 10, 0)"
    );
    assert!(header.contains("SPACE=RAS"), "{header}");
    let (m, header) = mesh("lps.ply", &["--space", "lps"]);
    assert!(
        (m[0] + c[0]).abs() < 1e-3 && (m[1] + c[1]).abs() < 1e-3,
        "--space lps mirrors x and y: {m:?} against {c:?}"
    );
    assert!(header.contains("SPACE=LPS"), "{header}");
}
