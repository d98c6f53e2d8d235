//! An adversarial user's probes of the command line, as a table: each must end quickly with a
//! non-zero exit that is not a panic (101), and a message naming the option or file and what
//! is wrong; no probe may change a byte of any file it was pointed at. Then the static-model,
//! time-range, completion and manual-page behaviour.

use dynaslice_test_support::fixtures::two_organ_model;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;

/// No probe may take longer (each is refused before any real work).
const PROBE_TIMEOUT: Duration = Duration::from_secs(30);

/// Runs the binary in `dir` with `args`, killing it after `timeout`; `None` on a timeout.
fn run_in(dir: &Path, args: &[String], timeout: Duration) -> Option<Output> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run dynaslice");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > timeout {
            child.kill().unwrap();
            child.wait().unwrap();
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    Some(child.wait_with_output().unwrap())
}

/// [`two_organ_model`], moving or static, written to `path`.
fn write_model(path: &Path, moving: bool) {
    std::fs::write(path, two_organ_model(moving)).unwrap();
}

fn write_json(path: &Path, classes: usize, name: impl Fn(usize) -> String, scale: f64) {
    let names: Vec<String> = (0..classes)
        .map(|k| format!(r#"{{"name": "{}", "label": {}}}"#, name(k), k + 1))
        .collect();
    let s = scale;
    let annotations: Vec<String> = (0..classes)
        .map(|k| {
            let x = 3.0 * k as f64 * s;
            format!(
                r#"{{"class": {k}, "polygons": [[[{x}, 0.0], [{}, 0.0], [{}, {s}], [{x}, {s}]]]}}"#,
                x + s,
                x + s
            )
        })
        .collect();
    let m = 3.0 * classes as f64 * s;
    let doc = format!(
        r#"{{"format": "dynaslice-sections", "version": 1, "classes": [{}],
          "frames": [{{"time": 0.0, "planes": [{{"origin": [0.0, 0.0, 0.0], "u": [1.0, 0.0, 0.0],
          "v": [0.0, 1.0, 0.0], "roi": {{"min": [{}, {}], "max": [{m}, {m}]}},
          "annotations": [{}]}}]}}]}}"#,
        names.join(", "),
        -s,
        -s,
        annotations.join(", ")
    );
    std::fs::write(path, doc).unwrap();
}

/// Every file under `dir` (not following links) with its bytes, to check that nothing changed.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let t = entry.file_type().unwrap();
        if t.is_file() {
            out.insert(entry.path(), std::fs::read(entry.path()).unwrap());
        } else if t.is_dir() {
            out.extend(snapshot(&entry.path()));
        }
    }
    out
}

/// Bytes the kernel reports available, where known.
fn mem_available() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    Some(line.split_whitespace().nth(1)?.parse::<f64>().ok()? * 1024.0)
}

