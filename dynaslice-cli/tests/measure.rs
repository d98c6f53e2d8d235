//! `dynaslice measure` and `dynaslice report` end to end on hand-built sphere models (closed-form
//! volumes and centres): the CSV, the JSON and the ITV files in the input's units and frame,
//! the report's numbers against the CSV's, and the report opened in headless Chromium (every
//! image decodes, no console message, a screenshot is written).

use dynaslice_data::nifti::read_volume;
use dynaslice_test_support::browser::{browse, browse_webgl, chromium};
use dynaslice_test_support::fixtures::succeeded;
use dynaslice_test_support::spheres::{self, Sphere, SPHERES_DOMAIN};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A growing "tumour" (label 7) and a still "lung" (label 3), apart, in millimetres.
const SPHERES: [Sphere; 2] = [
    Sphere {
        centre: [-0.4, 0.1, 0.0],
        radius: 0.3,
        rate: 0.1,
    },
    Sphere {
        centre: [0.45, -0.1, 0.1],
        radius: 0.25,
        rate: 0.0,
    },
];

/// The model file of [`SPHERES`] with `metadata` (what `train` records) in `dir`.
fn write_model(dir: &Path, name: &str, metadata: &str) -> PathBuf {
    let mut w = spheres::writer_in(SPHERES_DOMAIN, &SPHERES, &[("tumour", 7), ("lung", 3)]);
    w.metadata = metadata.into();
    let path = dir.join(name);
    std::fs::write(&path, w.to_bytes()).unwrap();
    path
}

