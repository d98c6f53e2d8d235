//! A DICOM Part 10 file held in memory, parsed by dicom-rs with every declared length checked
//! where the parse decodes it.
//!
//! dicom-rs 0.10 reserves and zero-fills a value's declared length before reading it
//! (`StatefulDecoder::read_value*`, the file meta reader's `read_str_body`, a pixel data item's
//! offset table), so a corrupted 1 kB file declaring a 4 GB element takes 4 GB. A walk over the
//! headers before the parse cannot rule that out: it decodes the file its own way, and wherever
//! the two disagree (where the meta group ends, an item delimiter's VR, nesting) the parse meets
//! headers the walk never saw. So the check sits inside the one decoder the parse uses:
//! [`Bounded`] wraps dicom-rs's stateful decoder and refuses every element or item header that
//! declares more bytes than are left, before the data set reader can act on it. No value can
//! then take more than the file's size.
//!
//! The file meta group is read with the same decoder (explicit VR little endian), not with
//! `FileMetaTable::from_reader`, which trusts the declared lengths. The data set is built from the
//! data set reader's tokens here rather than by `InMemDicomObject::read_dataset`, whose recursion
//! follows the file's nesting: a file of a million nested empty sequences would overflow the
//! stack. Here nesting deeper than [`MAX_NESTING`] is an error.

use std::cell::RefCell;
use std::io::{Cursor, Seek, Write};

use dicom_core::header::{DataElementHeader, Length, SequenceItemHeader};
use dicom_core::value::{DataSetSequence, PrimitiveValue};
use dicom_core::{DataElement, Tag, VR};
use dicom_dictionary_std::{tags, uids};
use dicom_object::InMemDicomObject;
use dicom_parser::dataset::read::{DataSetReaderOptions, Error as ReadError};
use dicom_parser::dataset::{DataSetReader, DataToken};
use dicom_parser::stateful::decode::{
    DynStatefulDecoder, Error as DecodeError, Result as DecodeResult, StatefulDecode,
};
use dicom_transfer_syntax_registry::{TransferSyntax, TransferSyntaxIndex, TransferSyntaxRegistry};

use super::{chain, dicom, MAX_NESTING};
use dynaslice_sequence::error::{DataError, Result};

/// How a DICOM file was laid out, where it is not a plain Part 10 file (for a warning).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Layout {
    /// A Part 10 file: `DICM` (after the preamble or at byte 0) and a file meta group.
    Part10,
    /// A bare data set, with no preamble, no `DICM` and no file meta group (older exports;
    /// what DCMTK reads and pydicom reads with `force=True`), in this transfer syntax.
    Bare(&'static str),
}

/// Largest data set a deflated file may inflate to: the cap on an RT Structure Set's size.
const MAX_INFLATED_BYTES: u64 = super::MAX_FILE_BYTES;

/// Parses a whole DICOM file into its data set, up to Pixel Data (an RT Structure Set has
/// none): a Part 10 file with or without its 128-byte preamble, or a bare data set (see
/// [`Layout`]); a deflated data set is inflated first (at most [`MAX_INFLATED_BYTES`]). Errors
/// name the element and its byte offset where they concern one; the caller adds the file.
pub(super) fn read_object(bytes: &[u8]) -> Result<(InMemDicomObject, Layout)> {
    let refusal = RefCell::new(None);
    let result = parse(bytes, &refusal);
    // A refused length is the cause of whatever error dicom-rs then reported.
    match refusal.into_inner() {
        Some(what) => Err(dicom(what)),
        None => result,
    }
}

/// The transfer syntax of a bare data set (no file meta group) starting at `bytes`, if it
/// starts like one: an element of group 0008 (Identifying: every RT Structure Set's first
/// group), explicit VR little endian where a VR's two letters follow the tag, else implicit.
fn bare_data_set(bytes: &[u8]) -> Option<&'static str> {
    let head = bytes.get(..8)?;
    if head[..2] != [0x08, 0x00] {
        return None;
    }
    let vr = [head[4], head[5]];
    Some(
        if VR::from_binary(vr).is_some() && vr.iter().all(u8::is_ascii_uppercase) {
            uids::EXPLICIT_VR_LITTLE_ENDIAN
        } else {
            uids::IMPLICIT_VR_LITTLE_ENDIAN
        },
    )
}

fn unreadable(what: impl std::fmt::Display) -> DataError {
    dicom(format!("not a readable DICOM file: {what}"))
}