#[test]
fn every_probe_ends_with_a_clear_error_and_changes_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_model(&d.join("m.dsm"), true);
    common::write_sequence(d); // ball.cslseq, ball_0..2.csl: 3 frames
    write_json(&d.join("in.json"), 1, |_| "ball".into(), 1.0);
    write_json(&d.join("long.json"), 1, |_| "x".repeat(57), 1.0);
    write_json(&d.join("many.json"), 65, |k| format!("c{k}"), 1.0);
    write_json(&d.join("huge.json"), 1, |_| "ball".into(), 1e300);
    std::fs::write(d.join("ref.nii.gz"), b"a user's reference image").unwrap();
    std::fs::write(d.join("mine.json"), b"a user's training input").unwrap();
    std::fs::write(d.join("old.dsm"), b"a user's model").unwrap();
    std::fs::write(d.join("busy.dsm.ckpt"), b"a user's checkpoint").unwrap();
    std::fs::create_dir(d.join("outdir")).unwrap();
    std::fs::create_dir(d.join("dir.dsm")).unwrap();
    let fifo = d.join("fifo.dsm");
    let made = Command::new("mkfifo").arg(&fifo).status();
    let has_fifo = made.is_ok_and(|s| s.success());

    // Small, fast training options (a probe that wrongly trains still ends soon).
    let train = |extra: &str| format!("train ball.cslseq -o t.dsm --widths 8 --steps 2 {extra}");
    let mut probes: Vec<(String, Vec<&str>)> = vec![
        // Numbers: NaN, infinities, zero and negative values, absurd sizes.
        (train("--omega0 0"), vec!["--omega0", "> 0"]),
        (
            train("--omega0 NaN"),
            vec!["--omega0", "not a finite number"],
        ),
        (
            train("--omega0 inf"),
            vec!["--omega0", "not a finite number"],
        ),
        (train("--temporal-factor NaN"), vec!["--temporal-factor"]),
        (
            train("--temporal-factor -1"),
            vec!["--temporal-factor", "> 0"],
        ),
        (train("--minutes NaN"), vec!["--minutes"]),
        (train("--minutes -1"), vec!["--minutes"]),
        (train("--minutes inf"), vec!["--minutes"]),
        (train("--minutes 0"), vec!["--minutes"]),
        (
            train("--checkpoint-minutes NaN"),
            vec!["--checkpoint-minutes"],
        ),
        (
            train("--checkpoint-minutes -1"),
            vec!["--checkpoint-minutes"],
        ),
        (train("--lr NaN"), vec!["--lr"]),
        (train("--lr=-1"), vec!["--lr"]),
        (train("--lambda-plane=-5"), vec!["--lambda-plane"]),
        (train("--alpha inf"), vec!["--alpha"]),
        (train("--init-offset 1e30"), vec!["--init-offset"]),
        (train("--threads 100000"), vec!["--threads", "1024"]),
        (train("--threads 0"), vec!["--threads"]),
        // Negative numbers reach the value parser (not clap's "unexpected argument '-1'"),
        // whole-number options, real ones, nested subcommands and positional values alike.
        (
            train("--threads -1"),
            vec![
                "'-1' for '--threads",
                "out of range",
                "a whole number from 1 to 1024",
            ],
        ),
        (
            train("--contour-samples -5"),
            vec!["'-5' for '--contour-samples", "out of range"],
        ),
        (
            train("--lr -1"),
            vec!["'-1' for '--lr", "out of range", "> 0"],
        ),
        (
            "mesh m.dsm --time 0 --threads -2 -o a.ply".into(),
            vec!["'-2' for '--threads", "from 1 to 1024"],
        ),
        (
            "eval synthetic m.dsm --shape blob --samples -4".into(),
            vec!["'-4' for '--samples", "out of range"],
        ),
        ("query m.dsm -1e39 0 0 0".into(), vec!["<X>", "32-bit"]),
        (train("--steps 0"), vec!["--steps"]),
        (train("--contour-samples 0"), vec!["--contour-samples"]),
        (train("--plane-samples 0"), vec!["--plane-samples"]),
        (train("--space-samples 0"), vec!["--space-samples"]),
        (train("--space-samples 4000000000"), vec!["--space-samples"]),
        (train("--widths 0"), vec!["--widths"]),
        (
            "train ball.cslseq -o t.dsm --widths 8,8,8,8,8,8,8,8,8".into(),
            vec!["--widths", "9 layers"],
        ),
        (train("--class-weights NaN"), vec!["--class-weights"]),
        // Input-derived limits, before any training.
        (
            "train long.json -o t.dsm --steps 2".into(),
            vec!["long.json", "57 bytes"],
        ),
        (
            "train many.json -o t.dsm --steps 2".into(),
            vec!["many.json", "65 classes"],
        ),
        (
            "train huge.json -o t.dsm --steps 2".into(),
            vec!["huge.json", "32-bit"],
        ),
        // Outputs: extensions, folders, inputs, existing models and checkpoints.
        (
            "train ball.cslseq -o t.txt".into(),
            vec!["-o t.txt", "*.dsm"],
        ),
        (
            "train ball.cslseq -o outdir".into(),
            vec!["outdir", "*.dsm"],
        ),
        (
            "train ball.cslseq -o dir.dsm".into(),
            vec!["dir.dsm", "is a directory"],
        ),
        (
            "train ball.cslseq -o new.dsm/".into(),
            vec!["new.dsm/", "not a file name"],
        ),
        (
            "train ball.cslseq -o nofolder/t.dsm".into(),
            vec!["nofolder", "does not exist"],
        ),
        ("train in.json -o in.json".into(), vec!["in.json", "*.dsm"]),
        (
            "train ball.cslseq -o old.dsm".into(),
            vec!["old.dsm", "--force"],
        ),
        (
            "train ball.cslseq -o busy.dsm".into(),
            vec!["busy.dsm.ckpt", "--resume", "--force"],
        ),
        (
            "eval split in.json --holdout-planes 0:1 -o in.json".into(),
            vec!["in.json", "input of the command"],
        ),
        (
            "eval split in.json --holdout-planes 0:1 -o model3.dsm".into(),
            vec!["model3.dsm", "*.json"],
        ),
        (
            "eval split in.json --holdout-planes 0:1 -o mine.json".into(),
            vec!["mine.json", "--force"],
        ),
        (
            "labels m.dsm --like ref.nii.gz -o ref.nii.gz".into(),
            vec!["ref.nii.gz", "input of the command"],
        ),
        ("labels m.dsm -o out.txt".into(), vec!["out.txt", "*.nii"]),
        ("eval volume m.dsm -o m.dsm".into(), vec!["m.dsm", "*.csv"]),
        (
            "eval volume m.dsm -o vol.png".into(),
            vec!["vol.png", "*.csv"],
        ),
        (
            "eval volume m.dsm --resolution 65536 -o v.csv".into(),
            vec!["--resolution"],
        ),
        (
            "eval volume m.dsm --times 0:5:3 -o v.csv".into(),
            vec!["m.dsm", "outside the model's time range"],
        ),
        (
            "mesh m.dsm --times 0:0.8:3 -o a.vtp".into(),
            vec!["a.vtp", "looks like a file"],
        ),
        (
            "mesh m.dsm --time 0.1 -o a.txt".into(),
            vec!["a.txt", "*.ply"],
        ),
        ("picture m.dsm in.json -o fig.txt".into(), vec!["*.png"]),
        // Meshing, label volumes, metrics: times and sizes.
        ("mesh m.dsm --time NaN -o a.ply".into(), vec!["--time"]),
        (
            "mesh m.dsm --time 5 -o a.ply".into(),
            vec!["m.dsm", "outside the model's time range"],
        ),
        (
            "mesh m.dsm -o a.ply".into(),
            vec!["m.dsm", "moves", "--time"],
        ),
        (
            "mesh m.dsm --time 0 --resolution 65536 -o a.ply".into(),
            vec!["--resolution", "2048"],
        ),
        (
            "mesh m.dsm --time 0 --newton-steps 4000000000 -o a.ply".into(),
            vec!["--newton-steps"],
        ),
        (
            "mesh m.dsm --times 0:1:100000000 -o series".into(),
            vec!["--times", "at most"],
        ),
        (
            "mesh m.dsm --time 0 --threads 100000 -o a.ply".into(),
            vec!["--threads"],
        ),
        (
            "mesh m.dsm --time 0 --safety NaN -o a.ply".into(),
            vec!["--safety"],
        ),
        (
            "query m.dsm 0 0 0 5".into(),
            vec!["outside the model's time range"],
        ),
        ("query m.dsm 0 0 0 NaN".into(), vec!["[T]"]),
        ("query m.dsm 0 0 0".into(), vec!["moves", "T"]),
        ("query m.dsm 1e39 0 0 0".into(), vec!["<X>", "32-bit"]),
        (
            "eval reference m.dsm ref.stl --time NaN".into(),
            vec!["--time"],
        ),
        (
            "eval heldout m.dsm in.json --holdout-planes 0:1 --pixels 1000000000".into(),
            vec!["--pixels"],
        ),
        (
            "eval synthetic m.dsm --shape blob --samples 4000000000".into(),
            vec!["--samples"],
        ),
        (
            "labels m.dsm -o l.nii.gz --spacing 0.001".into(),
            vec!["NIfTI-1 allows at most"],
        ),
        (
            "labels m.dsm -o l.nii.gz --spacing 0".into(),
            vec!["--spacing"],
        ),
        (
            "labels m.dsm -o l.nii.gz --times 0:1:100000000".into(),
            vec!["--times", "at most"],
        ),
        (
            "synth -o data --volume-resolution 100000".into(),
            vec!["--volume-resolution"],
        ),
        ("synth -o data --timesteps 1".into(), vec!["--timesteps"]),
        ("synth -o data.json".into(), vec!["looks like a file"]),
        ("bench --threads 100000".into(), vec!["--threads"]),
        ("bench --classes 65".into(), vec!["--classes"]),
        (
            "bench --widths 8,8,8,8,8,8,8,8,8".into(),
            vec!["--widths", "9 layers"],
        ),
        (
            "info /dev/zero".into(),
            vec!["/dev/zero", "not a regular file"],
        ),
        ("info outdir".into(), vec!["outdir", "not a regular file"]),
    ];
    if has_fifo {
        probes.push((
            "info fifo.dsm".into(),
            vec!["fifo.dsm", "not a regular file"],
        ));
    }
    // Refused by the memory estimate where no machine has that much (each names the figure).
    let memory_probes = [
        // 25000³ voxels × 12 bytes: 188 TB.
        ("labels m.dsm -o l.nii.gz --spacing 0.004", 1.5e14),
        // 2049³ vertices × (2·4 + 48) bytes: 482 GB.
        (
            "mesh m.dsm --time 0 --dense --resolution 2048 -o a.ply",
            4.8e11,
        ),
        // 1024³ voxels × 1000 frames × 8 bytes: 8.6 TB.
        (
            "synth -o data --volume-resolution 1024 --timesteps 1000",
            8.5e12,
        ),
    ];
    for (line, bytes) in memory_probes {
        if mem_available().is_some_and(|m| m < bytes) {
            probes.push((line.into(), vec!["memory", "--allow-memory", "TB"]));
        }
    }
    // Where the estimate is in GB the message says so.
    if let Some(p) = probes.iter_mut().find(|p| p.0.contains("--dense")) {
        p.1 = vec!["memory", "--allow-memory", "GB"];
    }

    let before = snapshot(d);
    let mut failures = Vec::new();
    for (line, expected) in &probes {
        let args = shlex::split(line).unwrap();
        let Some(out) = run_in(d, &args, PROBE_TIMEOUT) else {
            failures.push(format!("{line}: still running after {PROBE_TIMEOUT:?}"));
            continue;
        };
        let err = String::from_utf8_lossy(&out.stderr);
        match out.status.code() {
            Some(0) => failures.push(format!("{line}: succeeded\n{err}")),
            Some(101) => failures.push(format!("{line}: panicked\n{err}")),
            None => failures.push(format!("{line}: killed by a signal\n{err}")),
            Some(_) => {
                let missing: Vec<&&str> = expected.iter().filter(|e| !err.contains(**e)).collect();
                if !missing.is_empty() || err.contains("panicked") {
                    failures.push(format!("{line}: message lacks {missing:?}:\n{err}"));
                }
            }
        }
        let after = snapshot(d);
        if after != before {
            let changed: Vec<_> = after
                .keys()
                .chain(before.keys())
                .filter(|k| after.get(*k) != before.get(*k))
                .collect();
            failures.push(format!("{line}: changed or left files {changed:?}"));
            break;
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} probes failed:\n{}",
        failures.len(),
        probes.len(),
        failures.join("\n\n")
    );
    eprintln!("{} probes, each a clear error", probes.len());
}