fn dynaslice(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The CSV's rows as fields (header first).
fn csv_rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

const NIFTI_INPUT: &str = "trainer = dynaslice 0.1.0\ninput = scan.nii.gz\nframes = 0:2:1\n\
                           space = RAS\nunits = mm\nsteps_done = 3\nfinal_loss = 0.01\n";
const TIMES: &str = "0:2:5";

#[test]
fn measure_writes_mm_figures_csv_json_and_itv() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path(), "m.dsm", NIFTI_INPUT);
    let csv = dir.path().join("t.csv");
    let itv = dir.path().join("itv");
    let out = dynaslice(&[
        "measure",
        s(&model),
        "--times",
        TIMES,
        "--resolution",
        "64",
        "-o",
        s(&csv),
        "--json",
        "--itv",
        s(&itv),
    ]);
    let json: Value = serde_json::from_str(&succeeded(&out)).unwrap();
    assert_eq!(json["units"]["length"], "mm");
    assert_eq!(json["units"]["volume"], "mL");
    assert_eq!(json["frame"]["name"], "RAS");
    let times: Vec<f64> = (0..5).map(|i| i as f64 * 0.5).collect();
    let rows = csv_rows(&csv);
    assert_eq!(rows[0][3], "volume_mL");
    assert_eq!(rows[0][4], "centroid_R_mm");
    assert_eq!(rows.len(), 1 + 2 * times.len());
    for (k, sphere) in SPHERES.iter().enumerate() {
        let class = &json["classes"][k];
        assert_eq!(class["name"], ["tumour", "lung"][k]);
        let volumes: Vec<f64> = class["volume_ml"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        for (f, &t) in times.iter().enumerate() {
            let want = sphere.world_volume(t) / 1000.0;
            assert!(
                (volumes[f] - want).abs() < 0.01 * want,
                "{k} {t}: {} vs {want} mL",
                volumes[f]
            );
            // The CSV's row of this time and class holds the JSON's numbers, digit for digit.
            let row = &rows[1 + 2 * f + k];
            assert_eq!(
                (row[1].as_str(), row[2].as_str()),
                (["tumour", "lung"][k], ["7", "3"][k])
            );
            assert_eq!(row[3], volumes[f].to_string());
            let centroid = &class["centroid"][f];
            for a in 0..3 {
                assert_eq!(row[4 + a], centroid[a].as_f64().unwrap().to_string());
                assert!((centroid[a].as_f64().unwrap() - sphere.world_centre()[a]).abs() < 0.05);
            }
        }
        let amplitude = &class["amplitude_mm"];
        for axis in ["lr", "ap", "si"] {
            assert!(amplitude[axis].as_f64().unwrap() < 0.05, "{amplitude}");
        }
        let (lo, hi) = (
            volumes.iter().copied().fold(f64::MAX, f64::min),
            volumes.iter().copied().fold(f64::MIN, f64::max),
        );
        let ef = class["ejection_fraction"].as_f64().unwrap();
        assert!((ef - (hi - lo) / hi).abs() < 1e-4, "{ef}");
    }
    // The tumour grows: its extremes at the ends; the lung is still.
    assert_eq!(json["classes"][0]["max_volume"]["time"], 2.0);
    assert!(json["classes"][0]["ejection_fraction"].as_f64().unwrap() > 0.1);
    assert!(json["classes"][1]["ejection_fraction"].as_f64().unwrap() < 0.01);
    // The ITV of the growing tumour is its largest ball, as a mask and as a mesh.
    let mask = itv.join("class1_tumour.itv.nii.gz");
    let volume = read_volume(&mask).unwrap();
    let voxel = dynaslice_data::label_volume::det3(&volume.affine).abs();
    let inside = volume.labels.iter().filter(|&&l| l == 7).count() as f64 * voxel;
    let want = SPHERES[0].world_volume(2.0);
    assert!((inside - want).abs() < 0.03 * want, "{inside} vs {want}");
    assert!(volume.labels.iter().all(|&l| l == 0 || l == 7));
    for name in [
        "class1_tumour.itv.ply",
        "class1_tumour.itv.ctbl",
        "class2_lung.itv.nii.gz",
        "class2_lung.itv.ply",
    ] {
        assert!(itv.join(name).is_file(), "{name}");
    }
    // The masks are label volumes: a second run replaces them only with --force.
    let again = dynaslice(&["measure", s(&model), "--itv", s(&itv)]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
}

#[test]
fn plain_inputs_say_so_and_recorded_lps_inputs_are_lps() {
    let dir = tempfile::tempdir().unwrap();
    let plain = write_model(dir.path(), "plain.dsm", "input = slices.csl\n");
    let out = dynaslice(&[
        "measure",
        s(&plain),
        "--times",
        TIMES,
        "--resolution",
        "48",
        "--json",
    ]);
    let json: Value = serde_json::from_str(&succeeded(&out)).unwrap();
    assert_eq!(json["units"]["length"], "units");
    assert_eq!(json["frame"]["name"], "xyz");
    assert!(json["classes"][0]["volume_ml"].is_null());
    assert!(json["classes"][0]["amplitude_mm"].is_null());
    assert!(json["classes"][0]["volume"][0].as_f64().unwrap() > 100.0);
    assert!(String::from_utf8_lossy(&out.stderr).contains("plain input units"));

    // A model written before the units and frame were recorded is plain, whatever its
    // input's name (dynaslice_model::RunRecord's one rule: nothing is guessed).
    let old = write_model(dir.path(), "old.dsm", "input = RS.dcm\n");
    let out = dynaslice(&[
        "measure",
        s(&old),
        "--times",
        TIMES,
        "--resolution",
        "48",
        "--json",
    ]);
    let json: Value = serde_json::from_str(&succeeded(&out)).unwrap();
    assert_eq!(json["frame"]["name"], "xyz");
    assert_eq!(json["units"]["length"], "units");

    let dicom = write_model(
        dir.path(),
        "rt.dsm",
        "input = RS.dcm\nspace = LPS\nunits = mm\n",
    );
    let csv = dir.path().join("lps.csv");
    let args = [
        "measure",
        s(&dicom),
        "--times",
        TIMES,
        "--resolution",
        "48",
        "-o",
        s(&csv),
    ];
    succeeded(&dynaslice(&args));
    let rows = csv_rows(&csv);
    assert_eq!(
        rows[0][4..7],
        ["centroid_L_mm", "centroid_P_mm", "centroid_S_mm"]
    );
    // LPS: x and y of the RAS world negated.
    let c = SPHERES[0].world_centre();
    let got: Vec<f64> = rows[1][4..7].iter().map(|v| v.parse().unwrap()).collect();
    assert!((got[0] + c[0]).abs() < 0.05 && (got[1] + c[1]).abs() < 0.05);
    assert!((got[2] - c[2]).abs() < 0.05);

    let bad = dynaslice(&["measure", s(&dicom), "-o", s(&dir.path().join("t.txt"))]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("*.csv"));
    let outside = dynaslice(&["measure", s(&dicom), "--times", "0:3:4"]);
    assert!(String::from_utf8_lossy(&outside.stderr).contains("outside the model's time range"));
}

#[test]
fn report_is_self_contained_matches_the_csv_and_opens_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path(), "m.dsm", NIFTI_INPUT);
    let mut loss = String::from("step,total,surface,orientation,plane,eikonal,spurious\n");
    for step in 0..50 {
        let v = 1.0 / (1.0 + step as f64);
        loss += &format!("{step},{v},{v},{v},{v},{v},0\n");
    }
    std::fs::write(dir.path().join("m.dsm.loss.csv"), loss).unwrap();
    let html_path = dir.path().join("report.html");
    let csv = dir.path().join("t.csv");
    let common = ["--times", TIMES, "--resolution", "48"];
    let mut args = vec!["report", s(&model), "-o", s(&html_path)];
    args.extend(common);
    succeeded(&dynaslice(&args));
    let mut args = vec!["measure", s(&model), "-o", s(&csv)];
    args.extend(common);
    succeeded(&dynaslice(&args));
    let html = std::fs::read_to_string(&html_path).unwrap();
    // Self-contained: every image inline, nothing referenced outside the file.
    assert_eq!(
        html.matches("<img ").count(),
        6,
        "loss, volume, 3 trajectories, 3D"
    );
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 6);
    for needle in ["http:", "https:", "src=\"/", "href=", "url("] {
        assert!(!html.contains(needle), "{needle}");
    }
    for text in [
        "tumour",
        "lung",
        "scan.nii.gz",
        "mL",
        "final_loss",
        "steps_done",
    ] {
        assert!(html.contains(text), "{text}");
    }
    // Every number of the CSV is a cell of the report's table, in the same order.
    let mut rest = html.as_str();
    for row in csv_rows(&csv).iter().skip(1) {
        for cell in row {
            let needle = format!(">{cell}</td>");
            let at = rest
                .find(&needle)
                .unwrap_or_else(|| panic!("{cell} of {row:?} is not in the report's table"));
            rest = &rest[at + needle.len()..];
        }
    }

    let Some(browser) = chromium() else { return };
    let dom = browse_webgl(browser, &html_path, &["--dump-dom"]);
    assert!(
        dom.status.success(),
        "{}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let dom_text = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom_text.contains("data-images=\"ok 6\""),
        "not every image decoded: {}",
        dom_text
            .lines()
            .find(|l| l.contains("<body"))
            .unwrap_or("no <body>")
    );
    // Console messages (errors, uncaught exceptions) are logged as INFO:CONSOLE lines.
    let log = String::from_utf8_lossy(&dom.stderr);
    let console: Vec<&str> = log.lines().filter(|l| l.contains(":CONSOLE")).collect();
    assert!(console.is_empty(), "console messages: {console:#?}");
    let shot = dir.path().join("report.png");
    let out = browse(
        browser,
        &html_path,
        &[
            "--disable-gpu",
            &format!("--screenshot={}", shot.display()),
            "--window-size=1200,1600",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let png = image::open(&shot).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (1200, 1600));
    // Not a blank page: dark text and coloured figures among the white.
    let distinct: std::collections::HashSet<[u8; 3]> = png.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 50, "{} colours", distinct.len());
}

