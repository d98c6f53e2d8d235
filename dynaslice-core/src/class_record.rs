//! A model's class records (`docs/model-format.md`): what each output channel is called and the
//! label it had in its source, 64 bytes each after the header.

use crate::Error;

/// Size of one class record in bytes.
pub const CLASS_RECORD_SIZE: usize = 64;
/// Longest class name, in bytes of UTF-8.
pub const MAX_NAME_LEN: usize = 56;

/// Name and source label value of one class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClassInfo<'a> {
    /// Human-readable name (at most [`MAX_NAME_LEN`] bytes of UTF-8).
    pub name: &'a str,
    /// The label value this class had in its source (e.g. the segmentation's label number).
    pub label: i32,
}

/// One class record: `label: i32`, `name_len: u32`, `name: [u8; 56]` (zero-padded UTF-8).
pub(crate) struct ClassRecord;

impl ClassRecord {
    /// Decodes and validates a 64-byte record of class `k` (1-based, for errors).
    pub(crate) fn decode(raw: &[u8], k: u32) -> Result<ClassInfo<'_>, Error> {
        let bad = Error::BadClassRecord { class: k };
        if raw.len() != CLASS_RECORD_SIZE {
            return Err(bad);
        }
        let word = |i: usize| [raw[i], raw[i + 1], raw[i + 2], raw[i + 3]];
        let label = i32::from_le_bytes(word(0));
        let len = u32::from_le_bytes(word(4)) as usize;
        let field = &raw[8..];
        if len > MAX_NAME_LEN || field[len..].iter().any(|&b| b != 0) {
            return Err(bad);
        }
        let name = core::str::from_utf8(&field[..len]).map_err(|_| bad)?;
        Ok(ClassInfo { name, label })
    }
}