#[test]
fn a_static_model_needs_no_time_and_a_moving_one_stays_in_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_model(&d.join("s.dsm"), false);
    write_model(&d.join("m.dsm"), true);
    let run = |line: &str| run_in(d, &shlex::split(line).unwrap(), PROBE_TIMEOUT).unwrap();
    let out = run("query s.dsm 12 0 -5");
    common::succeeded(&out);
    let out = run("mesh s.dsm --resolution 8 -o s.ply");
    common::succeeded(&out);
    assert!(d.join("s_class1_liver.ply").exists() && d.join("s_class2_spleen.ply").exists());
    // In range: fine, to the end of the range.
    common::succeeded(&run("query m.dsm 12 0 -5 0.8"));
    let out = run("query m.dsm 12 0 -5 0.81");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(1) && err.contains("[0, 0.8]"),
        "{err}"
    );
}

#[test]
fn completions_and_manual_pages() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let run = |line: &str| run_in(d, &shlex::split(line).unwrap(), PROBE_TIMEOUT).unwrap();
    let bash = common::succeeded(&run("completions bash"));
    assert!(
        bash.contains("--omega0") && bash.contains("dynaslice"),
        "{bash}"
    );
    let out = run("completions cmd.exe");
    assert_eq!(out.status.code(), Some(2));
    let page = common::succeeded(&run("man"));
    assert!(page.contains(".TH dynaslice"), "{page}");
    common::succeeded(&run("man -o pages"));
    let train = std::fs::read_to_string(d.join("pages/dynaslice-train.1")).unwrap();
    assert!(train.contains("omega0"), "{train}");
    assert!(d.join("pages/dynaslice-eval-synthetic.1").exists());
}

