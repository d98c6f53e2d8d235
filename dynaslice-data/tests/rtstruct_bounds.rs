//! RT Structure Sets built byte by byte (no Python needed) in the three transfer syntaxes the
//! reader decodes: a minimal valid structure set reads, and the same file with one declared
//! length made huge (an element, a sequence, an item, deep inside nested sequences of undefined
//! length, or a fragment of encapsulated pixel data in an item) is refused as that header is
//! decoded, with the element and its byte offset named: dicom-rs would otherwise reserve the
//! declared length (up to 4 GiB) before reading it. Also: nesting beyond `MAX_NESTING` is an
//! error, never a stack overflow.

use std::path::{Path, PathBuf};

use dynaslice_data::rtstruct::{read, RoiExtent, MAX_NESTING};

const UNDEFINED: u32 = 0xFFFF_FFFF;
/// The declared length of the corrupted headers: 4 GiB less 16.
const HUGE: u32 = 0xFFFF_FFF0;

/// A transfer syntax: its UID and how it encodes element headers.
#[derive(Clone, Copy, Debug)]
struct Syntax {
    uid: &'static str,
    explicit: bool,
    big: bool,
}

const SYNTAXES: [Syntax; 3] = [
    Syntax {
        uid: "1.2.840.10008.1.2.1",
        explicit: true,
        big: false,
    },
    Syntax {
        uid: "1.2.840.10008.1.2",
        explicit: false,
        big: false,
    },
    Syntax {
        uid: "1.2.840.10008.1.2.2",
        explicit: true,
        big: true,
    },
];

impl Syntax {
    fn u16(self, v: u16) -> [u8; 2] {
        if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }

    fn u32(self, v: u32) -> [u8; 4] {
        if self.big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        }
    }

    fn tag(self, (group, element): (u16, u16)) -> Vec<u8> {
        [self.u16(group), self.u16(element)].concat()
    }

    /// An element header; in explicit VR, the VRs of PS3.5 Table 7.1-2 get a 2-byte length.
    fn header(self, tag: (u16, u16), vr: &str, len: u32) -> Vec<u8> {
        let mut out = self.tag(tag);
        if !self.explicit {
            out.extend(self.u32(len));
        } else if ["CS", "DS", "IS", "LO", "UI", "UL"].contains(&vr) {
            out.extend(vr.as_bytes());
            out.extend(self.u16(len as u16));
        } else {
            out.extend(vr.as_bytes());
            out.extend([0, 0]);
            out.extend(self.u32(len));
        }
        out
    }

    /// A text element, padded to even length with a space.
    fn text(self, tag: (u16, u16), vr: &str, value: &str) -> Vec<u8> {
        let mut value = value.as_bytes().to_vec();
        if value.len() % 2 == 1 {
            value.push(b' ');
        }
        [self.header(tag, vr, value.len() as u32), value].concat()
    }

    /// A sequence of undefined length holding `items`, each an item of undefined length.
    fn sequence(self, tag: (u16, u16), items: &[Vec<u8>]) -> Vec<u8> {
        let mut out = self.header(tag, "SQ", UNDEFINED);
        for item in items {
            out.extend(self.item(UNDEFINED));
            out.extend(item);
            out.extend(self.delimiter(0xE00D));
        }
        out.extend(self.delimiter(0xE0DD));
        out
    }

    /// An item header (FFFE,E000) declaring `len`.
    fn item(self, len: u32) -> Vec<u8> {
        [self.tag((0xFFFE, 0xE000)), self.u32(len).to_vec()].concat()
    }

    /// An item (E00D) or sequence (E0DD) delimiter.
    fn delimiter(self, element: u16) -> Vec<u8> {
        [self.tag((0xFFFE, element)), vec![0; 4]].concat()
    }
}

