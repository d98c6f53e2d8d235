//! Printing to standard output and standard error without panicking: `println!` and
//! `eprintln!` panic when the write fails (a closed pipe, a full disk), which killed
//! `dynaslice info m.dsm | head -1` with exit status 101 and made `train … 2>/dev/full` lose its
//! model.
//!
//! - Standard output carries a command's answer (`info`, `query`, tables, scripts):
//!   [`outln!`] and [`out_bytes`] return an error to pass on with `?`. A closed pipe ends the
//!   command quietly with success, as ripgrep does ([`is_closed_pipe`]); any other failure (a
//!   full disk) becomes one `error:` line.
//! - Standard error carries reports, progress and warnings: [`errln!`] drops what cannot be
//!   written, so a full or closed standard error never stops the work.

use std::fmt::{self, Arguments};
use std::io::{self, Write};

/// Writes one formatted line to standard output; returns [`StdoutError`] if that fails.
macro_rules! outln {
    () => {
        $crate::console::stdout(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::console::stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// Writes one formatted line to standard error, dropping it if that fails.
macro_rules! errln {
    () => {
        $crate::console::stderr(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::console::stderr(format_args!("{}\n", format_args!($($arg)*)))
    };
}

pub(crate) use {errln, outln};

/// Standard output could not be written.
#[derive(Debug)]
pub struct StdoutError(io::Error);

impl fmt::Display for StdoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write to standard output: {}", self.0)
    }
}

// No `source`: the message already quotes the I/O error, which `{:#}` would print twice.
impl std::error::Error for StdoutError {}

/// Writes `args` to standard output and flushes it, so that a failure shows at this line
/// rather than at exit (where the standard library drops it silently). The body of [`outln!`].
pub fn stdout(args: Arguments) -> Result<(), StdoutError> {
    let mut out = io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| out.flush())
        .map_err(StdoutError)
}

/// Writes `bytes` to standard output and flushes it.
pub fn out_bytes(bytes: &[u8]) -> Result<(), StdoutError> {
    let mut out = io::stdout().lock();
    out.write_all(bytes)
        .and_then(|()| out.flush())
        .map_err(StdoutError)
}

/// Writes `args` to standard error; a failure is dropped (there is nowhere left to report it).
/// The body of [`errln!`].
pub fn stderr(args: Arguments) {
    let _ = io::stderr().lock().write_fmt(args);
}

/// Whether `error` (or one of its causes) is standard output's reader having gone away
/// (`| head -1`): the command ends quietly with success, as ripgrep does.
pub fn is_closed_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        cause
            .downcast_ref::<StdoutError>()
            .is_some_and(|e| e.0.kind() == io::ErrorKind::BrokenPipe)
    })
}
