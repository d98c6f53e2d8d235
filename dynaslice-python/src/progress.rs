//! The Python side of a training run's progress ([`Watch`]): the `progress` callback and
//! Ctrl-C, polled between steps, and the run's notes and sampling-index progress on standard
//! error, where `dynaslice train` prints them.

use dynaslice_train::{fit::Observer, trainer::Progress};
use pyo3::prelude::*;
use pyo3::types::IntoPyDict;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

/// How often Python is asked for Ctrl-C (and the callback is called) at the most: often enough
/// to stop within a blink, rarely enough to cost nothing next to a step.
const POLL: Duration = Duration::from_millis(50);

/// How often the index's progress is printed while it is built.
const INDEXING_LINES: Duration = Duration::from_secs(4);

/// The run as Python sees it: the `progress` callback and Ctrl-C, polled at most every
/// [`POLL`] (the last poll's time); why training stopped early (Ctrl-C or the callback's
/// exception), raised after the job.
pub struct Watch(Option<Py<PyAny>>, Option<PyErr>, Option<Instant>);

impl Watch {
    /// A watch calling `callback` (when given) with each polled step's figures.
    pub fn new(callback: Option<Py<PyAny>>) -> Watch {
        Watch(callback, None, None)
    }

    /// Why training stopped early: Ctrl-C or the callback's exception; `None` if it did not.
    pub fn stopped_by(self) -> Option<PyErr> {
        self.1
    }
}

impl Observer for Watch {
    fn step(&mut self, p: &Progress) -> ControlFlow<()> {
        if self.2.is_some_and(|t| t.elapsed() < POLL) && p.step < p.steps {
            return ControlFlow::Continue(());
        }
        self.2 = Some(Instant::now());
        let polled = Python::attach(|py| -> PyResult<()> {
            py.check_signals()?;
            if let Some(callback) = &self.0 {
                let info = [("step", p.step), ("steps", p.steps)].into_py_dict(py)?;
                for (key, value) in p.figures() {
                    info.set_item(key, value)?;
                }
                callback.call1(py, (info,))?;
            }
            Ok(())
        });
        self.1 = polled.err();
        self.1
            .as_ref()
            .map_or(ControlFlow::Continue(()), |_| ControlFlow::Break(()))
    }

    fn note(&mut self, line: &str) {
        // Where `dynaslice train` prints it: standard error.
        eprintln!("{line}");
    }

    fn indexing(&mut self, done: usize, total: usize) {
        // A line every few seconds, as the command line prints one, and the last.
        if done == total || self.2.is_none_or(|t| t.elapsed() >= INDEXING_LINES) {
            eprintln!("building the sampling index: annotation {done}/{total}");
            self.2 = Some(Instant::now());
        }
    }
}