/// The still lung is reported rigid (stderr, JSON, report), the growing tumour by its volume
/// change, with no ejection fraction or stroke volume named for either outside the cardiac
/// note and the JSON's kept keys.
#[test]
fn still_classes_are_rigid_and_growing_ones_change_in_measure_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let model = write_model(dir.path(), "m.dsm", NIFTI_INPUT);
    let common = ["--times", TIMES, "--resolution", "48"];
    let mut args = vec!["measure", s(&model), "--json"];
    args.extend(common);
    let out = dynaslice(&args);
    let json: Value = serde_json::from_str(&succeeded(&out)).unwrap();
    let (tumour, lung) = (&json["classes"][0], &json["classes"][1]);
    assert_eq!(
        (tumour["rigid"].as_bool(), lung["rigid"].as_bool()),
        (Some(false), Some(true))
    );
    assert!(tumour["relative_volume_change"].as_f64().unwrap() > 0.1);
    assert_eq!(
        tumour["relative_volume_change"],
        tumour["ejection_fraction"]
    );
    assert_eq!(tumour["volume_change"], tumour["stroke_volume"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let line = |name: &str| {
        stderr
            .lines()
            .find(|l| l.starts_with(&format!("  \"{name}\":")))
            .unwrap_or_else(|| panic!("no line for {name}: {stderr}"))
            .to_string()
    };
    assert!(line("lung").contains("rigid: volume") && line("lung").contains("within 5 %"));
    assert!(line("tumour").contains("change ") && !line("tumour").contains("rigid"));
    for l in [line("lung"), line("tumour")] {
        assert!(!l.contains("EF") && !l.contains("stroke"), "{l}");
    }

    let html_path = dir.path().join("r.html");
    let mut args = vec!["report", s(&model), "-o", s(&html_path)];
    args.extend(common);
    succeeded(&dynaslice(&args));
    let html = std::fs::read_to_string(&html_path).unwrap();
    // The cycle table: the lung's row says rigid, the tumour's changes.
    let cycle = &html[html.find("volume change (mL)").unwrap()..];
    for (name, word) in [("tumour", "changes"), ("lung", "rigid")] {
        let row = &cycle[cycle.find(&format!("<td>{name}</td>")).unwrap()..];
        let row = &row[..row.find("</tr>").unwrap()];
        assert!(row.contains(&format!("<td>{word}</td>")), "{name}: {row}");
    }
    assert!(!html.contains("ejection fraction</th>"));
}
