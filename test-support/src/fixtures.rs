//! Input fixtures and process helpers of the command-line tests.

use std::path::{Path, PathBuf};
use std::process::Output;

/// A sphere of radius r(t) = 10 + 2t mm cut by 5 z-planes, at times 0, 1, 2 (s), as a .csl
/// manifest with one file per timestep (counter-clockwise circles, label 1).
pub fn write_sequence(dir: &Path) -> PathBuf {
    let mut manifest = String::new();
    for (i, t) in [0.0f64, 1.0, 2.0].iter().enumerate() {
        let r = 10.0 + 2.0 * t;
        let zs = [-6.0f64, -3.0, 0.0, 3.0, 6.0];
        let mut csl = format!("CSLC\n{} 1\n\n", zs.len());
        for (p, z) in zs.iter().enumerate() {
            let rc = (r * r - z * z).sqrt();
            let n = 48;
            csl += &format!("{} {n} 1 0 0 1 {}\n\n", p + 1, -z);
            for j in 0..n {
                let a = std::f64::consts::TAU * j as f64 / n as f64;
                csl += &format!("{} {} {z}\n", rc * a.cos(), rc * a.sin());
            }
            csl += &format!(
                "\n{n} 1 {}\n\n",
                (0..n).map(|j| j.to_string()).collect::<Vec<_>>().join(" ")
            );
        }
        let name = format!("ball_{i}.csl");
        std::fs::write(dir.join(&name), csl).unwrap();
        manifest += &format!("{t} {name}\n");
    }
    let path = dir.join("ball.cslseq");
    std::fs::write(&path, manifest).unwrap();
    path
}

/// Fails the test with the command's stderr unless it exited 0; returns its stdout.
pub fn succeeded(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
