//! The one way to train a model: a [`Sequence`] and a [`TrainSpec`] in, a model file's bytes
//! and the loss log out. The command line, the Python package, the lab and the benchmarks are
//! adapters over [`fit`]: they map their flags and keywords onto a [`TrainSpec`], watch the run
//! through an [`Observer`] and write what it returns ([`Trained::write`]).
//!
//! [`fit`] fixes the normalised frame ([`domain_for`]) and the temporal bound (Eq. 4,
//! [`temporal_bound`]), runs every check that can run before training (the options, the
//! input's fit to the model format, the per-class weights), builds the sampler, runs the loop
//! ([`trainer::train`], with its time planning and checkpoints) while journaling the loss rows
//! ([`crate::journal`]), and builds the model file ([`TrainedModel`]).

use crate::data_sampler::{domain_for, DataSampler};
use crate::journal::{self, Journal, LossRow};
use crate::model_file::{check_model_limits, TrainedModel};
use crate::spatial_bound::plane_band;
use crate::spec::{SpecError, TrainSpec, MAX_STEPS};
use crate::temporal_bound::temporal_bound;
use crate::trainer::{self, Progress, TrainOptions};
use crate::warp::{motion_options, SHAPE_TEMPORAL_FACTOR};
use anyhow::{anyhow, bail, Context, Result};
use dynaslice_core::ModelBytes;
use dynaslice_model::RunRecord;
use dynaslice_output::write_atomically;
use dynaslice_sequence::nesting::to_labels;
use dynaslice_sequence::{Sequence, Space, TimeUnit, Units};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The files of one training run, all beside the model: `MODEL.loss.csv` (one row per step),
/// `MODEL.loss.png` (the curve, drawn by the front end's [`crate::job::DrawCurve`]), and while
/// the run goes the checkpoint `MODEL.ckpt` and its loss rows `MODEL.ckpt.loss.csv`, which a
/// finished run removes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunFiles {
    /// The model file.
    pub model: PathBuf,
    /// The loss log.
    pub csv: PathBuf,
    /// The loss curve.
    pub png: PathBuf,
    /// The checkpoint.
    pub checkpoint: PathBuf,
    /// The loss rows the checkpoint covers, appended as the run goes.
    pub journal: PathBuf,
}

impl RunFiles {
    /// The files of a run writing `model`.
    pub fn beside(model: &Path) -> RunFiles {
        let beside = |suffix: &str| {
            let mut s = model.as_os_str().to_owned();
            s.push(suffix);
            PathBuf::from(s)
        };
        RunFiles {
            model: model.to_path_buf(),
            csv: beside(".loss.csv"),
            png: beside(".loss.png"),
            checkpoint: beside(".ckpt"),
            journal: beside(".ckpt.loss.csv"),
        }
    }

    /// Whether a run of `spec` may start with the state found on disk: an existing checkpoint
    /// needs `resume` (continue it) or `force` (discard it); a journal without a checkpoint
    /// (a run killed before its first checkpoint) is replaced; anything else at the journal's
    /// path (a user's file, a link) needs `force`, as the model does. Returns whether the run
    /// resumes from a checkpoint.
    pub fn check_state(&self, spec: &TrainSpec) -> Result<bool> {
        if !spec.force && !journal::is_journal(&self.journal) {
            bail!(
                "{} exists and is not a training run's loss journal; it would be replaced and \
                 then removed: move it, or force to replace it (--force, force=True)",
                self.journal.display()
            );
        }
        let has_checkpoint = self.checkpoint.exists();
        if has_checkpoint && !spec.resume && !spec.force {
            bail!(
                "{} holds the checkpoint of an earlier run; resume to continue it (--resume, \
                 resume=True), or force to start afresh and replace it (--force, force=True)",
                self.checkpoint.display()
            );
        }
        // A journal without its checkpoint is the leftover of a run killed before its first
        // checkpoint: rows of no state, which nothing can continue. It does not block a fresh
        // start: the run's first step rewrites it ([`crate::journal::Journal::record`]).
        Ok(has_checkpoint && spec.resume)
    }
}

