//! `dynaslice train` end to end on a small .csl sequence the test writes: outputs, and a real
//! run killed mid-way then resumed, which must end with the same model, bit for bit, as an
//! uninterrupted run.

use dynaslice_core::ModelBytes;
use std::process::Stdio;
use std::time::{Duration, Instant};

mod common;

use common::{succeeded, train_command, write_sequence};

#[test]
fn trains_writes_outputs_and_resumes_bit_for_bit_after_a_kill() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_sequence(dir.path());

    // Uninterrupted reference run.
    let straight = dir.path().join("straight.dsm");
    let out = train_command(&input, &straight, &["--steps", "1500"])
        .output()
        .unwrap();
    succeeded(&out);
    let bytes = ModelBytes::read(&straight).unwrap();
    let model = bytes.model().unwrap();
    assert_eq!(model.domain().time_range(), (0.0, 2.0));
    assert!(
        model.omega_t_max() > 0.0,
        "three frames: temporal control is on"
    );
    let mut f = [0.0];
    model.eval([0.0, 0.0, 0.0], 1.0, &mut f).unwrap();
    assert!(f[0] < 0.0, "the centre is inside: {}", f[0]);
    model.eval([11.0, 9.0, 0.0], 1.0, &mut f).unwrap();
    assert!(f[0] > 0.0, "far away is outside: {}", f[0]);
    let csv = std::fs::read_to_string(dir.path().join("straight.dsm.loss.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1501, "header + one line per step");
    let png = std::fs::read(dir.path().join("straight.dsm.loss.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    for state in ["straight.dsm.ckpt", "straight.dsm.ckpt.loss.csv"] {
        assert!(
            !dir.path().join(state).exists(),
            "a finished run removes {state}"
        );
    }

    // The same run, killed once its checkpoint holds some progress, then resumed.
    let resumed = dir.path().join("resumed.dsm");
    let ckpt = dir.path().join("resumed.dsm.ckpt");
    let mut child = train_command(
        &input,
        &resumed,
        &["--steps", "1500", "--checkpoint-minutes", "0"],
    )
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let start = Instant::now();
    while std::fs::metadata(&ckpt).map(|m| m.len()).unwrap_or(0) == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no checkpoint appeared"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!resumed.exists(), "killed before the end: no model yet");
    // Checkpoint layout: magic, fingerprint, then the step (see dynaslice-optim/src/checkpoint.rs).
    let saved = std::fs::read(&ckpt).unwrap();
    let step = u64::from_le_bytes(saved[16..24].try_into().unwrap());
    assert!(step > 0 && step < 1500, "killed mid-way, at step {step}");
    let out = train_command(&input, &resumed, &["--steps", "1500", "--resume"])
        .output()
        .unwrap();
    succeeded(&out);
    assert_eq!(
        std::fs::read(&resumed).unwrap(),
        bytes.as_bytes(),
        "resumed model differs from the uninterrupted one"
    );
    assert!(
        !ckpt.exists(),
        "the resumed run, finished, removes its checkpoint"
    );
}

#[test]
fn bad_inputs_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.csl");
    let out = train_command(&missing, &dir.path().join("m.dsm"), &["--steps", "1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("nope.csl"), "{err}");
    let odd = dir.path().join("data.xyz");
    std::fs::write(&odd, "1 2 3").unwrap();
    let out = train_command(&odd, &dir.path().join("m.dsm"), &["--steps", "1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("not a kind of input DynaSlice reads"),
        "{err}"
    );
    let input = write_sequence(dir.path());
    let out = train_command(&input, &dir.path().join("m.dsm"), &["--frames", "5:9"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no frame"), "{err}");
    // A range past the last of the 3 frames is cut there, as a Python slice is, and said.
    let out = train_command(
        &input,
        &dir.path().join("m.dsm"),
        &["--frames", "0:9", "--steps", "1"],
    )
    .output()
    .unwrap();
    succeeded(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("frames 0:9:1: the input has 3 frames, so the range ends at frame 2 (not 8)"),
        "{err}"
    );
}

/// Per-class weights are checked against the data's classes and recorded in the model.
#[test]
fn class_weights_are_validated_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let input = common::write_sequence(dir.path());
    let model = dir.path().join("w.dsm");
    let out = common::train_command(&input, &model, &["--steps", "2", "--class-weights", "1,2"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--class-weights: 2 class weights for 1 classes"),
        "{err}"
    );
    let out = common::train_command(&input, &model, &["--steps", "2", "--class-weights", "3"])
        .output()
        .unwrap();
    succeeded(&out);
    let bytes = ModelBytes::read(&model).unwrap();
    let m = bytes.model().unwrap();
    assert!(
        m.metadata().contains("class_weights = [3.0]"),
        "{}",
        m.metadata()
    );
}

/// Ctrl-C mid-run saves the checkpoint and prints the command that continues; a run without
/// --resume refuses to discard that checkpoint (leaving it byte for byte); the printed command
/// resumes, says from where, and its loss log runs from step 1 to the end without a gap.
#[test]
fn interrupt_refusal_and_resumed_loss_log() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_sequence(dir.path());
    let model = dir.path().join("r.dsm");
    let ckpt = dir.path().join("r.dsm.ckpt");
    let journal = dir.path().join("r.dsm.ckpt.loss.csv");
    let mut child = train_command(
        &input,
        &model,
        &["--steps", "1500", "--checkpoint-minutes", "0"],
    )
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    let start = Instant::now();
    let rows = || {
        std::fs::read_to_string(&journal)
            .map(|s| s.lines().count())
            .unwrap_or(0)
    };
    while rows() < 50 {
        assert!(start.elapsed() < Duration::from_secs(60), "no loss rows");
        assert!(child.try_wait().unwrap().is_none(), "ended too soon");
        std::thread::sleep(Duration::from_millis(10));
    }
    let kill = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("interrupted at step") && err.contains("r.dsm.ckpt"),
        "{err}"
    );
    assert!(!model.exists(), "an interrupted run writes no model");
    let saved = std::fs::read(&ckpt).unwrap();
    let step = u64::from_le_bytes(saved[16..24].try_into().unwrap());
    assert!(step > 0 && step < 1500, "{step}");
    let command = err
        .lines()
        .skip_while(|l| !l.contains("continue with"))
        .nth(1)
        .expect("the resume command")
        .trim()
        .to_string();
    assert!(command.ends_with("--resume"), "{command}");

    // Without --resume: refused, nothing touched.
    let out = train_command(&input, &model, &["--steps", "1500"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--resume") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(std::fs::read(&ckpt).unwrap(), saved);

    // The printed command continues the run.
    let args = shlex::split(&command).unwrap();
    let out = std::process::Command::new(&args[0])
        .args(&args[1..])
        .output()
        .unwrap();
    let err = succeeded(&out);
    let err = err + &String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("at step {step} of 1500")) && err.contains("resumed from"),
        "{err}"
    );
    let csv = std::fs::read_to_string(dir.path().join("r.dsm.loss.csv")).unwrap();
    let steps: Vec<u64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(steps, (1..=1500).collect::<Vec<u64>>());
    assert!(dir.path().join("r.dsm.loss.png").exists());
}

/// `--minutes` without `--steps` plans the schedule to the time, not to the default 3000 steps,
/// and records the plan in the model's metadata.
#[test]
fn a_timed_run_plans_past_the_default_step_count() {
    let dir = tempfile::tempdir().unwrap();
    let input = write_sequence(dir.path());
    let model = dir.path().join("timed.dsm");
    let out = train_command(&input, &model, &["--minutes", "0.2"])
        .output()
        .unwrap();
    succeeded(&out);
    let bytes = ModelBytes::read(&model).unwrap();
    let metadata = bytes.model().unwrap().metadata().to_string();
    let value = |key: &str| -> u64 {
        let line = metadata
            .lines()
            .find_map(|l| l.strip_prefix(&format!("{key} = ")))
            .unwrap_or_else(|| panic!("no {key} in\n{metadata}"));
        line.parse().unwrap()
    };
    let (planned, done) = (value("planned_steps"), value("steps_done"));
    assert!(done <= planned, "{done} steps of a {planned}-step plan");
    // Capped at the default 3000, a run this fast would stop at 3000 with a 3000-step plan.
    assert!(
        done > 3000 || planned < 3000,
        "planned {planned}, done {done}: the plan was capped at the default --steps"
    );
    let csv = std::fs::read_to_string(dir.path().join("timed.dsm.loss.csv")).unwrap();
    assert_eq!(
        csv.lines().count() as u64,
        done + 1,
        "header + one line per step"
    );
}
