//! The whole training job as the front ends call it: the run's files, the check after training
//! told to the observer, the output refusals in the front end's words, and a stopped run that
//! keeps its checkpoint and writes nothing else.

use dynaslice_data::input_spec::InputSpec;
use dynaslice_figures::plot::loss_curve;
use dynaslice_test_support::fixtures::write_sequence;
use dynaslice_train::fit::Observer;
use dynaslice_train::job::{self, Job, Words};
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::trainer::Progress;
use std::ops::ControlFlow;

/// Records what the job tells it; stops after `stop_at` steps where given.
#[derive(Default)]
struct Record {
    notes: Vec<String>,
    checked: Option<(usize, usize)>,
    warnings: Vec<String>,
    stop_at: Option<u64>,
}

impl Observer for Record {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        match self.stop_at {
            Some(s) if p.step >= s => ControlFlow::Break(()),
            _ => ControlFlow::Continue(()),
        }
    }
    fn note(&mut self, line: &str) {
        self.notes.push(line.to_string());
    }
    fn checking(&mut self, done: usize, total: usize) {
        self.checked = Some((done, total));
    }
    fn warning(&mut self, line: &str) {
        self.warnings.push(line.to_string());
    }
}

fn spec(steps: u64) -> TrainSpec {
    TrainSpec {
        steps: Some(steps),
        threads: Some(1),
        widths: Some(vec![8, 8]),
        contour_samples: Some(64),
        plane_samples: Some(64),
        space_samples: Some(64),
        checkpoint_minutes: Some(0.0),
        ..TrainSpec::default()
    }
}

#[test]
fn the_job_writes_the_runs_files_and_checks_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let input = InputSpec {
        inputs: vec![write_sequence(dir.path())],
        ..InputSpec::default()
    };
    let output = dir.path().join("m.dsm");
    let spec = spec(6);
    let job = Job::new(&input, &spec, &output, Words::PYTHON, loss_curve);
    let mut record = Record::default();
    let finished = job::run(&job, &mut record).unwrap();
    assert!(!finished.trained.stopped);
    assert_eq!(finished.trained.steps_done, 6);
    let written = std::fs::read(&output).unwrap();
    assert_eq!(written, &finished.trained.bytes[..]);
    let csv = std::fs::read_to_string(&finished.files.csv).unwrap();
    assert_eq!(csv.lines().count(), 7, "header and one row per step");
    assert_eq!(&std::fs::read(&finished.files.png).unwrap()[1..4], b"PNG");
    assert!(!finished.files.checkpoint.exists() && !finished.files.journal.exists());
    assert!(
        record.notes.iter().any(|n| n.starts_with("reading ")),
        "{:?}",
        record.notes
    );
    // The extent check ran to its end, and every warning it found was told.
    let (done, total) = record.checked.expect("the check reports its progress");
    assert!(total > 0 && done == total, "{done} of {total}");
    assert_eq!(record.warnings.len(), finished.warnings.len());

    // Again on the same output: refused in the front end's words, the model kept.
    let Err(e) = job::run(&job, &mut Record::default()) else {
        panic!("a second run replaced the model");
    };
    assert!(format!("{e:#}").contains("force=True"), "{e:#}");
    assert_eq!(std::fs::read(&output).unwrap(), written);
}

#[test]
fn a_stopped_job_keeps_its_checkpoint_and_writes_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let input = InputSpec {
        inputs: vec![write_sequence(dir.path())],
        ..InputSpec::default()
    };
    let output = dir.path().join("m.dsm");
    let spec = spec(50);
    let job = Job::new(&input, &spec, &output, Words::COMMAND_LINE, loss_curve);
    let mut record = Record {
        stop_at: Some(2),
        ..Record::default()
    };
    let finished = job::run(&job, &mut record).unwrap();
    assert!(finished.trained.stopped);
    assert!(finished.files.checkpoint.exists());
    assert!(!output.exists() && !finished.files.csv.exists() && !finished.files.png.exists());
    assert!(record.checked.is_none(), "no model, no check");
    let message = finished.interrupted("--resume");
    assert!(
        message.starts_with("interrupted at step 2 of 50") && message.contains("m.dsm.ckpt"),
        "{message}"
    );
}