/// Preamble, `DICM` and a file meta group (always explicit VR little endian) naming `syntax`.
fn part10(syntax: Syntax, data_set: &[u8]) -> Vec<u8> {
    let meta = Syntax {
        uid: "",
        explicit: true,
        big: false,
    };
    let mut uid = syntax.uid.as_bytes().to_vec();
    if uid.len() % 2 == 1 {
        uid.push(0);
    }
    let ts = [meta.header((0x0002, 0x0010), "UI", uid.len() as u32), uid].concat();
    let mut out = vec![0u8; 128];
    out.extend(b"DICM");
    out.extend(meta.header((0x0002, 0x0000), "UL", 4));
    out.extend((ts.len() as u32).to_le_bytes());
    out.extend(ts);
    out.extend(data_set);
    out
}

/// One ROI "GTV" with one triangle; `contour_data` is the ContourData element, given whole so
/// that a test can corrupt its header.
fn structure_set(s: Syntax, contour_data: Vec<u8>) -> Vec<u8> {
    let roi = [
        s.text((0x3006, 0x0022), "IS", "1"),
        s.text((0x3006, 0x0026), "LO", "GTV"),
    ]
    .concat();
    let contour = [
        s.text((0x3006, 0x0042), "CS", "CLOSED_PLANAR"),
        s.text((0x3006, 0x0046), "IS", "3"),
        contour_data,
    ]
    .concat();
    let roi_contour = [
        s.sequence((0x3006, 0x0040), &[contour]),
        s.text((0x3006, 0x0084), "IS", "1"),
    ]
    .concat();
    [
        s.text((0x0008, 0x0060), "CS", "RTSTRUCT"),
        s.sequence((0x3006, 0x0020), &[roi]),
        s.sequence((0x3006, 0x0039), &[roi_contour]),
    ]
    .concat()
}

fn triangle(s: Syntax) -> Vec<u8> {
    s.text((0x3006, 0x0050), "DS", r"0\0\0\10\0\0\0\10\0")
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// Reads `bytes` expecting an error naming the file and containing every one of `expect`.
fn refused(dir: &Path, name: &str, bytes: &[u8], expect: &[&str]) {
    let path = write(dir, name, bytes);
    let message = read(&path, RoiExtent::File).unwrap_err().to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    for e in expect {
        assert!(message.contains(e), "{name}: expected `{e}` in: {message}");
    }
}

#[test]
fn the_hand_built_structure_set_reads_in_every_syntax() {
    let dir = tempfile::tempdir().unwrap();
    for s in SYNTAXES {
        let path = write(
            dir.path(),
            "ok.dcm",
            &part10(s, &structure_set(s, triangle(s))),
        );
        let seq = read(&path, RoiExtent::File).unwrap_or_else(|e| panic!("{s:?}: {e}"));
        assert_eq!(seq.classes().len(), 1, "{s:?}");
        assert_eq!(seq.classes()[0].name, "GTV", "{s:?}");
        assert_eq!(seq.frames()[0].planes.len(), 1, "{s:?}");
    }
}

#[test]
fn a_huge_element_inside_nested_sequences_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for s in SYNTAXES {
        // ContourData with a 4-byte length (UN in explicit VR), three items deep.
        let mut data = s.header((0x3006, 0x0050), "UN", HUGE);
        data.extend(b"0\\0\\0\\10\\0\\0\\0\\10\\0 ");
        let bytes = part10(s, &structure_set(s, data));
        refused(
            dir.path(),
            "element.dcm",
            &bytes,
            &[
                "element (3006,0050) declares 4294967280 bytes at byte ",
                "bytes left in the file",
            ],
        );
    }
}

