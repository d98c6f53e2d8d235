//! Closed pipes and full disks on standard output and standard error (issue 29): no command
//! panics (exit status 101). A closed standard output ends the command quietly with success, as
//! ripgrep does; a full one is one `error:` line; a full standard error loses nothing.
//! Also: far finite queries are answered with finite values, and the demo's option ranges are
//! checked before any work.

use dynaslice_test_support::fixtures::two_organ_model;
use std::fs::File;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn dynaslice(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_dynaslice"));
    c.args(args);
    c
}

/// Whether `line` is a progress line (`WHAT done/total, S s` or `WHAT done/total in S s`).
fn is_progress_line(line: &str) -> bool {
    let Some(rest) = line.strip_suffix(" s") else {
        return false;
    };
    [", ", " in "].iter().any(|sep| {
        rest.rsplit_once(sep).is_some_and(|(head, seconds)| {
            let count = head.rsplit_once(' ').map_or(head, |(_, c)| c);
            seconds.parse::<f64>().is_ok()
                && count
                    .split_once('/')
                    .is_some_and(|(a, b)| a.parse::<u64>().is_ok() && b.parse::<u64>().is_ok())
        })
    })
}

#[test]
fn progress_lines_are_told_from_other_lines() {
    assert!(is_progress_line(
        "extent check: meshing the classes, time 2/5, 4 s"
    ));
    assert!(is_progress_line(
        "extent check: meshing the classes, time 5/5 in 7 s"
    ));
    assert!(!is_progress_line(
        "error: cannot write to standard output: Broken pipe"
    ));
    assert!(!is_progress_line(
        "warning: m.dsm: class 1 reaches 3.0 mm past, 4 s"
    ));
}

/// Runs `c` with standard output a pipe whose reader is closed before the command writes.
fn into_closed_pipe(mut c: Command) -> Output {
    let mut child = c
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run dynaslice");
    drop(child.stdout.take());
    child.wait_with_output().expect("wait for dynaslice")
}

fn full() -> Stdio {
    Stdio::from(
        File::options()
            .write(true)
            .open("/dev/full")
            .expect("/dev/full"),
    )
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn model(dir: &Path) -> String {
    let path = dir.join("m.dsm");
    std::fs::write(&path, two_organ_model(true)).unwrap();
    path.to_str().unwrap().to_owned()
}

#[test]
fn a_closed_standard_output_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    let data = dir.path().join("data");
    let synth = [
        "synth",
        "-o",
        data.to_str().unwrap(),
        "--shape",
        "all",
        "--timesteps",
        "2",
        "--plane-resolution",
        "8",
        "--volume-resolution",
        "4",
    ];
    let lines: [&[&str]; 6] = [
        &["info", &m],
        &["query", &m, "--", "0", "0", "0", "0.5"],
        &["completions", "bash"],
        &["man"],
        &["info", &m, "--help"],
        &synth,
    ];
    for args in lines {
        let out = into_closed_pipe(dynaslice(args));
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", stderr(&out));
        // Quietly: nothing on standard error but the progress lines a slow step prints every
        // few seconds (a loaded machine makes even this small model's extent check slow).
        let err = stderr(&out);
        assert!(err.lines().all(is_progress_line), "{args:?}: {err}");
    }
    // The listing stopped; the data sets did not.
    let sets = std::fs::read_dir(&data).unwrap().count();
    assert!(sets >= 3, "{sets} data sets written");
}

#[test]
fn a_full_standard_output_is_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    for args in [&["info", m.as_str()][..], &["completions", "zsh"]] {
        let out = dynaslice(args).stdout(full()).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        assert_eq!(
            stderr(&out),
            "error: cannot write to standard output: No space left on device (os error 28)\n",
            "{args:?}"
        );
    }
}

#[test]
fn a_full_standard_error_loses_no_work() {
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    let ply = dir.path().join("t.ply");
    let series = dir.path().join("series");
    std::fs::create_dir(&series).unwrap();
    let lines: [&[&str]; 2] = [
        &[
            "mesh",
            &m,
            "--time",
            "0.5",
            "--resolution",
            "8",
            "-o",
            ply.to_str().unwrap(),
        ],
        &[
            "mesh",
            &m,
            "--times",
            "0:0.8:2",
            "--resolution",
            "8",
            "--format",
            "vtp",
            "-o",
            series.to_str().unwrap(),
        ],
    ];
    for args in lines {
        let out = dynaslice(args).stderr(full()).output().unwrap();
        assert_eq!(out.status.code(), Some(0), "{args:?}");
    }
    // Two classes: one file per class beside -o (t_class1_….ply, t_class2_….ply).
    let plys = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("t_class") && n.ends_with(".ply"))
        .count();
    assert_eq!(plys, 2);
    assert!(series.join("series.pvd").is_file());
    // An error message that cannot be written still gives the failure status, not a panic.
    let out = dynaslice(&["info", "/nonexistent.dsm"])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn far_finite_queries_are_answered() {
    let dir = tempfile::tempdir().unwrap();
    let m = model(dir.path());
    for (x, t) in [
        ("1e9", "0.5"),
        ("4294967297", "0.5"),
        ("1e30", "0.5"),
        ("1e38", "0.5"),
    ] {
        let out = dynaslice(&["query", &m, "--", x, "0", "0", t])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{x}: {}", stderr(&out));
        assert!(
            !text.contains("NaN") && !text.contains("undefined"),
            "{x}:\n{text}"
        );
        assert!(text.contains("label "), "{text}");
    }
}

#[test]
fn demo_options_are_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("demo");
    let o = out_dir.to_str().unwrap();
    let too_many = vec!["16"; 64].join(",");
    for (args, says) in [
        (vec!["--resolution", "1"], "--resolution"),
        (vec!["--widths", "0"], "--widths"),
        (vec!["--widths", too_many.as_str()], "--widths"),
    ] {
        let mut all = vec!["demo", "-o", o];
        all.extend(&args);
        let out = dynaslice(&all).output().unwrap();
        let err = stderr(&out);
        assert!(!out.status.success(), "{args:?}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("error: error:"), "{args:?}: {err}");
        assert!(
            !err.contains("$ dynaslice synth"),
            "{args:?} ran the demo: {err}"
        );
        assert!(!out_dir.join("data").exists(), "{args:?} synthesised");
    }
}
