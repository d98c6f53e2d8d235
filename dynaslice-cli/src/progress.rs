//! Progress of a command's long work, so that no step is silent for more than a few seconds: on
//! a terminal an indicatif bar that redraws itself every second; elsewhere (a log file, a pipe,
//! the demo captured) a line `WHAT done/total, S s` whenever [`QUIET`] has passed without a line,
//! and a last one at the end of work that printed any, so the next step follows within `QUIET`.

use super::console::errln;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The longest a command stays silent when its standard error is not a terminal: 4 s, so that
/// a line comes within the promised 5 s even after a training step or a loaded machine's
/// scheduling delay (the demo measured 5.3 s with a 5 s interval).
pub(crate) const QUIET: Duration = Duration::from_secs(4);

/// The counts a non-terminal progress line reports, shared with its ticker thread.
struct State {
    what: String,
    done: u64,
    total: u64,
    last_line: Instant,
    /// Whether a progress line was printed: then the end gets one too, so the next step's
    /// first line follows within [`QUIET`].
    printed: bool,
    finished: bool,
}

/// Progress over `total` steps of one piece of work (frames, times, …).
pub(crate) struct Progress {
    bar: Option<ProgressBar>,
    state: Arc<(Mutex<State>, Condvar)>,
    ticker: Option<JoinHandle<()>>,
}

impl Progress {
    /// Progress over `total` steps, described by `what` ("meshing the exact shapes: frame").
    pub(crate) fn new(what: &str, total: u64) -> Progress {
        let terminal = std::io::stderr().is_terminal();
        let start = Instant::now();
        let state = Arc::new((
            Mutex::new(State {
                what: what.to_string(),
                done: 0,
                total,
                last_line: start,
                printed: false,
                finished: false,
            }),
            Condvar::new(),
        ));
        if terminal {
            let bar = ProgressBar::new(total);
            bar.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:30}] {msg} {pos}/{len} ETA {eta}",
                )
                .expect("valid template")
                .progress_chars("=> "),
            );
            bar.set_message(what.to_string());
            bar.enable_steady_tick(Duration::from_secs(1));
            return Progress {
                bar: Some(bar),
                state,
                ticker: None,
            };
        }
        let shared = Arc::clone(&state);
        let ticker = std::thread::spawn(move || {
            let (lock, wake) = &*shared;
            let mut s = lock.lock().expect("progress state");
            while !s.finished {
                let due = s.last_line + QUIET;
                let now = Instant::now();
                if now >= due {
                    errln!(
                        "{} {}/{}, {:.0} s",
                        s.what,
                        s.done,
                        s.total,
                        start.elapsed().as_secs_f64()
                    );
                    s.last_line = now;
                    s.printed = true;
                } else {
                    s = wake.wait_timeout(s, due - now).expect("progress state").0;
                }
            }
            if s.printed {
                errln!(
                    "{} {}/{} in {:.0} s",
                    s.what,
                    s.done,
                    s.total,
                    start.elapsed().as_secs_f64()
                );
            }
        });
        Progress {
            bar: None,
            state,
            ticker: Some(ticker),
        }
    }

    /// Marks `done` steps finished.
    pub(crate) fn set_position(&self, done: u64) {
        if let Some(bar) = &self.bar {
            bar.set_position(done);
        }
        self.state.0.lock().expect("progress state").done = done;
    }

    /// Marks one more step finished.
    pub(crate) fn inc(&self) {
        let done = self.state.0.lock().expect("progress state").done + 1;
        self.set_position(done);
    }

    /// Prints `line` on standard error without breaking the bar (and counts it as a line).
    pub(crate) fn println(&self, line: impl AsRef<str>) {
        match &self.bar {
            Some(bar) => bar.println(line.as_ref()),
            None => {
                let mut s = self.state.0.lock().expect("progress state");
                errln!("{}", line.as_ref());
                s.last_line = Instant::now();
            }
        }
    }

    /// Clears the bar, or stops the progress lines.
    pub(crate) fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        self.state.0.lock().expect("progress state").finished = true;
        self.state.1.notify_all();
        if let Some(ticker) = self.ticker.take() {
            let _ = ticker.join();
        }
    }
}

impl Drop for Progress {
    /// An error part-way through stops the lines too.
    fn drop(&mut self) {
        self.stop();
    }
}
