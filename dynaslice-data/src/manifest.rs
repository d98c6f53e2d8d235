//! Sequence manifests: a text file `NAME.seq` listing single-timestep inputs and their times.
//!
//! One `<time> <path>` per line, paths relative to the manifest, `#` comments and blank lines
//! ignored; the entries may be any single-timestep input ([`crate::input`]): RT Structure Sets,
//! `.csl` files, 3D label maps. `.cslseq` is read the same way (its older name, for `.csl` files).
//! ```text
//! # 4D CT, RT Structure Set per breathing phase (time in % of the cycle)
//! 0    phase00/RS.dcm
//! 10   phase10/RS.dcm
//! 20   phase20/RS.dcm
//! ```
//! Times never decrease down the file; entries of equal time join one timestep (e.g. two
//! structure sets of one phase). Classes are matched by name across entries (see
//! [`crate::combine`]).

use std::path::{Path, PathBuf};

use dynaslice_sequence::error::{excerpt, DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;

/// Lines a manifest may hold: far beyond any real cohort, and a bound on what a hostile file
/// can make us open.
pub const MAX_ENTRIES: usize = 100_000;

/// Bytes of one entry's path: Linux's `PATH_MAX`.
const MAX_PATH_BYTES: usize = 4096;

/// Bytes a manifest may hold.
pub const MAX_BYTES: u64 = 16 << 20;

/// One manifest line: a time and the input read at it.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// World time.
    pub time: f64,
    /// The input, resolved against the manifest's folder.
    pub path: PathBuf,
    /// The manifest line (1-based), for messages.
    pub line: usize,
}

/// Parses a manifest's text; `dir` is the folder paths are relative to.
pub fn parse(text: &str, dir: &Path) -> Result<Vec<Entry>> {
    let mut entries = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = |what: String| DataError::new(ErrorKind::Syntax(what)).at_line(i + 1);
        let (time, path) = line.split_once(char::is_whitespace).ok_or_else(|| {
            at(format!(
                "expected `<time> <path>`, found `{}`",
                excerpt(line)
            ))
        })?;
        let time: f64 = time
            .parse()
            .map_err(|_| at(format!("time `{}` is not a number", excerpt(time))))?;
        if !time.is_finite() {
            return Err(at(format!("time `{time}` is not finite")));
        }
        if let Some(previous) = entries.last().map(|e: &Entry| e.time) {
            if time < previous {
                return Err(at(format!(
                    "time {time} is earlier than the previous entry's {previous} (times never \
                     decrease)"
                )));
            }
        }
        if path.len() > MAX_PATH_BYTES {
            return Err(at(format!(
                "a path of {} bytes; no file system takes paths over {MAX_PATH_BYTES}",
                path.len()
            )));
        }
        if entries.len() == MAX_ENTRIES {
            return Err(at(format!("more than {MAX_ENTRIES} entries")));
        }
        entries.push(Entry {
            time,
            path: dir.join(path.trim()),
            line: i + 1,
        });
    }
    if entries.is_empty() {
        return Err(ErrorKind::Empty("the manifest lists no input".into()).into());
    }
    Ok(entries)
}

/// Reads a manifest file.
pub fn read(path: &Path) -> Result<Vec<Entry>> {
    let text = input_file::read_text(path, MAX_BYTES, "a manifest")?;
    parse(&text, path.parent().unwrap_or(Path::new("."))).map_err(|e| e.in_file(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_times_paths_and_comments() {
        let e = parse("# c\n\n0 a.csl\n 0.5\tsub/b c.dcm \n", Path::new("/d")).unwrap();
        assert_eq!(
            e,
            [
                Entry {
                    time: 0.0,
                    path: "/d/a.csl".into(),
                    line: 3
                },
                Entry {
                    time: 0.5,
                    path: "/d/sub/b c.dcm".into(),
                    line: 4
                }
            ]
        );
    }

    #[test]
    fn errors_name_the_line_and_problem() {
        for (text, line, what) in [
            ("0 a\nx b\n", 2, "not a number"),
            ("nan a\n", 1, "not finite"),
            ("0.5\n", 1, "expected `<time> <path>`"),
            ("1 a\n0.5 b\n", 2, "earlier than the previous entry's 1"),
        ] {
            let e = parse(text, Path::new(".")).unwrap_err();
            assert_eq!(e.location.line, Some(line), "{e}");
            assert!(e.to_string().contains(what), "{e}");
        }
        assert!(parse("# only\n", Path::new("."))
            .unwrap_err()
            .to_string()
            .contains("lists no input"));
    }
}