/// clap's own consistency checks of every subcommand (defaults pass their value parsers, no
/// clashing names).
#[test]
fn command_line_definition_is_consistent() {
    use clap::CommandFactory;
    dynaslice_cli::Cli::command().debug_assert();
}

/// Each kind of bad input file is refused, by the command that reads it, with a message that
/// names that file (a manifest entry or an NRRD data file that cannot be opened: both the file
/// and the manifest or header line that names it).
#[test]
fn every_bad_input_is_refused_naming_its_file() {
    use dynaslice_data::label_volume::LabelVolume;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::write_sequence(d); // ball_0..2.csl, ball.cslseq
    write_json(&d.join("in.json"), 1, |_| "ball".into(), 1.0);
    // A valid label map, then its damaged copies.
    let mut labels = vec![0u8; 12 * 12 * 6];
    for k in 1..5 {
        for j in 3..9 {
            for i in 3..9 {
                labels[(k * 12 + j) * 12 + i] = 1;
            }
        }
    }
    let volume = LabelVolume {
        dims: [12, 12, 6],
        frames: 1,
        affine: [
            [2.0, 0.0, 0.0, 0.0],
            [0.0, 2.0, 0.0, 0.0],
            [0.0, 0.0, 3.0, 0.0],
        ],
        frame_interval: 1.0,
        labels: labels.iter().map(|&v| i32::from(v)).collect(),
    };
    dynaslice_data::nifti::write_volume(&volume, &d.join("map.nii.gz")).unwrap();
    let gz = std::fs::read(d.join("map.nii.gz")).unwrap();
    // Cut inside the gzip stream's first block: the header itself is incomplete.
    std::fs::write(d.join("cut.nii.gz"), &gz[..40]).unwrap();
    std::fs::write(d.join("tabled.nii.gz"), &gz).unwrap();
    std::fs::write(d.join("tabled.ctbl"), "1 liver 300 0 0 255\n").unwrap();
    // The .csl declares 4 planes and holds 5.
    let csl = std::fs::read_to_string(d.join("ball_0.csl")).unwrap();
    std::fs::write(d.join("count.csl"), csl.replacen("5 1", "4 1", 1)).unwrap();
    let nrrd_head = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 twelve 6\nencoding: raw\n\n";
    std::fs::write(d.join("header.nrrd"), nrrd_head).unwrap();
    let detached = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 12 6\nencoding: raw\n\
                    data file: gone.raw\n";
    std::fs::write(d.join("detached.nhdr"), detached).unwrap();
    std::fs::write(d.join("gap.seq"), "0 ball_0.csl\n1 absent.csl\n").unwrap();
    let json = std::fs::read_to_string(d.join("in.json")).unwrap();
    let wrong = json.replacen("\"u\": [1.0, 0.0, 0.0]", "\"u\": \"east\"", 1);
    assert_ne!(wrong, json, "the JSON fixture changed shape");
    std::fs::write(d.join("field.json"), wrong).unwrap();
    std::fs::write(d.join("names.txt"), "1 ball\nnot-a-number spleen\n").unwrap();
    write_model(&d.join("m.dsm"), true);

    let train = |input: &str| format!("train {input} -o t.dsm --widths 8 --steps 2");
    // (command line, what its message must hold: the damaged file, and where one names another
    // the file and line that name it)
    let cases: Vec<(String, Vec<&str>)> = vec![
        (train("count.csl"), vec!["count.csl", "the header says 4"]),
        (train("cut.nii.gz"), vec!["cut.nii.gz"]),
        (
            "labels m.dsm --like cut.nii.gz -o l.nii.gz".into(),
            vec!["cut.nii.gz"],
        ),
        (train("header.nrrd"), vec!["header.nrrd, line 4", "sizes"]),
        (
            train("detached.nhdr"),
            vec!["detached.nhdr, line 6", "gone.raw", "No such file"],
        ),
        (
            train("gap.seq"),
            vec!["gap.seq, line 2", "absent.csl", "No such file"],
        ),
        (train("field.json"), vec!["field.json", "planes[0].u"]),
        (train("tabled.nii.gz"), vec!["tabled.ctbl, line 1"]),
        (
            train("ball.cslseq --label-names names.txt"),
            vec!["names.txt, line 2", "not-a-number"],
        ),
    ];
    let mut failures = Vec::new();
    for (line, expected) in &cases {
        let args = shlex::split(line).unwrap();
        let Some(out) = run_in(d, &args, PROBE_TIMEOUT) else {
            failures.push(format!("{line}: still running after {PROBE_TIMEOUT:?}"));
            continue;
        };
        let err = String::from_utf8_lossy(&out.stderr);
        let missing: Vec<&&str> = expected.iter().filter(|e| !err.contains(**e)).collect();
        match out.status.code() {
            Some(0) => failures.push(format!("{line}: succeeded\n{err}")),
            Some(101) | None => failures.push(format!("{line}: crashed\n{err}")),
            Some(_) if !missing.is_empty() => {
                failures.push(format!("{line}: message lacks {missing:?}:\n{err}"))
            }
            Some(_) => {}
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} bad inputs:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n\n")
    );
}
