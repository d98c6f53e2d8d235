//! The whole training job, as `dynaslice train` and Python's `dynaslice.train` run it: from the
//! input and the options to the run's files. The front ends map their flags or keywords onto an
//! [`InputSpec`] and a [`TrainSpec`], call [`run`] with an [`Observer`] that shows the progress,
//! and say how the run ended; nothing of the job is computed anywhere else.
//!
//! [`run`] checks the options ([`TrainSpec::validate`]), the outputs ([`Plan`]: the model, its
//! loss log and curve, claimed for the whole run) and the checkpoint's fate
//! ([`RunFiles::check_state`]) before the input is read; reads the input; trains
//! ([`crate::fit`]); validates the model once, writes it with its loss log and curve; and checks
//! each class's extent against its contours ([`extent::check_model`]), telling the observer of
//! what the data does not support.
//!
//! The curve is drawn by the front end's [`DrawCurve`] (both pass
//! `dynaslice_figures::plot::loss_curve`), called here while the outputs are claimed, so the
//! trainer carries no plotting code and the files are the same from every front end.

use crate::fit::{fit_checked, InputRecord, Observer, RunFiles, Trained};
use crate::journal::TERM_NAMES;
use crate::spec::TrainSpec;
use anyhow::{anyhow, Result};
use dynaslice_data::input_spec::InputSpec;
use dynaslice_metrics::extent::{self, Warning};
use dynaslice_model::ModelFile;
use dynaslice_output::{Kind, Plan};
use std::path::Path;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_set_by_name_as_the_command_line_reads_them() {
        let (mut spec, mut input) = (TrainSpec::default(), InputSpec::default());
        set(&mut spec, &mut input, "lr", "0.002").unwrap();
        set(&mut spec, &mut input, "widths", "32, 24").unwrap();
        set(&mut spec, &mut input, "no_orientation", "True").unwrap();
        set(&mut spec, &mut input, "rotated-planes", "8").unwrap();
        assert_eq!(
            (spec.lr, spec.widths.clone(), spec.no_orientation),
            (Some(0.002), Some(vec![32, 24]), true)
        );
        assert_eq!(input.rotated_planes, Some(8));
        assert_eq!(
            set(&mut spec, &mut input, "lr", "-1"),
            Err(SetError::Invalid(
                "lr: -1: out of range; allowed: a number > 0 and ≤ 10".into()
            ))
        );
        let e = set(&mut spec, &mut input, "labels", "1,x").unwrap_err();
        assert!(
            matches!(&e, SetError::Invalid(m) if m.starts_with("labels \"1,x\": \"x\"")),
            "{e:?}"
        );
        assert_eq!(
            set(&mut spec, &mut input, "omega", "3"),
            Err(SetError::Unknown)
        );
    }
}

/// How the front end's user names the output and the override, for the messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Words {
    /// The output's option: `-o`, or Python's `output`.
    pub output: &'static str,
    /// The override: `--force`, or Python's `force=True`.
    pub force: &'static str,
    /// The continuation: `--resume`, or Python's `resume=True`.
    pub resume: &'static str,
}

impl Words {
    /// `dynaslice train`'s.
    pub const COMMAND_LINE: Words = Words {
        output: "-o",
        force: "--force",
        resume: "--resume",
    };
    /// Python's `dynaslice.train`'s.
    pub const PYTHON: Words = Words {
        output: "output",
        force: "force=True",
        resume: "resume=True",
    };
}

/// What draws a run's loss curve: writes the PNG `path` (atomically) of the `rows`, each a step
/// and its values in the order of the term `names`, one line per term against the step. The
/// front ends pass `dynaslice_figures::plot::loss_curve`.
pub type DrawCurve = fn(path: &Path, names: &[&str], rows: &[(u64, &[f64])]) -> Result<()>;

/// A training job: what to read, how to train, where to write.
#[derive(Clone, Debug)]
pub struct Job<'a> {
    /// The inputs and how to read them.
    pub input: &'a InputSpec,
    /// The training options.
    pub spec: &'a TrainSpec,
    /// The model file; the loss log, curve and checkpoint go beside it ([`RunFiles::beside`]).
    pub output: &'a Path,
    /// The front end's words for its options.
    pub words: Words,
    /// What draws the loss curve ([`RunFiles::png`]).
    pub curve: DrawCurve,
}

impl<'a> Job<'a> {
    /// The job of training on `input` as `spec` says, writing `output` with its loss curve
    /// drawn by `curve`, in the messages the `words` of the front end.
    pub fn new(
        input: &'a InputSpec,
        spec: &'a TrainSpec,
        output: &'a Path,
        words: Words,
        curve: DrawCurve,
    ) -> Self {
        Job {
            input,
            spec,
            output,
            words,
            curve,
        }
    }
}

/// How a job ended.
pub struct Finished {
    /// The run's files.
    pub files: RunFiles,
    /// What training produced. Where [`Trained::stopped`], the checkpoint holds the run and
    /// nothing else was written.
    pub trained: Trained,
    /// What the model shows that its input does not support (already told to the observer).
    pub warnings: Vec<Warning>,
}

