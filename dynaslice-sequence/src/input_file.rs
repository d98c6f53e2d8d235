//! Opening a user's file for reading: the one place every reader (and the command line's other
//! inputs) goes through.
//!
//! A path that is not a regular file is refused before it is opened: opening a FIFO for reading
//! blocks until a writer comes, and a device such as `/dev/zero` never ends. The open itself is
//! non-blocking and the opened file is checked again, so a file swapped for a FIFO between the
//! check and the open is refused too. What is read is capped by the format's own bound, so a file
//! that grows while it is read cannot take more memory than that bound either.

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

use crate::error::{DataError, ErrorKind, Result};

/// Why `meta` is not a regular file: `Some("a FIFO")`, …; `None` for a regular file.
fn not_regular(meta: &Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a folder");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO");
        }
        if t.is_char_device() || t.is_block_device() {
            return Some("a device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a plain file")
}

fn refused(path: &Path, what: &'static str) -> DataError {
    DataError::new(ErrorKind::NotRegularFile(what)).in_file(path)
}

/// Checks that `path` (links followed) is a regular file, without opening it; returns its size
/// in bytes. Errors name the file.
pub fn regular_file(path: &Path) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| DataError::new(e.into()).in_file(path))?;
    match not_regular(&meta) {
        Some(what) => Err(refused(path, what)),
        None => Ok(meta.len()),
    }
}

/// [`regular_file`] for a file the caller names as `what` ("reference", "RT Structure Set"),
/// refused with the one message every front end shows: `cannot read {what} {path}: {why}`.
pub fn require(what: &str, path: &Path) -> std::result::Result<u64, String> {
    regular_file(path).map_err(|e| format!("cannot read {what} {}: {}", path.display(), e.kind))
}

/// Opens the regular file `path` for reading (see the [module docs](self)); returns it and its
/// size in bytes.
pub fn open(path: &Path) -> Result<(File, u64)> {
    regular_file(path)?;
    let io = |e: std::io::Error| DataError::new(e.into()).in_file(path);
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        // Non-blocking, so that a FIFO put in the file's place after the check cannot block the
        // open; reads of a regular file ignore the flag.
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if let Some(what) = not_regular(&meta) {
        return Err(refused(path, what));
    }
    Ok((file, meta.len()))
}

/// Reads the whole regular file `path`, refusing one of over `limit` bytes (the bound of the
/// format, `what`, e.g. "a .csl file") before reading it, and stopping at `limit` + 1 bytes if
/// it grows while read.
pub fn read(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let (file, size) = open(path)?;
    let too_large = |size: String| {
        DataError::new(ErrorKind::TooLarge(format!(
            "{size} bytes, over the {limit}-byte limit for {what}"
        )))
        .in_file(path)
    };
    if size > limit {
        return Err(too_large(size.to_string()));
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| DataError::new(e.into()).in_file(path))?;
    if bytes.len() as u64 > limit {
        return Err(too_large("over".into()));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text.
pub fn read_text(path: &Path, limit: u64, what: &str) -> Result<String> {
    String::from_utf8(read(path, limit, what)?).map_err(|e| {
        DataError::new(ErrorKind::Syntax(format!(
            "not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        )))
        .in_file(path)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_folders_devices_and_fifos_and_caps_reads() {
        let dir = tempfile::tempdir().unwrap();
        let e = read(dir.path(), 10, "x").unwrap_err();
        assert!(e.to_string().contains("a folder"), "{e}");
        #[cfg(unix)]
        {
            let e = read(Path::new("/dev/zero"), 10, "x").unwrap_err();
            assert!(e.to_string().contains("/dev/zero") && e.to_string().contains("a device"));
            let fifo = dir.path().join("f.csl");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status();
            if made.is_ok_and(|s| s.success()) {
                // Would block forever if the FIFO were opened for reading.
                let e = read(&fifo, 10, "x").unwrap_err();
                assert!(e.to_string().contains("a FIFO"), "{e}");
            }
        }
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "12345").unwrap();
        assert_eq!(read_text(&file, 5, "x").unwrap(), "12345");
        let e = read(&file, 4, "a test file").unwrap_err();
        assert!(
            e.to_string()
                .contains("over the 4-byte limit for a test file"),
            "{e}"
        );
        let missing = read(&dir.path().join("none"), 4, "x").unwrap_err();
        assert!(missing.to_string().contains("none"), "{missing}");
    }
}