/// What the inputs were, as the model's metadata records it.
#[derive(Clone, Debug, PartialEq)]
pub struct InputRecord {
    /// The inputs, as the user named them (`a.nii.gz + b.nii.gz`).
    pub description: String,
    /// The frames kept (`A:B:STEP`).
    pub frames: String,
    /// The input options it was read with (dynaslice-data's `InputSpec::reading`), if any.
    pub reading: Option<String>,
    /// The patient frame of the inputs' coordinates, which outputs default to.
    pub space: Space,
    /// The inputs' length unit.
    pub units: Units,
    /// The unit of the inputs' times.
    pub time_unit: TimeUnit,
}

impl InputRecord {
    /// The record's `input`, `frames`, `reading`, `space`, `units` and `time_unit`.
    fn record(&self) -> RunRecord {
        RunRecord {
            input: Some(self.description.clone()),
            frames: Some(self.frames.clone()),
            reading: self.reading.clone(),
            space: Some(self.space),
            units: Some(self.units),
            time_unit: Some(self.time_unit),
            ..RunRecord::default()
        }
    }
}

/// Watches a run: called after every step, and with notes worth telling the user.
pub trait Observer {
    /// After each step; `Break` stops the run (it is checkpointed and [`Trained::stopped`]).
    fn step(&mut self, progress: &Progress) -> ControlFlow<()>;
    /// A line for the user (e.g. "resumed from … at step 120 of 3000").
    fn note(&mut self, line: &str);
    /// Once, after the input is read and indexed, just before the first step: from here on
    /// a stop ([`Observer::step`]) saves a checkpoint. Nothing by default.
    fn training(&mut self) {}
    /// The index of exact in-plane distances being built before the first step: `done` of
    /// `total` annotations. Nothing by default.
    fn indexing(&mut self, done: usize, total: usize) {
        let _ = (done, total);
    }
    /// The check of the finished model against its input ([`crate::job::run`]): `done` of
    /// `total` times meshed. Nothing by default.
    fn checking(&mut self, done: usize, total: usize) {
        let _ = (done, total);
    }
    /// A warning about the finished model (a class reaching far past its contours): by default
    /// a `log` warning, which the command line prints as `warning: …` and Python's `logging`
    /// receives (logger `dynaslice_train.fit`).
    fn warning(&mut self, line: &str) {
        log::warn!("{line}");
    }
}

/// An observer that lets the run go to the end and says nothing.
pub struct Quiet;

impl Observer for Quiet {
    fn step(&mut self, _: &Progress) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
    fn note(&mut self, _: &str) {}
}

/// A run's result.
pub struct Trained {
    /// The model file (validated by [`fit`], and by [`crate::job::run`] before it is written).
    pub bytes: ModelBytes,
    /// The loss rows from step 1.
    pub rows: Vec<LossRow>,
    /// Steps completed.
    pub steps_done: u64,
    /// The schedule's length (a timed run's plan where it made one).
    pub schedule_steps: u64,
    /// This process's training wall time.
    pub elapsed: Duration,
    /// The median time of this process's steps after its first (none: fewer than two steps).
    pub median_step_seconds: Option<f64>,
    /// The observer stopped the run before its schedule ended: the checkpoint holds it and
    /// [`Trained::write`] refuses.
    pub stopped: bool,
}

impl Trained {
    /// Writes the model and its loss log (each atomically) and, the run being finished,
    /// removes its checkpoint and journal. The loss curve (`files.png`) is drawn by the front
    /// end's function ([`crate::job::DrawCurve`]).
    pub fn write(&self, files: &RunFiles) -> Result<()> {
        if self.stopped {
            bail!(
                "stopped at step {} of {}: checkpoint {} kept, no model written",
                self.steps_done,
                self.schedule_steps,
                files.checkpoint.display()
            );
        }
        write_atomically(&files.model, &self.bytes)?;
        write_atomically(&files.csv, journal::csv(&self.rows).as_bytes())?;
        for state in [&files.checkpoint, &files.journal] {
            match std::fs::remove_file(state) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => {
                    return Err(e).with_context(|| format!("cannot remove {}", state.display()))
                }
            }
        }
        Ok(())
    }
}

