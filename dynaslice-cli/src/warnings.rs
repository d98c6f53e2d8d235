//! Printing the libraries' warnings (input repairs and skips, reported through the `log`
//! facade) on standard error, as `warning: …`, the way errors are printed as `error: …`.

use super::console::errln;
use log::{Level, LevelFilter, Log, Metadata, Record};

/// The logger: warnings and errors of every crate, nothing more verbose.
struct Stderr;

impl Log for Stderr {
    fn enabled(&self, metadata: &Metadata) -> bool {
        metadata.level() <= Level::Warn
    }

    fn log(&self, record: &Record) {
        if self.enabled(record.metadata()) {
            let level = if record.level() == Level::Error {
                "error"
            } else {
                "warning"
            };
            errln!("{level}: {}", record.args());
        }
    }

    fn flush(&self) {}
}

/// Installs the logger (once; later calls change nothing).
pub fn install() {
    static LOGGER: Stderr = Stderr;
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(LevelFilter::Warn);
    }
}
