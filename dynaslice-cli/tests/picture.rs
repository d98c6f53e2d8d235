//! `dynaslice picture` on a model trained by the test: a PNG of the right size, and errors;
//! `picture --3d` on a hand-built model of two balls: panels, class colours, views, errors.

mod common;

use common::{succeeded, train_command, write_sequence};
use dynaslice_figures::class_color;
use dynaslice_test_support::spheres::{self, Sphere};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

    let out = picture(&["-o", png.to_str().unwrap(), "--frame", "9", "--force"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--frame 9") && err.contains("3 frames"),
        "{err}"
    );
}

/// Two static-and-growing balls in `SPHERES_DOMAIN` (world centre (10, −5, 2), half-extent 20,
/// times 0..2): class 1 on the patient's right (+x, world x = 19), growing; class 2 on the
/// left (world x = 1).
fn two_balls(dir: &Path) -> PathBuf {
    let bytes = spheres::model(
        &[
            Sphere::new([0.45, 0.0, 0.0], 0.3, 0.05),
            Sphere::new([-0.45, 0.0, 0.0], 0.25, 0.0),
        ],
        &[("right ball", 4), ("left ball", 9)],
    );
    let path = dir.join("balls.dsm");
    std::fs::write(&path, bytes).unwrap();
    path
}

fn picture_3d(model: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(["picture", "--3d", model.to_str().unwrap()])
        .args(extra)
        .output()
        .unwrap()
}

/// The pixels of `img` in columns `xs` and rows `ys` that are a shade of class `k`'s colour
/// (the renderer scales the colour by a shade from 0.2 to 1), as (x, y).
fn class_pixels(
    img: &image::RgbImage,
    k: usize,
    xs: std::ops::Range<u32>,
    ys: std::ops::Range<u32>,
) -> Vec<(u32, u32)> {
    let c = class_color(k, None);
    let base = [c.0, c.1, c.2].map(f64::from);
    let norm: f64 = base.iter().map(|b| b * b).sum();
    let mut out = Vec::new();
    for y in ys {
        for x in xs.clone() {
            let p = img.get_pixel(x, y).0.map(f64::from);
            let s = (0..3).map(|i| p[i] * base[i]).sum::<f64>() / norm;
            if (0.15..=1.01).contains(&s) && (0..3).all(|i| (p[i] - s * base[i]).abs() <= 2.0) {
                out.push((x, y));
            }
        }
    }
    out
}

/// Layout of `render3d`: a 10-pixel margin, a 30-pixel title row, panels of `--size`.
const MARGIN: u32 = 10;
const TITLE: u32 = 30;

#[test]
fn draws_every_class_in_3d_at_four_times_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let model = two_balls(dir.path());
    let png = dir.path().join("surfaces.png");
    let size = 160;
    let out = picture_3d(
        &model,
        &[
            "-o",
            png.to_str().unwrap(),
            "--size",
            "160",
            "--resolution",
            "32",
        ],
    );
    succeeded(&out);
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        log.contains("wrote") && log.contains("surfaces.png"),
        "{log}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    // Four panels (times 0, 2/3, 4/3, 2 of the range 0..2) side by side, the legend below.
    assert_eq!(img.width(), MARGIN + 4 * (size + MARGIN));
    assert!(img.height() > TITLE + size + 2 * MARGIN, "{}", img.height());
    for panel in 0..4 {
        let x0 = MARGIN + panel * (size + MARGIN);
        for k in 0..2 {
            let n = class_pixels(&img, k, x0..x0 + size, TITLE..TITLE + size).len();
            // Each ball covers hundreds of pixels of a 160-pixel panel.
            assert!(n > 300, "panel {panel}, class {}: {n} pixels", k + 1);
        }
    }
    // The growing ball grows: more of its pixels in the last panel than in the first.
    let area = |panel: u32| {
        let x0 = MARGIN + panel * (size + MARGIN);
        class_pixels(&img, 0, x0..x0 + size, TITLE..TITLE + size).len()
    };
    assert!(area(3) > area(0), "{} vs {}", area(3), area(0));
}

#[test]
fn the_3d_views_put_the_patients_right_where_they_say() {
    let dir = tempfile::tempdir().unwrap();
    let model = two_balls(dir.path());
    let png = dir.path().join("v.png");
    let size = 120;
    // Seen from the front the patient's right is on the viewer's left; from above (anterior
    // up) on the viewer's right.
    for (view, right_ball_on_the_left) in [("anterior", true), ("superior", false)] {
        let out = picture_3d(
            &model,
            &[
                "-o",
                png.to_str().unwrap(),
                "--size",
                "120",
                "--resolution",
                "24",
                "--times",
                "1",
                "--view",
                view,
                "--force",
            ],
        );
        succeeded(&out);
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.width(), MARGIN + size + MARGIN, "one panel");
        let mean_x = |k: usize| {
            let px = class_pixels(&img, k, MARGIN..MARGIN + size, TITLE..TITLE + size);
            assert!(px.len() > 100, "{view}: class {}", k + 1);
            px.iter().map(|p| f64::from(p.0)).sum::<f64>() / px.len() as f64
        };
        assert_eq!(mean_x(0) < mean_x(1), right_ball_on_the_left, "{view}");
    }
}

#[test]
fn bad_3d_requests_fail_clearly_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let model = two_balls(dir.path());
    let listing = || {
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    let before = listing();
    let png = dir.path().join("s.png");
    let png = png.to_str().unwrap();
    let jpg = dir.path().join("s.jpg");
    let seventeen = (0..17)
        .map(|i| format!("{}", i as f64 / 10.0))
        .collect::<Vec<_>>()
        .join(",");
    let cases: [(Vec<&str>, &[&str]); 4] = [
        (vec!["-o", jpg.to_str().unwrap()], &["s.jpg", "*.png"]),
        (
            vec!["-o", png, "--times", "0,5"],
            &[
                "--times 0,5: time 5",
                "outside the model's time range [0, 2]",
                "balls.dsm",
            ],
        ),
        (
            vec!["-o", png, "--times", "-1"],
            &["--times -1: time -1", "outside"],
        ),
        (vec!["-o", png, "--times", &seventeen], &["at most 16"]),
    ];
    for (args, wanted) in cases {
        let out = picture_3d(&model, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        for w in wanted {
            assert!(err.contains(w), "{args:?}: {w:?} in {err}");
        }
        assert_eq!(listing(), before, "{args:?} wrote a file");
    }
    // The two kinds of picture take different arguments: clap says which clash.
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_dynaslice"))
            .arg("picture")
            .args(args)
            .output()
            .unwrap()
    };
    let m = model.to_str().unwrap();
    for (args, wanted) in [
        (vec![m, "-o", png], "<INPUT>"),
        (
            vec!["--3d", m, "in.json", "-o", png],
            "'--3d' cannot be used with '[INPUT]...'",
        ),
        (vec!["--3d", m, "--frame", "1", "-o", png], "--frame"),
        (vec![m, "in.json", "--view", "left", "-o", png], "--view"),
    ] {
        let out = run(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(wanted), "{args:?}: {wanted:?} in {err}");
    }
    assert_eq!(listing(), before);
}
