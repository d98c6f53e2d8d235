//! Input fixtures and process helpers of the reader and command-line tests: .csl files
//! ([`csl_file`] and its plane records), the ball .csl sequence, the two-organ model of the
//! command-line tests ([`two_organ_model`]), [`succeeded`], and the shared data beside the
//! repository ([`shared_data`]).

use std::path::{Path, PathBuf};
use std::process::Output;

use dynaslice_core::format::ModelWriter;
use dynaslice_core::Domain;

/// The model file of a small random network of 2 classes, "liver" (source label 5) and
/// "spleen" (1), hidden widths [16, 16], centred at (10, 0, -5) mm with 50 mm scale, over world
/// times 0..0.8: moving (its temporal frequency bound from seed 4), or static (`omega_t_max` =
/// 0, as a model trained on one timestep is).
pub fn two_organ_model(moving: bool) -> Vec<u8> {
    let mut w = ModelWriter::random_siren(&[16, 16], 2, 4);
    w.classes = vec![("liver".into(), 5), ("spleen".into(), 1)];
    w.domain = Domain {
        center: [10.0, 0.0, -5.0],
        scale: [50.0; 3],
        time_origin: 0.0,
        time_span: 0.8,
        output_scale: 50.0,
    };
    if !moving {
        w.omega_t_max = 0.0;
    }
    w.to_bytes()
}

/// A .csl file (the CSLC text format of `dynaslice_data::csl`): the header, with the plane count
/// and `labels` (the label count, informational), then the records of `planes`, each ending in
/// a newline and a blank line where another follows.
pub fn csl_file<S: AsRef<str>>(labels: usize, planes: &[S]) -> String {
    let records: String = planes.iter().map(AsRef::as_ref).collect();
    format!("CSLC\n{} {labels}\n\n{records}", planes.len())
}

/// Plane 1 of a .csl file, z = 0 (normal (0, 0, 1), D = 0): a 4×4 square of label 1 with a 2×2
/// square hole, labelled 2 (the single-object convention); a blank line ends it.
pub const SQUARE_WITH_HOLE_PLANE: &str = "1 8 2 0 0 1 0

0 0 0
4 0 0
4 4 0
0 4 0
1 1 0
3 1 0
3 3 0
1 3 0
4 1 0 1 2 3
4h0 2 4 7 6 5

";

/// Plane 2 of a .csl file, z = 1 (D = −1): a triangle of label 7.
pub const TRIANGLE_PLANE: &str = "2 3 1 0 0 1 -1
0 0 1
1 0 1
0 1 1
3 7 0 1 2
";

/// A sphere of radius r(t) = 10 + 2t mm cut by 5 z-planes, at times 0, 1, 2 (s), as a .csl
/// manifest with one file per timestep (counter-clockwise circles, label 1).
pub fn write_sequence(dir: &Path) -> PathBuf {
    write_ball_sequence(dir, 2.0, 0.0)
}

/// [`write_sequence`]'s ball with its radius growing by `growth` mm and its centre moving by
/// `shift` mm along x per second: r(t) = 10 + growth·t, centre (shift·t, 0, 0). Written as
/// `dir/ball_{0,1,2}.csl` and the manifest `dir/ball.cslseq`, which it returns.
pub fn write_ball_sequence(dir: &Path, growth: f64, shift: f64) -> PathBuf {
    let mut manifest = String::new();
    for (i, t) in [0.0f64, 1.0, 2.0].iter().enumerate() {
        let (cx, r) = (shift * t, 10.0 + growth * t);
        let zs = [-6.0f64, -3.0, 0.0, 3.0, 6.0];
        let planes: Vec<String> = zs
            .iter()
            .enumerate()
            .map(|(p, z)| {
                let rc = (r * r - z * z).sqrt();
                let n = 48;
                let mut plane = format!("{} {n} 1 0 0 1 {}\n\n", p + 1, -z);
                for j in 0..n {
                    let a = std::f64::consts::TAU * j as f64 / n as f64;
                    plane += &format!("{} {} {z}\n", cx + rc * a.cos(), rc * a.sin());
                }
                plane += &format!(
                    "\n{n} 1 {}\n\n",
                    (0..n).map(|j| j.to_string()).collect::<Vec<_>>().join(" ")
                );
                plane
            })
            .collect();
        let name = format!("ball_{i}.csl");
        std::fs::write(dir.join(&name), csl_file(1, &planes)).unwrap();
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

/// `rel` under the shared data directory beside the repository (`../shared/data`), or `None`,
/// with a notice that the test skips, where it is absent.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel);
    if path.exists() {
        Some(path)
    } else {
        println!("skipped: {} is absent", path.display());
        None
    }
}
