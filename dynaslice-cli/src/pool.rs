//! The worker threads of a command's `--threads`.

use anyhow::{Context, Result};

/// A pool of `threads` workers (`None`: one per core) for the command's parallel work.
pub(crate) fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}