/// Trains a model of `seq` as `spec` asks. With `files`, the run checkpoints beside
/// `files.model` and journals its loss rows, and resumes from an earlier checkpoint where
/// `spec.resume` says so (see [`RunFiles::check_state`]); without, it keeps everything in
/// memory (the lab, benchmarks). Option errors come before any work, as [`SpecError`]s. The
/// whole run with its files is [`crate::job::run`].
pub fn fit(
    seq: &Sequence,
    spec: &TrainSpec,
    input: &InputRecord,
    files: Option<&RunFiles>,
    observer: &mut dyn Observer,
) -> Result<Trained> {
    spec.validate()?;
    let files = match files {
        Some(f) => Some((f, f.check_state(spec)?)),
        None => None,
    };
    let trained = fit_checked(seq, spec, input, files, observer)?;
    trained
        .bytes
        .model()
        .map_err(|e| anyhow!("the trained model does not validate: {e}"))?;
    Ok(trained)
}

/// [`fit`] for a caller that has validated `spec` and decided the checkpoint's fate
/// (`files` with whether the run resumes), and validates the model it returns itself: each
/// check runs once per run.
pub(crate) fn fit_checked(
    seq: &Sequence,
    spec: &TrainSpec,
    input: &InputRecord,
    files: Option<(&RunFiles, bool)>,
    observer: &mut dyn Observer,
) -> Result<Trained> {
    let (files, resuming) = match files {
        Some((f, resuming)) => (Some(f), resuming),
        None => (None, false),
    };
    let classes = seq.classes();
    spec.check_classes(classes.len())?;
    let domain = domain_for(seq);
    check_model_limits(classes, &domain).map_err(|e| anyhow!("{}: {e}", input.description))?;
    let motion = motion_options(seq, &domain, spec.motion, !spec.no_temporal_control);
    // Carried by a motion network, the shape keeps a narrower band of its own (unless
    // `--temporal-factor` says otherwise): its time input is the residual of shapes that
    // really change, so the motion goes to u (`warp::SHAPE_TEMPORAL_FACTOR`).
    let temporal_factor = match (&motion, spec.temporal_factor) {
        (Some(_), None) => SHAPE_TEMPORAL_FACTOR,
        _ => spec.temporal_factor(),
    };
    let omega_t_max = temporal_bound(seq, &domain, temporal_factor, !spec.no_temporal_control);
    let plane_band = plane_band(seq, &domain, temporal_factor, !spec.no_plane_band);
    let options = TrainOptions {
        plane_band,
        motion,
        ..spec.options(omega_t_max, files.map(|f| f.checkpoint.clone()))
    };
    let counts = spec.counts();
    observer.note(&format!(
        "{}: {} classes, {} frames, {} planes; domain centre {:?}, half-width {:.4}, time {}..{}; \
         ω_t^max {omega_t_max}; {}; ω₀ {}; building the sampling index (the exact in-plane \
         distances)",
        input.description,
        classes.len(),
        seq.frames().len(),
        seq.frames().iter().map(|f| f.planes.len()).sum::<usize>(),
        domain.center,
        domain.scale[0],
        domain.time_origin,
        domain.time_origin + domain.time_span,
        match (&options.plane_band, spec.no_plane_band) {
            (Some(b), _) => format!(
                "|⟨ω_x, n⟩| ≤ {} across the parallel planes (n {:?})",
                b.max, b.normal
            ),
            (None, true) => "plane band off: ω_x unbounded".into(),
            (None, false) => "planes not all parallel: ω_x unbounded".into(),
        },
        options.omega_0,
    ));
    observer.note(&match (&options.motion, spec.motion) {
        (Some(m), _) => format!(
            "a moving input: each structure's shape is carried by a motion network ({:?}, ω₀ {}, \
             ω_t^max {})",
            m.widths, m.omega_0, m.omega_t_max
        ),
        (None, true) => "one annotated time: no motion network".into(),
        (None, false) => "no motion network (--motion carries each shape by one)".into(),
    });
    let mut sampler =
        DataSampler::with_progress(seq, domain, counts, &mut |d, t| observer.indexing(d, t));
    let extent_margin = sampler.extents().map(|e| e.margin() as f32);
    observer.note(&match extent_margin {
        Some(m) => format!(
            "each class is held outside its contours' box grown by {m:.4} (half the planes' \
             spacing): it ends where its contours end"
        ),
        None => "planes not all parallel: no class held to its contours' box".into(),
    });
    let pairs = sampler.neighbour_pairs();
    observer.note(&if pairs.iter().any(|&n| n > 0) {
        format!(
            "between neighbouring planes that both outline a class ({} pairs per class), f is \
             held on the side of their in-plane distances blended (the loss column between)",
            pairs
                .iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    } else {
        "no two neighbouring parallel planes outline one class: no targets between planes".into()
    });
    if let Some(w) = &spec.class_weights {
        sampler = sampler.with_class_weights(w).map_err(|message| SpecError {
            option: "class_weights",
            message,
        })?;
    }
    let earlier = match files {
        Some(f) if resuming => journal::read(&f.journal, MAX_STEPS)?,
        _ => Vec::new(),
    };
    let mut journal = Journal::new(files.map(|f| f.journal.clone()), earlier);
    let mut failure = None;
    let mut stopped = false;
    let checkpoint = files.map(|f| f.checkpoint.display().to_string());
    observer.training();
    let outcome = trainer::train(&options, classes.len(), &mut sampler, |p| {
        match journal.record(LossRow::of(p.step, &p.terms, p.loss)) {
            Ok(Some(missing)) => {
                let start = p.step - 1;
                observer.note(&format!(
                    "resumed from {} at step {start} of {}",
                    checkpoint.as_deref().unwrap_or("the checkpoint"),
                    p.steps
                ));
                if missing > 0 {
                    observer.note(&format!(
                        "the loss log lacks the rows of {missing} of the checkpoint's {start} steps"
                    ));
                }
            }
            Ok(None) => {}
            Err(e) => {
                failure = Some(e);
                return ControlFlow::Break(());
            }
        }
        let flow = observer.step(p);
        stopped |= flow.is_break();
        flow
    })
    .context("training failed")?;
    if let Some(e) = failure {
        return Err(e.context("the loss log failed; the checkpoint is saved"));
    }
    if outcome.last.is_none() && outcome.steps_done > 0 {
        observer.note(&format!(
            "{} already holds all {} steps",
            checkpoint.as_deref().unwrap_or("the checkpoint"),
            outcome.steps_done
        ));
    }
    if outcome.steps_done == 0 {
        bail!(
            "no training step finished within {} minutes; no model written",
            spec.minutes.unwrap_or_default()
        );
    }
    let bytes = TrainedModel {
        outcome: &outcome,
        domain,
        classes,
        options: &options,
        counts,
        temporal_factor,
        class_weights: spec.class_weights.as_deref(),
        extent_margin,
        between_pairs: pairs
            .iter()
            .any(|&n| n > 0)
            .then(|| pairs.iter().map(|&n| n as u32).collect()),
        // Classes drawn nested and trained disjoint: outputs recompose the outer from it.
        input: RunRecord {
            nesting: (!seq.nesting().is_empty()).then(|| {
                to_labels(
                    &classes.iter().map(|c| c.label).collect::<Vec<_>>(),
                    seq.nesting(),
                )
            }),
            ..input.record()
        },
    }
    .to_bytes()
    .map_err(|e| anyhow!("cannot write the model: {e}"))?;
    Ok(Trained {
        bytes,
        rows: journal.into_rows(outcome.steps_done),
        steps_done: outcome.steps_done,
        schedule_steps: outcome.planned_steps.unwrap_or(options.steps),
        elapsed: outcome.elapsed,
        median_step_seconds: outcome.median_step_seconds,
        stopped,
    })
}