#[test]
fn a_huge_sequence_or_item_length_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for s in SYNTAXES {
        let modality = s.text((0x0008, 0x0060), "CS", "RTSTRUCT");
        // A sequence of defined length.
        let sequence = [
            modality.clone(),
            s.header((0x3006, 0x0020), "SQ", HUGE),
            s.item(UNDEFINED),
            s.text((0x3006, 0x0022), "IS", "1"),
            s.delimiter(0xE00D),
        ]
        .concat();
        refused(
            dir.path(),
            "sequence.dcm",
            &part10(s, &sequence),
            &["element (3006,0020) declares 4294967280 bytes"],
        );
        // An item of defined length in a sequence of undefined length.
        let item = [
            modality,
            s.header((0x3006, 0x0020), "SQ", UNDEFINED),
            s.item(HUGE),
            s.text((0x3006, 0x0022), "IS", "1"),
        ]
        .concat();
        refused(
            dir.path(),
            "item.dcm",
            &part10(s, &item),
            &["a sequence item declares 4294967280 bytes at byte "],
        );
    }
}

/// Encapsulated pixel data in an item (an icon image): its first fragment is the offset table,
/// which dicom-rs reserves before reading.
#[test]
fn a_huge_pixel_data_fragment_in_an_item_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let s = SYNTAXES[0];
    let icon = [
        s.header((0x7FE0, 0x0010), "OB", UNDEFINED),
        s.item(HUGE),
        vec![0; 16],
    ]
    .concat();
    let bytes = part10(
        s,
        &[
            s.text((0x0008, 0x0060), "CS", "RTSTRUCT"),
            s.header((0x0088, 0x0200), "SQ", UNDEFINED),
            s.item(UNDEFINED),
            icon,
        ]
        .concat(),
    );
    refused(
        dir.path(),
        "icon.dcm",
        &bytes,
        &["a sequence item declares 4294967280 bytes"],
    );
}

/// Sequences nested `MAX_NESTING + 1` deep, and 200 000 deep (4 MB: dicom-rs's own object
/// builder recurses once per level and would overflow the stack).
#[test]
fn nesting_beyond_the_limit_is_an_error_not_a_stack_overflow() {
    let dir = tempfile::tempdir().unwrap();
    for s in SYNTAXES {
        for depth in [MAX_NESTING + 1, 200_000] {
            let mut data = s.text((0x0008, 0x0060), "CS", "RTSTRUCT");
            for _ in 0..depth {
                data.extend(s.header((0x3006, 0x0039), "SQ", UNDEFINED));
                data.extend(s.item(UNDEFINED));
            }
            refused(
                dir.path(),
                "deep.dcm",
                &part10(s, &data),
                &[&format!(
                    "more than the limit of {MAX_NESTING} nested sequences"
                )],
            );
        }
    }
    // Exactly at the limit it is only not a structure set.
    let s = SYNTAXES[0];
    let mut data = s.text((0x0008, 0x0060), "CS", "RTSTRUCT");
    for _ in 0..MAX_NESTING {
        data.extend(s.header((0x0008, 0x1115), "SQ", UNDEFINED));
        data.extend(s.item(UNDEFINED));
    }
    for _ in 0..MAX_NESTING {
        data.extend(s.delimiter(0xE00D));
        data.extend(s.delimiter(0xE0DD));
    }
    refused(
        dir.path(),
        "at_limit.dcm",
        &part10(s, &data),
        &["no StructureSetROISequence"],
    );
}

/// A deflated data set would have to be inflated before its lengths mean anything, and then
/// they are not bounded by the file's size: refused, as is an unknown transfer syntax.
#[test]
fn undeflatable_or_unknown_transfer_syntaxes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = structure_set(SYNTAXES[0], triangle(SYNTAXES[0]));
    let deflated = Syntax {
        uid: "1.2.840.10008.1.2.1.99",
        ..SYNTAXES[0]
    };
    // Deflated transfer syntax, but a data set that is not deflated.
    refused(
        dir.path(),
        "deflated.dcm",
        &part10(deflated, &data),
        &["transfer syntax 1.2.840.10008.1.2.1.99", "does not inflate"],
    );
    let unknown = Syntax {
        uid: "1.2.3.4",
        ..SYNTAXES[0]
    };
    refused(
        dir.path(),
        "unknown.dcm",
        &part10(unknown, &data),
        &["unsupported transfer syntax 1.2.3.4"],
    );
}