/// `element (GGGG,EEEE)`, `file meta element (0002,EEEE)`.
fn element(tag: Tag) -> String {
    let meta = if tag.0 == 0x0002 { "file meta " } else { "" };
    format!("{meta}element ({:04X},{:04X})", tag.0, tag.1)
}

fn parse(bytes: &[u8], refusal: &RefCell<Option<String>>) -> Result<(InMemDicomObject, Layout)> {
    // The preamble as dicom-rs's `open_file` detects it.
    let start = if bytes.get(128..132) == Some(b"DICM") {
        Some(132)
    } else if bytes.starts_with(b"DICM") {
        Some(4)
    } else {
        None
    };
    let (uid, data_start, layout) = match start {
        Some(start) => {
            let (uid, data_start) = file_meta(bytes, start, refusal)?;
            (uid, data_start, Layout::Part10)
        }
        None => {
            let uid = bare_data_set(bytes).ok_or_else(|| {
                unreadable(
                    "no `DICM` marker at byte 0 or 128, and it does not start like a data set \
                     (an element of group 0008)",
                )
            })?;
            (uid.to_string(), 0, Layout::Bare(uid))
        }
    };
    let ts = TransferSyntaxRegistry
        .get(&uid)
        .ok_or_else(|| dicom(format!("unsupported transfer syntax {uid}")))?;
    if uid == uids::DEFLATED_EXPLICIT_VR_LITTLE_ENDIAN {
        // Inflated here (raw deflate, PS3.5 A.5) and parsed as explicit VR little endian
        // through the same bounded decoder: every declared length is then checked against the
        // inflated size, itself capped.
        let mut inflated = Vec::new();
        std::io::Read::read_to_end(
            &mut std::io::Read::take(
                flate2::read::DeflateDecoder::new(&bytes[data_start..]),
                MAX_INFLATED_BYTES + 1,
            ),
            &mut inflated,
        )
        .map_err(|e| {
            unreadable(format!(
                "transfer syntax {uid} (deflated): the data set does not inflate: {e}"
            ))
        })?;
        if inflated.len() as u64 > MAX_INFLATED_BYTES {
            return Err(dicom(format!(
                "the deflated data set inflates to over {MAX_INFLATED_BYTES} bytes, the limit \
                 for an RT Structure Set"
            )));
        }
        let explicit = TransferSyntaxRegistry
            .get(uids::EXPLICIT_VR_LITTLE_ENDIAN)
            .ok_or_else(|| dicom("dicom-rs lacks explicit VR little endian".into()))?;
        // Offsets in messages are then offsets into the inflated data set.
        let decoder = Bounded::new(&inflated, 0, explicit, refusal)?;
        let mut tokens = DataSetReader::new(decoder, DataSetReaderOptions::default());
        return Ok((build_object(&mut tokens, 0, false)?, layout));
    }
    if !(ts.is_codec_free() || ts.is_encapsulated_pixel_data()) {
        return Err(dicom(format!(
            "unsupported transfer syntax {uid} ({}): its data set is compressed",
            ts.name()
        )));
    }
    let decoder = Bounded::new(&bytes[data_start..], data_start, ts, refusal)?;
    let mut tokens = DataSetReader::new(decoder, DataSetReaderOptions::default());
    Ok((build_object(&mut tokens, 0, false)?, layout))
}

/// Reads the file meta group from `start` (just after `DICM`): explicit VR little endian
/// elements of group 0002, up to the first element of another group (where pydicom also ends
/// it; the group length (0002,0000) is not needed). Returns the Transfer Syntax UID and where
/// the data set begins.
fn file_meta(
    bytes: &[u8],
    start: usize,
    refusal: &RefCell<Option<String>>,
) -> Result<(String, usize)> {
    let explicit = TransferSyntaxRegistry
        .get(uids::EXPLICIT_VR_LITTLE_ENDIAN)
        .ok_or_else(|| dicom("dicom-rs lacks explicit VR little endian".into()))?;
    let mut decoder = Bounded::new(&bytes[start..], start, explicit, refusal)?;
    let meta = |e: DecodeError| unreadable(format!("file meta group: {}", chain(&e)));
    let mut uid = None;
    // Each turn consumes at least an 8-byte header, so this ends.
    loop {
        let at = decoder.offset();
        let group = usize::try_from(at)
            .ok()
            .and_then(|at| bytes.get(at..at.checked_add(2)?));
        if group != Some(&[0x02, 0x00]) {
            break;
        }
        let header = decoder.decode_header().map_err(meta)?;
        let Some(len) = header.len.get() else {
            return Err(unreadable(format!(
                "{} at byte {at} has an undefined length",
                element(header.tag)
            )));
        };
        if header.tag == tags::TRANSFER_SYNTAX_UID {
            let mut value = Vec::new();
            decoder.read_to_vec(len, &mut value).map_err(meta)?;
            let text = String::from_utf8_lossy(&value);
            uid = Some(
                text.trim_matches(|c: char| c == '\0' || c.is_whitespace())
                    .to_string(),
            );
        } else {
            decoder.skip_bytes(len).map_err(meta)?;
        }
    }
    let data_start = start + decoder.inner.position() as usize;
    let uid = uid.ok_or_else(|| {
        let end = match bytes.get(data_start..data_start + 4) {
            Some(t) => format!(
                "which ends at byte {data_start}, where {} begins",
                element(Tag(
                    u16::from_le_bytes([t[0], t[1]]),
                    u16::from_le_bytes([t[2], t[3]])
                ))
            ),
            None => "which ends with the file".into(),
        };
        unreadable(format!(
            "the file meta group ({end}) has no Transfer Syntax UID (0002,0010)"
        ))
    })?;
    Ok((uid, data_start))
}

