//! What a run leaves on disk if a signal ends it: the files this process made only for the
//! run's duration (its outputs' temporaries, its `.NAME.lock` claims, the folders an
//! [`crate::OutputSet`] created) are listed here while they exist, and
//! [`remove_all_and_exit`] (called by a front end's SIGINT / SIGTERM / SIGHUP handler) removes
//! them before the process ends.
//!
//! The library installs no handler itself: the command line does (the `ctrlc` crate), while
//! Python keeps its own signal handling. A commit of an [`crate::OutputSet`] holds the list's
//! lock while it renames its files, so a signal arriving then waits for the set to be whole
//! (new or old) before the process ends.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// What is removed on a signal, in creation order.
#[derive(Default)]
pub(crate) struct Registry {
    files: Vec<PathBuf>,
    folders: Vec<PathBuf>,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    files: Vec::new(),
    folders: Vec::new(),
});

/// The list, locked; a panic elsewhere does not make it unusable.
pub(crate) fn lock() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

impl Registry {
    /// Lists `path`, a file this process will remove or rename before it ends.
    pub(crate) fn file(&mut self, path: &Path) {
        self.files.push(path.to_path_buf());
    }

    /// Lists `path`, a folder this process created and removes (when empty) on a signal.
    pub(crate) fn folder(&mut self, path: &Path) {
        self.folders.push(path.to_path_buf());
    }

    /// Forgets `path` (renamed into place, or removed).
    pub(crate) fn forget(&mut self, path: &Path) {
        if let Some(i) = self.files.iter().rposition(|p| p == path) {
            self.files.swap_remove(i);
        } else if let Some(i) = self.folders.iter().rposition(|p| p == path) {
            self.folders.swap_remove(i);
        }
    }
}

/// Lists `path` for removal on a signal.
pub(crate) fn register(path: &Path) {
    lock().file(path);
}

/// Forgets `path`.
pub(crate) fn forget(path: &Path) {
    lock().forget(path);
}

/// The paths listed now (temporaries, lock files, then created folders), for tests and
/// diagnostics.
pub fn listed() -> Vec<PathBuf> {
    let list = lock();
    list.files.iter().chain(&list.folders).cloned().collect()
}

/// Removes every listed temporary and lock file and every listed folder left empty, then ends
/// the process with `code` (130 by convention for an interrupt). Holds the list's lock to the
/// end, so no output set commits after this starts and none is left half-renamed. For a
/// front end's signal handler.
pub fn remove_all_and_exit(code: i32) -> ! {
    let list = lock();
    for file in &list.files {
        let _ = std::fs::remove_file(file);
    }
    // Deepest first: a folder created inside another created one.
    for folder in list.folders.iter().rev() {
        let _ = std::fs::remove_dir(folder);
    }
    std::process::exit(code)
}
