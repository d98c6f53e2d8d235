//! The one error type of the core: every failure is a value, never a panic.

use core::fmt;

/// Why a model could not be loaded or a query could not be answered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The buffer is shorter than the structure that was being read.
    Truncated {
        /// Bytes needed.
        needed: u64,
        /// Bytes available.
        available: u64,
    },
    /// The first 8 bytes are not [`crate::format::MAGIC`].
    BadMagic,
    /// The file's format version is not one this library reads.
    UnsupportedVersion(u32),
    /// The header size field disagrees with this version's header.
    BadHeaderSize(u32),
    /// The weight data type code is unknown.
    BadDtype(u32),
    /// A dimension (layer count, width, class count, metadata length) is zero or above its limit.
    BadDimension {
        /// Which dimension.
        what: &'static str,
        /// The value found.
        value: u64,
        /// The largest value allowed.
        max: u64,
    },
    /// A section offset or the file size disagrees with the layout the header implies.
    BadLayout(&'static str),
    /// The CRC32 trailer does not match the file's contents.
    CrcMismatch {
        /// CRC stored in the file.
        stored: u32,
        /// CRC computed over the file.
        computed: u32,
    },
    /// A header field (domain, scale, time range, ω_t^max) is not finite or out of range.
    BadHeaderValue(&'static str),
    /// A weight is NaN or infinite.
    NonFiniteWeight {
        /// Index of the first bad scalar in the weight section.
        index: u64,
    },
    /// A class record is malformed (name not UTF-8, too long, or non-zero padding).
    BadClassRecord {
        /// 1-based class number.
        class: u32,
    },
    /// The metadata section is not UTF-8.
    BadMetadata,
    /// Padding bytes that must be zero are not.
    NonZeroPadding,
    /// The weight section is not aligned for zero-copy reading: place the bytes at an address
    /// that is a multiple of 4 (f32 weights) or 2 (f16 weights), e.g. with a 64-byte aligned
    /// wrapper around `include_bytes!`.
    Misaligned,
    /// This library reads weights zero-copy and so needs a little-endian target.
    BigEndianHost,
    /// An output or input buffer has the wrong length.
    BufferLength {
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A class number is outside 1..=K.
    NoSuchClass(u32),
    /// A model to be written is inconsistent (only produced by the writer).
    InvalidModel(&'static str),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::Truncated { needed, available } => {
                write!(
                    f,
                    "truncated model: needs {needed} bytes, {available} available"
                )
            }
            Error::BadMagic => f.write_str("not a DynaSlice model (bad magic bytes)"),
            Error::UnsupportedVersion(v) => write!(f, "unsupported model format version {v}"),
            Error::BadHeaderSize(s) => write!(f, "bad header size {s}"),
            Error::BadDtype(d) => write!(f, "unknown weight data type code {d}"),
            Error::BadDimension { what, value, max } => {
                write!(f, "{what} = {value} is outside 1..={max}")
            }
            Error::BadLayout(what) => write!(f, "inconsistent file layout: {what}"),
            Error::CrcMismatch { stored, computed } => write!(
                f,
                "CRC mismatch: file says {stored:#010x}, contents give {computed:#010x}"
            ),
            Error::BadHeaderValue(what) => write!(f, "bad header value: {what}"),
            Error::NonFiniteWeight { index } => write!(f, "weight {index} is not finite"),
            Error::BadClassRecord { class } => write!(f, "malformed record for class {class}"),
            Error::BadMetadata => f.write_str("metadata is not valid UTF-8"),
            Error::NonZeroPadding => f.write_str("non-zero padding bytes"),
            Error::Misaligned => f.write_str("weights are not aligned for zero-copy reading"),
            Error::BigEndianHost => f.write_str("big-endian targets are not supported"),
            Error::BufferLength { expected, got } => {
                write!(f, "buffer length {got}, expected {expected}")
            }
            Error::NoSuchClass(k) => write!(f, "no class {k}"),
            Error::InvalidModel(what) => write!(f, "invalid model: {what}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}