/// dicom-rs's stateful decoder over a part of the file, refusing any declared length beyond the
/// bytes left in it.
struct Bounded<'a> {
    inner: DynStatefulDecoder<Cursor<&'a [u8]>>,
    /// Bytes the decoder reads from.
    len: u64,
    /// File offset of the decoder's first byte, for messages.
    base: u64,
    /// The first refusal, in words: dicom-rs's error type has no variant that could carry it.
    refusal: &'a RefCell<Option<String>>,
}

impl<'a> Bounded<'a> {
    fn new(
        bytes: &'a [u8],
        base: usize,
        ts: &TransferSyntax,
        refusal: &'a RefCell<Option<String>>,
    ) -> Result<Self> {
        let inner = DynStatefulDecoder::new_with_ts(Cursor::new(bytes), ts, 0)
            .map_err(|e| dicom(format!("transfer syntax {}: {}", ts.uid(), chain(&e))))?;
        Ok(Bounded {
            inner,
            len: bytes.len() as u64,
            base: base as u64,
            refusal,
        })
    }

    /// File offset of the next byte to decode.
    fn offset(&self) -> u64 {
        self.base + self.inner.position()
    }

    /// Refuses `len` bytes declared by `what` (which began at file offset `at`) where fewer are
    /// left; an undefined length is the data set reader's to handle.
    fn check(&self, len: Length, at: u64, what: impl FnOnce() -> String) -> DecodeResult<()> {
        let Some(n) = len.get() else {
            return Ok(());
        };
        let left = self.len.saturating_sub(self.inner.position());
        if u64::from(n) <= left {
            return Ok(());
        }
        let mut refusal = self.refusal.borrow_mut();
        if refusal.is_none() {
            *refusal = Some(format!(
                "{} declares {n} bytes at byte {at}, more than the {left} bytes left in the file",
                what()
            ));
        }
        // Any error ends the parse; `read_object` reports the refusal above instead.
        Err(DecodeError::AllocateValueData { len: n })
    }

    /// Checks a value about to be read (already checked with its header; kept so that no
    /// length reaches dicom-rs's allocations unchecked, whatever calls these).
    fn check_value(&self, len: Length) -> DecodeResult<()> {
        self.check(len, self.offset(), || "a value".into())
    }
}

impl<'a> StatefulDecode for Bounded<'a> {
    type Reader = Cursor<&'a [u8]>;

    fn decode_header(&mut self) -> DecodeResult<DataElementHeader> {
        let at = self.offset();
        let header = self.inner.decode_header()?;
        self.check(header.len, at, || element(header.tag))?;
        Ok(header)
    }

    fn decode_item_header(&mut self) -> DecodeResult<SequenceItemHeader> {
        let at = self.offset();
        let header = self.inner.decode_item_header()?;
        if let SequenceItemHeader::Item { len } = header {
            self.check(len, at, || "a sequence item".into())?;
        }
        Ok(header)
    }

    fn read_value(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check_value(header.len)?;
        self.inner.read_value(header)
    }

    fn read_value_preserved(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check_value(header.len)?;
        self.inner.read_value_preserved(header)
    }

    fn read_value_bytes(&mut self, header: &DataElementHeader) -> DecodeResult<PrimitiveValue> {
        self.check_value(header.len)?;
        self.inner.read_value_bytes(header)
    }

