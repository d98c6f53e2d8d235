//! SIGINT (Ctrl-C), SIGTERM (what `kill`, `timeout`, Slurm and `docker stop` send) and SIGHUP
//! (a closed terminal), handled alike by every command.
//!
//! While training ([`graceful`]) the first signal asks the run to stop after its current step,
//! save its checkpoint and print the command that continues it; a second one ends the process
//! at once. Before a training run's first step ([`before_training`]: reading, tracing,
//! indexing) there is nothing to save: a signal ends it at once and says that nothing was
//! trained. Anywhere else a signal ends the process at once, after removing what the run made
//! only for its duration: its outputs' temporaries, its `.NAME.lock` claims and the folders an
//! unfinished output set created (`dynaslice_output::cleanup`). The exit status is 130 for
//! every one of the three signals (the `ctrlc` crate does not say which came).

use super::console::errln;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// The exit status of a run ended by a signal.
pub const EXIT_INTERRUPTED: i32 = 130;

/// Set by a signal while a [`Graceful`] guard lives: training stops after the current step.
static STOP: AtomicBool = AtomicBool::new(false);

/// Live [`Graceful`] guards.
static GRACEFUL: AtomicUsize = AtomicUsize::new(0);

/// Set while a training run has not reached its first step ([`BeforeTraining`]).
static BEFORE_TRAINING: AtomicBool = AtomicBool::new(false);

/// Installs the handler, once, at the start of the process.
pub fn install() {
    let installed = ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) > 0 && !STOP.swap(true, Ordering::SeqCst) {
            errln!(
                "\ninterrupted: stopping after this step to save the checkpoint (interrupt \
                 again to quit without it)"
            );
            return;
        }
        if BEFORE_TRAINING.load(Ordering::SeqCst) {
            errln!("\ninterrupted before the first training step: nothing was trained or written");
        }
        dynaslice_output::cleanup::remove_all_and_exit(EXIT_INTERRUPTED)
    });
    if let Err(e) = installed {
        log::warn!("signals will end the run without removing its temporary files: {e}");
    }
}

/// While the returned guard lives, a first signal only asks the work to stop
/// ([`stop_requested`]) instead of ending the process.
pub fn graceful() -> Graceful {
    GRACEFUL.fetch_add(1, Ordering::SeqCst);
    BEFORE_TRAINING.store(false, Ordering::SeqCst);
    Graceful(())
}

/// Marks a training run that has not begun its first step, until the guard is dropped or
/// [`graceful`] is called: a signal then ends it at once (after the usual removals), saying
/// that nothing was trained.
pub fn before_training() -> BeforeTraining {
    BEFORE_TRAINING.store(true, Ordering::SeqCst);
    BeforeTraining(())
}

/// See [`before_training`].
pub struct BeforeTraining(());

impl Drop for BeforeTraining {
    fn drop(&mut self) {
        BEFORE_TRAINING.store(false, Ordering::SeqCst);
    }
}

/// See [`graceful`].
pub struct Graceful(());

impl Drop for Graceful {
    fn drop(&mut self) {
        GRACEFUL.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Whether a signal asked the work to stop.
pub fn stop_requested() -> bool {
    STOP.load(Ordering::SeqCst)
}
