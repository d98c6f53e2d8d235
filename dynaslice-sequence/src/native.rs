//! The native format: one JSON document holding a whole [`Sequence`] (schema and example in
//! `docs/data-format.md`), easy to write from a script and exact to read back.
//!
//! Exactness: numbers are written with the shortest representation that parses back to the same
//! `f64` and read with correct rounding (serde_json's `float_roundtrip`), and a validated sequence
//! is already canonical, so `read(write(s)) == s` bit for bit.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{DataError, ErrorKind, Result};
use crate::input_file;
use crate::sequence::{ClassInfo, Frame, Sequence};

/// Value of the document's `format` field.
pub const FORMAT_NAME: &str = "dynaslice-sections";
/// The format version this reader writes and accepts.
pub const FORMAT_VERSION: u32 = 1;

/// Bytes a native JSON file may hold (the cap on what is read: the parsed sequence takes about
/// as much memory again).
pub const MAX_BYTES: u64 = 1 << 30;

#[derive(Serialize)]
struct DocumentRef<'a> {
    format: &'static str,
    version: u32,
    classes: &'a [ClassInfo],
    frames: &'a [Frame],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Document {
    format: String,
    version: u32,
    classes: Vec<ClassInfo>,
    frames: Vec<Frame>,
}

/// Serialises `seq` as a native JSON document.
pub fn to_json(seq: &Sequence) -> String {
    let doc = DocumentRef {
        format: FORMAT_NAME,
        version: FORMAT_VERSION,
        classes: seq.classes(),
        frames: seq.frames(),
    };
    // Serialising plain structs of finite numbers and strings cannot fail.
    serde_json::to_string(&doc).unwrap_or_default()
}

/// A 64-bit FNV-1a digest of `seq`'s native JSON document, streamed (no document is held in
/// memory): equal for equal sequences, and what a checkpoint records of its training data.
pub fn digest(seq: &Sequence) -> u64 {
    struct Fnv(u64);
    impl std::io::Write for Fnv {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            for &b in bytes {
                self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
            }
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let doc = DocumentRef {
        format: FORMAT_NAME,
        version: FORMAT_VERSION,
        classes: seq.classes(),
        frames: seq.frames(),
    };
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    // Writing plain structs of finite numbers into a sink that never fails cannot fail.
    let _ = serde_json::to_writer(&mut h, &doc);
    h.0
}

/// Parses and validates a native JSON document. Parse errors name the line, column and the path
/// of the offending value (e.g. `frames[2].planes[3].origin`), hence timestep and plane.
pub fn from_json(text: &str) -> Result<Sequence> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let doc: Document = serde_path_to_error::deserialize(de).map_err(|e| {
        let line = e.inner().line();
        DataError::new(ErrorKind::Syntax(format!(
            "at {}: {} (column {})",
            e.path(),
            e.inner(),
            e.inner().column()
        )))
        .at_line(line)
    })?;
    if doc.format != FORMAT_NAME {
        return Err(ErrorKind::Syntax(format!(
            "\"format\" is \"{}\", expected \"{FORMAT_NAME}\"",
            doc.format
        ))
        .into());
    }
    if doc.version != FORMAT_VERSION {
        return Err(ErrorKind::Syntax(format!(
            "\"version\" is {}, this reader knows version {FORMAT_VERSION}",
            doc.version
        ))
        .into());
    }
    Sequence::new(doc.classes, doc.frames)
}

/// Reads a native JSON file.
pub fn read(path: &Path) -> Result<Sequence> {
    let text = input_file::read_text(path, MAX_BYTES, "a native JSON sequence")?;
    from_json(&text).map_err(|e| e.in_file(path))
}

/// Writes `seq` to a native JSON file.
pub fn write(seq: &Sequence, path: &Path) -> Result<()> {
    let io = |e: std::io::Error| DataError::new(e.into()).in_file(path);
    let mut out = BufWriter::new(File::create(path).map_err(io)?);
    out.write_all(to_json(seq).as_bytes()).map_err(io)?;
    out.flush().map_err(io)
}