    fn read_to_vec(&mut self, length: u32, vec: &mut Vec<u8>) -> DecodeResult<()> {
        self.check_value(Length(length))?;
        self.inner.read_to_vec(length, vec)
    }

    fn read_u32_to_vec(&mut self, length: u32, vec: &mut Vec<u32>) -> DecodeResult<()> {
        self.check_value(Length(length))?;
        self.inner.read_u32_to_vec(length, vec)
    }

    fn read_to<W>(&mut self, length: u32, out: W) -> DecodeResult<()>
    where
        Self: Sized,
        W: Write,
    {
        self.check_value(Length(length))?;
        self.inner.read_to(length, out)
    }

    fn skip_bytes(&mut self, length: u32) -> DecodeResult<()> {
        self.check_value(Length(length))?;
        self.inner.skip_bytes(length)
    }

    fn seek(&mut self, position: u64) -> DecodeResult<()>
    where
        Self::Reader: Seek,
    {
        self.inner.seek(position)
    }

    fn position(&self) -> u64 {
        self.inner.position()
    }
}

type Tokens<'a> = DataSetReader<Bounded<'a>>;

fn read_error(e: ReadError) -> DataError {
    unreadable(chain(&e))
}

fn unexpected(token: DataToken) -> DataError {
    unreadable(format!("unexpected {token} in the data set"))
}

/// Builds the data set (`in_item`: a sequence item's, ending at its ItemEnd) inside `depth`
/// sequences. At the top level, reading stops at Pixel Data (an RT Structure Set has none, and
/// nothing after it is needed).
fn build_object(tokens: &mut Tokens, depth: usize, in_item: bool) -> Result<InMemDicomObject> {
    let mut obj = InMemDicomObject::new_empty();
    let top = depth == 0;
    while let Some(token) = tokens.next() {
        match token.map_err(read_error)? {
            DataToken::ElementHeader(header) => {
                if top && header.tag >= tags::PIXEL_DATA {
                    break;
                }
                let value = match tokens.next() {
                    Some(Ok(DataToken::PrimitiveValue(v))) => v,
                    Some(Err(e)) => return Err(read_error(e)),
                    Some(Ok(other)) => return Err(unexpected(other)),
                    None => {
                        return Err(unreadable(format!(
                            "the file ends before the value of {}",
                            element(header.tag)
                        )))
                    }
                };
                obj.put(DataElement::new(header.tag, header.vr, value));
            }
            DataToken::SequenceStart { tag, len } => {
                if top && tag >= tags::PIXEL_DATA {
                    break;
                }
                if depth == MAX_NESTING {
                    return Err(dicom(format!(
                        "sequence {} is nested in {depth} others, more than the limit of \
                         {MAX_NESTING} nested sequences",
                        element(tag)
                    )));
                }
                let items = build_sequence(tokens, depth + 1)?;
                obj.put(DataElement::new(
                    tag,
                    VR::SQ,
                    DataSetSequence::new(items, len),
                ));
            }
            DataToken::PixelSequenceStart if top => break,
            // Encapsulated pixel data in an item (an icon image): not needed, skipped.
            DataToken::PixelSequenceStart => skip_pixel_sequence(tokens)?,
            DataToken::ItemEnd if in_item => return Ok(obj),
            other => return Err(unexpected(other)),
        }
    }
    if in_item {
        return Err(unreadable("the file ends inside a sequence item"));
    }
    Ok(obj)
}

/// The items of a sequence whose SequenceStart was just read, `depth` sequences deep.
fn build_sequence(tokens: &mut Tokens, depth: usize) -> Result<Vec<InMemDicomObject>> {
    let mut items = Vec::new();
    while let Some(token) = tokens.next() {
        match token.map_err(read_error)? {
            DataToken::ItemStart { .. } => items.push(build_object(tokens, depth, true)?),
            DataToken::SequenceEnd => return Ok(items),
            other => return Err(unexpected(other)),
        }
    }
    Err(unreadable("the file ends inside a sequence"))
}

/// Reads past the fragments of encapsulated pixel data to its SequenceEnd.
fn skip_pixel_sequence(tokens: &mut Tokens) -> Result<()> {
    for token in tokens {
        match token.map_err(read_error)? {
            DataToken::SequenceEnd => return Ok(()),
            DataToken::ItemStart { .. }
            | DataToken::ItemEnd
            | DataToken::ItemValue(_)
            | DataToken::OffsetTable(_) => {}
            other => return Err(unexpected(other)),
        }
    }
    Err(unreadable("the file ends inside encapsulated pixel data"))
}