impl Finished {
    /// Where a stopped run stands, for the error that ends the front end's call: "interrupted
    /// at step 120 of 3000: checkpoint m.dsm.ckpt saved, no model written; continue with
    /// `how`".
    pub fn interrupted(&self, how: &str) -> String {
        format!(
            "interrupted at step {} of {}: checkpoint {} saved, no model written; continue with \
             {how}",
            self.trained.steps_done,
            self.trained.schedule_steps,
            self.files.checkpoint.display()
        )
    }
}

/// Why [`set`] refused an option.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SetError {
    /// No option of `dynaslice train` has the name.
    Unknown,
    /// The value does not parse, or is out of range: the message names the option.
    Invalid(String),
}

/// Sets the option `key` of `dynaslice train` (its flag without `--`, `_` or `-`) from the
/// command line's text of its value: a training option of the table ([`crate::flags`]) on
/// `spec`, an input option ([`InputSpec::set`]) on `input`. How a front end that takes options
/// by name (Python's keywords) reads them exactly as the command line does.
pub fn set(
    spec: &mut TrainSpec,
    input: &mut InputSpec,
    key: &str,
    text: &str,
) -> Result<(), SetError> {
    let key = key.replace('-', "_");
    match crate::flags::find(&key) {
        Some(flag) => {
            let value = flag
                .parse(text)
                .map_err(|e| SetError::Invalid(format!("{key}: {text}: {e}")))?;
            spec.set(flag.name, value)
                .map_err(|e| SetError::Invalid(format!("{}: {}", e.option, e.message)))
        }
        None if dynaslice_data::input_flags::find(&key).is_some() => input
            .set(&key, text)
            .map_err(|e| SetError::Invalid(format!("{key} {text:?}: {e}"))),
        None => Err(SetError::Unknown),
    }
}

/// `spec` with every option it leaves unset taken from how `file`'s model read its input (its
/// run record's `frames` and `reading`), so that a command given the training input again (the
/// extent check, the report's plane view, a picture) reads it as training did (`--labels`,
/// `--planes`, …) without the options given again; with a note naming what was taken, where
/// anything was, for the front end to show.
pub fn input_as_trained(
    mut spec: InputSpec,
    file: &ModelFile,
) -> Result<(InputSpec, Option<String>)> {
    let record = file.record();
    let mut taken = Vec::new();
    if spec.frames.is_none() {
        if let Some(frames) = &record.frames {
            spec.frames = Some(frames.parse().map_err(|e| {
                anyhow!("{}: recorded frames {frames:?}: {e}", file.path().display())
            })?);
            taken.push(format!("frames={frames}"));
        }
    }
    if let Some(reading) = &record.reading {
        let before = spec.clone();
        spec = spec
            .with_reading(reading)
            .map_err(|e| anyhow!("{}: {e}", file.path().display()))?;
        if spec != before {
            taken.push(reading.clone());
        }
    }
    let note = (!taken.is_empty()).then(|| {
        format!(
            "reading {} as {} was trained ({}); give the options to read it otherwise",
            spec.describe(),
            file.path().display(),
            taken.join("; ")
        )
    });
    Ok((spec, note))
}

/// Runs `job`, telling `observer` of its progress, notes and warnings (see the module's doc).
pub fn run(job: &Job, observer: &mut dyn Observer) -> Result<Finished> {
    let (input, spec) = (job.input, job.spec);
    spec.validate()?;
    let files = RunFiles::beside(job.output);
    // Held for the whole run: every file below is claimed, so a second run on the same output
    // refuses and what is on disk comes from one run.
    let mut plan = Plan::new(input.inputs.iter().chain(&input.label_names), spec.force)
        .force_option(job.words.force);
    plan.file(job.words.output, &files.model, Kind::Model)?;
    plan.beside(&files.csv)?;
    plan.beside(&files.png)?;
    // The run's state may exist: a checkpoint to resume (or, with force, to replace).
    plan.continued(&files.checkpoint)?;
    plan.continued(&files.journal)?;
    let resuming = files.check_state(spec)?;
    if spec.resume && !resuming {
        observer.note(&format!(
            "{}: no checkpoint at {}; starting at step 0",
            job.words.resume,
            files.checkpoint.display()
        ));
    }
    observer.note(&format!("reading {}", input.describe()));
    let (seq, space, units) = input.read_with_space()?;
    let record = InputRecord {
        description: input.describe(),
        frames: input.frames().to_string(),
        reading: input.reading(),
        space,
        units,
        time_unit: input.time_unit()?,
    };
    let trained = fit_checked(&seq, spec, &record, Some((&files, resuming)), observer)?;
    if trained.stopped {
        return Ok(Finished {
            files,
            trained,
            warnings: Vec::new(),
        });
    }
    // The one full validation of the model, CRC included, before it is written and checked.
    let model = trained
        .bytes
        .model()
        .map_err(|e| anyhow!("the trained model does not validate: {e}"))?;
    trained.write(&files)?;
    let rows: Vec<(u64, &[f64])> = trained.rows.iter().map(|r| (r.0, &r.1[..])).collect();
    (job.curve)(&files.png, &TERM_NAMES, &rows)?;
    // Outputs that contradict the data are reported: a class reaching far past its contours,
    // or far larger than they allow (`dynaslice info MODEL INPUT` repeats the check).
    let warnings = extent::check_model(&model, &seq, |done, total| observer.checking(done, total))?;
    for w in &warnings {
        observer.warning(&format!("{}: {w}", files.model.display()));
    }
    drop(plan);
    Ok(Finished {
        files,
        trained,
        warnings,
    })
}
