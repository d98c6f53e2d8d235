//! Robustness of the input readers on malformed input, by property tests: the `.csl` parser, the
//! native JSON reader, the NIfTI reader (`.nii` and `.nii.gz`) and label-name tables, fed valid
//! files with random and targeted damage, never panic, never hang and never allocate more than
//! the input can justify. They return `Ok` (a sequence that passes its own validation again) or a
//! typed [`DataError`] whose message names the file (or line) and what is wrong.
//!
//! How the three "never"s are checked: every reader call runs on a fresh thread (`guarded`) that
//! must answer within [`DEADLINE`] (a panic there, or no answer, fails the test), and this test
//! binary's global allocator records the largest single allocation each thread *requests*,
//! granted or refused, so a reader that reserves memory from an untrusted count field fails the
//! size bound even where the operating system would have let it have the address space.
//!
//! Every property starts from a valid input that is asserted to read back `Ok` (a control), so no
//! property can pass by rejecting everything. Case counts are modest; the file runs in seconds.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use dynaslice_data::label_volume::LabelVolume;
use dynaslice_data::nifti;
use dynaslice_data::reslice::ResliceOptions;
use dynaslice_data::{csl, DataError, ErrorKind, LabelTable, Result, Sequence};
use dynaslice_sequence::native;
use dynaslice_test_support::fixtures::{csl_file, SQUARE_WITH_HOLE_PLANE, TRIANGLE_PLANE};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

mod common;

use common::sample;

// ---------------------------------------------------------------------------------------------
// Measuring: the largest allocation request per thread, and a deadline per reader call.

/// The system allocator, recording per thread the largest size requested of it.
struct LargestRequest;

thread_local! {
    // `const` initialisation with a type without `Drop`: no lazy set-up, no allocation and no
    // destructor registration, so it is safe to touch from inside the allocator.
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
}

unsafe impl GlobalAlloc for LargestRequest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: LargestRequest = LargestRequest;

/// Longest a reader may take on one of these tiny inputs before the test calls it a hang: far
/// beyond what any takes (seconds at most, on a loaded 2-core machine while CI builds beside it).
const DEADLINE: Duration = Duration::from_secs(60);

/// Fixed allowance for any read: buffers, error messages, the gzip decoder's state (about 75 KiB).
const SLACK: usize = 128 << 10;

/// Allowance per input byte for text formats: the parsed sequence is a few times the text.
const PER_TEXT_BYTE: usize = 64;

/// Allowance per input byte for NIfTI: the file, its voxels, and their labels as `i32`.
const PER_NIFTI_BYTE: usize = 8;

/// Runs `f` on a fresh thread and returns its value and the largest allocation it requested
/// (on that thread). Fails the test if `f` panics or does not finish within [`DEADLINE`].
fn guarded<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> (T, usize) {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name(format!("guarded {what}"))
        .spawn(move || {
            LARGEST.with(|l| l.set(0));
            let value = f();
            let largest = LARGEST.with(Cell::get);
            let _ = tx.send((value, largest));
        })
        .expect("spawn a reader thread");
    match rx.recv_timeout(DEADLINE) {
        Ok(answer) => answer,
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{what}: no answer within {DEADLINE:?} (a hang)")
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{what}: the reader panicked"),
    }
}

/// Checks `largest` against `SLACK + per_byte × input_len`.
fn bounded(
    what: &str,
    largest: usize,
    input_len: usize,
    per_byte: usize,
) -> std::result::Result<(), TestCaseError> {
    let bound = SLACK + per_byte * input_len;
    prop_assert!(
        largest <= bound,
        "{}: requested {} bytes at once for {} bytes of input (bound {})",
        what,
        largest,
        input_len,
        bound
    );
    Ok(())
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        // Failures print the shrunk edits; regression files would land beside the sources.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// A valid sequence is its own canonical form: validating it again changes nothing, and it
/// round-trips through the native format.
fn revalidates(seq: &Sequence) -> std::result::Result<(), TestCaseError> {
    let again = Sequence::new(seq.classes().to_vec(), seq.frames().to_vec());
    prop_assert!(again.is_ok(), "revalidation failed: {}", again.unwrap_err());
    prop_assert_eq!(&again.unwrap(), seq);
    let back = native::from_json(&native::to_json(seq));
    prop_assert!(
        back.is_ok(),
        "JSON round trip failed: {}",
        back.unwrap_err()
    );
    prop_assert_eq!(&back.unwrap(), seq);
    Ok(())
}

/// An error's message is non-empty, says what is wrong and names `name`.
fn names(e: &DataError, name: &str) -> std::result::Result<(), TestCaseError> {
    let message = e.to_string();
    prop_assert!(
        !e.kind.to_string().trim().is_empty(),
        "empty kind: {}",
        message
    );
    prop_assert!(message.contains(name), "{} is not named: {}", name, message);
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Text damage, shared by `.csl`, JSON and label tables.

/// Numbers that overflow every integer type, are out of `f64`'s range, are not finite, or are not
/// numbers at all.
const HOSTILE_NUMBERS: &[&str] = &[
    "4294967295",
    "4294967296",
    "2147483648",
    "-2147483649",
    "18446744073709551615",
    "18446744073709551616",
    "340282366920938463463374607431768211456",
    "-1",
    "0",
    "-0",
    "1e309",
    "-1e309",
    "1e-400",
    "1e300",
    "-1e300",
    "4.9e-324",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "Infinity",
    "0.5",
    "3",
    "1e3",
    "0x10",
    "",
];

#[derive(Debug, Clone)]
enum TextEdit {
    Replace {
        at: usize,
        with: char,
    },
    Insert {
        at: usize,
        with: char,
    },
    Delete {
        at: usize,
        len: usize,
    },
    Truncate {
        at: usize,
    },
    /// Copies `len` characters from `at` and inserts them at `to`.
    Duplicate {
        at: usize,
        len: usize,
        to: usize,
    },
    DuplicateLine {
        at: usize,
    },
    DeleteLine {
        at: usize,
    },
    /// Replaces the `nth` number (mod their count) with a hostile one.
    Number {
        nth: usize,
        with: &'static str,
    },
}

/// Characters that matter to the formats (digits, signs, separators, JSON punctuation, the hole
/// marker `h`, multi-byte whitespace), and now and then any character.
fn text_char() -> impl Strategy<Value = char> {
    prop_oneof![
        4 => prop::sample::select(vec![
            '0', '1', '2', '7', '9', '-', '+', '.', 'e', 'E', 'h', ' ', '\t', '\n', '\r', ',', '{',
            '}', '[', ']', '"', ':', '\\', '#', 'u', 'n', '\u{a0}', '\u{3000}', '\u{85}', 'é', '\0',
        ]),
        1 => any::<char>(),
    ]
}

fn text_edit() -> impl Strategy<Value = TextEdit> {
    prop_oneof![
        1 => (any::<usize>(), text_char()).prop_map(|(at, with)| TextEdit::Replace { at, with }),
        1 => (any::<usize>(), text_char()).prop_map(|(at, with)| TextEdit::Insert { at, with }),
        1 => (any::<usize>(), 1usize..24).prop_map(|(at, len)| TextEdit::Delete { at, len }),
        1 => any::<usize>().prop_map(|at| TextEdit::Truncate { at }),
        1 => (any::<usize>(), 1usize..40, any::<usize>())
            .prop_map(|(at, len, to)| TextEdit::Duplicate { at, len, to }),
        1 => any::<usize>().prop_map(|at| TextEdit::DuplicateLine { at }),
        1 => any::<usize>().prop_map(|at| TextEdit::DeleteLine { at }),
        2 => (any::<usize>(), prop::sample::select(HOSTILE_NUMBERS))
            .prop_map(|(nth, with)| TextEdit::Number { nth, with }),
    ]
}

/// Spans of the numeric tokens (runs of digits, signs, dots and exponents holding a digit).
fn number_spans(chars: &[char]) -> Vec<(usize, usize)> {
    let numeric = |c: char| c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-');
    let mut spans = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        if numeric(chars[i]) {
            let start = i;
            while i < chars.len() && numeric(chars[i]) {
                i += 1;
            }
            if chars[start..i].iter().any(char::is_ascii_digit) {
                spans.push((start, i));
            }
        } else {
            i += 1;
        }
    }
    spans
}

fn apply_text(base: &str, edits: &[TextEdit]) -> String {
    let mut chars: Vec<char> = base.chars().collect();
    for edit in edits {
        let n = chars.len();
        match *edit {
            TextEdit::Replace { at, with } if n > 0 => chars[at % n] = with,
            TextEdit::Insert { at, with } => chars.insert(at % (n + 1), with),
            TextEdit::Delete { at, len } if n > 0 => {
                let a = at % n;
                chars.drain(a..(a + len).min(n));
            }
            TextEdit::Truncate { at } => chars.truncate(at % (n + 1)),
            TextEdit::Duplicate { at, len, to } if n > 0 => {
                let a = at % n;
                let piece: Vec<char> = chars[a..(a + len).min(n)].to_vec();
                let to = to % (n + 1);
                chars.splice(to..to, piece);
            }
            TextEdit::DuplicateLine { at } | TextEdit::DeleteLine { at } => {
                let text: String = chars.iter().collect();
                let mut lines: Vec<&str> = text.split('\n').collect();
                let i = at % lines.len();
                if matches!(edit, TextEdit::DuplicateLine { .. }) {
                    lines.insert(i, lines[i]);
                } else {
                    lines.remove(i);
                }
                chars = lines.join("\n").chars().collect();
            }
            TextEdit::Number { nth, with } => {
                let spans = number_spans(&chars);
                if !spans.is_empty() {
                    let (a, b) = spans[nth % spans.len()];
                    chars.splice(a..b, with.chars());
                }
            }
            _ => {}
        }
    }
    chars.into_iter().collect()
}

fn text_edits() -> impl Strategy<Value = Vec<TextEdit>> {
    prop::collection::vec(text_edit(), 1..4)
}

// ---------------------------------------------------------------------------------------------
// .csl

/// Two planes: z = 0 with a square and its hole (label 1, hole marked 2), z = 1 with a triangle of
/// label 7.
fn base_csl() -> String {
    csl_file(2, &[SQUARE_WITH_HOLE_PLANE, TRIANGLE_PLANE])
}

const CSL_NAME: &str = "mutated.csl";

fn parse_csl(text: &str) -> (Result<Sequence>, usize) {
    let text = text.to_string();
    guarded("csl::parse", move || {
        csl::parse(&text, Path::new(CSL_NAME), &LabelTable::default())
    })
}

/// Checks one `.csl` parse: bounded, and `Ok` revalidates or the error names file and line.
fn check_csl(text: &str) -> std::result::Result<Option<Sequence>, TestCaseError> {
    let (result, largest) = parse_csl(text);
    bounded("csl::parse", largest, text.len(), PER_TEXT_BYTE)?;
    match result {
        Ok(seq) => {
            revalidates(&seq)?;
            Ok(Some(seq))
        }
        Err(e) => {
            names(&e, CSL_NAME)?;
            if let Some(line) = e.location.line {
                prop_assert!(
                    (1..=text.lines().count()).contains(&line),
                    "line {} of a {}-line file: {}",
                    line,
                    text.lines().count(),
                    e
                );
            }
            Ok(None)
        }
    }
}

#[test]
fn csl_control_parses() {
    let seq = check_csl(&base_csl())
        .unwrap()
        .expect("the base .csl is valid");
    let labels: Vec<i32> = seq.classes().iter().map(|c| c.label).collect();
    assert_eq!(labels, [1, 7]);
    assert_eq!(seq.frames()[0].planes.len(), 2);
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn csl_damage_is_ok_or_a_located_error(edits in text_edits()) {
        check_csl(&apply_text(&base_csl(), &edits))?;
    }
}

/// Count fields claiming 2^31 (or 2^64 − 1) planes, vertices, components or indices in files of
/// a few dozen bytes: an error, at once, without reserving memory for what is claimed.
#[test]
fn csl_huge_counts_fail_fast_without_reserving_them() {
    let triangle = "0 0 0\n1 0 0\n0 1 0\n3 1 0 1 2\n";
    let valid = format!("CSLC\n1 1\n1 3 1 0 0 1 0\n{triangle}");
    assert!(check_csl(&valid).unwrap().is_some(), "control");
    for huge in ["2147483648", "4294967295", "18446744073709551615"] {
        let says = format!("the header says {huge}");
        let files = [
            // (file, what its error must say)
            (
                format!("CSLC\n{huge} 1\n1 3 1 0 0 1 0\n{triangle}"),
                says.as_str(),
            ),
            (
                format!("CSLC\n1 1\n1 {huge} 1 0 0 1 0\n{triangle}"),
                "vertex count",
            ),
            (format!("CSLC\n1 1\n1 3 {huge} 0 0 1 0\n{triangle}"), &says),
            (
                format!("CSLC\n1 1\n1 3 1 0 0 1 0\n0 0 0\n1 0 0\n0 1 0\n{huge} 1 0 1 2\n"),
                &says,
            ),
            (format!("CSLC\n{huge} 1\n1 {huge} {huge} 0 0 1 0\n"), &says),
            // The label count is informational: only the stray last line is wrong.
            (
                format!("CSLC\n1 {huge}\n1 3 1 0 0 1 0\n{triangle}x"),
                "after the last plane",
            ),
        ];
        for (text, what) in &files {
            let (result, largest) = parse_csl(text);
            let e = result.expect_err(text);
            assert!(e.to_string().contains(CSL_NAME), "{e}");
            assert!(e.to_string().contains(what), "{text:?}: {e}");
            bounded(text, largest, text.len(), PER_TEXT_BYTE).unwrap();
        }
    }
}

/// An error of the whole sequence (here: no class at all) still names the file.
#[test]
fn csl_sequence_level_errors_name_the_file() {
    let (result, _) = parse_csl(&csl_file(1, &["1 0 0 0 0 1 0\n"]));
    let e = result.unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
    assert!(e.to_string().contains(CSL_NAME), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Native JSON

const JSON_NAME: &str = "mutated.json";

/// Reads `text` with `from_json` and, written to `path`, with `native::read`: both bounded, the
/// same outcome, `Ok` revalidates, errors say what is wrong (and `read`'s name the file).
fn check_json(text: &str, path: &Path) -> std::result::Result<Option<Sequence>, TestCaseError> {
    std::fs::write(path, text).unwrap();
    let (owned, path) = (text.to_string(), path.to_path_buf());
    let ((parsed, read), largest) = guarded("native JSON", move || {
        (native::from_json(&owned), native::read(&path))
    });
    bounded("native JSON", largest, text.len(), PER_TEXT_BYTE)?;
    match (parsed, read) {
        (Ok(a), Ok(b)) => {
            prop_assert_eq!(&a, &b);
            revalidates(&a)?;
            Ok(Some(a))
        }
        (Err(a), Err(b)) => {
            prop_assert!(!a.to_string().trim().is_empty());
            prop_assert_eq!(a.kind.to_string(), b.kind.to_string());
            names(&b, JSON_NAME)?;
            Ok(None)
        }
        (a, b) => Err(TestCaseError::fail(format!(
            "from_json gave {a:?} but read gave {b:?}"
        ))),
    }
}

#[test]
fn json_control_parses() {
    let dir = tempfile::tempdir().unwrap();
    let seq = sample();
    let back = check_json(&native::to_json(&seq), &dir.path().join(JSON_NAME)).unwrap();
    assert_eq!(back.as_ref(), Some(&seq));
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn json_damage_is_ok_or_a_typed_error(edits in text_edits()) {
        thread_local! {
            static BASE: (String, tempfile::TempDir) =
                (native::to_json(&sample()), tempfile::tempdir().unwrap());
        }
        let (text, path) = BASE.with(|(json, dir)| (apply_text(json, &edits), dir.path().join(JSON_NAME)));
        check_json(&text, &path)?;
    }
}

// ---------------------------------------------------------------------------------------------
// Label-name tables

#[test]
fn label_names_accept_any_whitespace_separator() {
    for table in [
        "1\u{a0}spleen\n",
        "1\u{3000}spleen\n",
        "1\u{85}spleen\n",
        "1\tspleen\n",
    ] {
        let (t, _) = guarded("LabelTable::parse", move || LabelTable::parse(table));
        assert_eq!(t.unwrap().name(1), "spleen", "{table:?}");
    }
    // Commas and spaces in any order separate; what `to_text` writes reads back the same.
    for table in ["5 , ,x\n", "5,, ,x\n", "5, x\n", "5 ,x\n"] {
        let t = LabelTable::parse(table).unwrap();
        assert_eq!(t.name(5), "x", "{table:?}");
        assert_eq!(LabelTable::parse(&t.to_text()).unwrap(), t);
    }
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn label_name_damage_is_ok_or_a_located_error(
        edits in text_edits(),
        noise in prop::collection::vec(text_char(), 0..48),
    ) {
        let base = "# labels\n1 spleen\n5, right kidney\n-3\tliver\n";
        let mut text = apply_text(base, &edits);
        text.extend(noise);
        let owned = text.clone();
        let (result, largest) = guarded("LabelTable::parse", move || LabelTable::parse(&owned));
        bounded("LabelTable::parse", largest, text.len(), PER_TEXT_BYTE)?;
        match result {
            Ok(table) => prop_assert_eq!(LabelTable::parse(&table.to_text()).unwrap(), table),
            Err(e) => {
                prop_assert!(e.location.line.is_some(), "{}", e);
                names(&e, "line ")?;
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// NIfTI

/// 4×3×2 voxels, 2 frames, labels 0..=3, an anisotropic rotated and shifted grid.
fn base_volume() -> LabelVolume {
    let mut labels = Vec::new();
    for f in 0..2 {
        for k in 0..2 {
            for j in 0..3 {
                for i in 0..4 {
                    labels.push((i + 2 * j + k + f) % 4);
                }
            }
        }
    }
    LabelVolume {
        dims: [4, 3, 2],
        frames: 2,
        affine: [
            [0.0, -1.5, 0.0, 10.0],
            [1.0, 0.0, 0.0, -20.0],
            [0.0, 0.0, 2.0, 5.0],
        ],
        frame_interval: 0.5,
        labels,
    }
}

/// The base volume as a `.nii` (uncompressed) and a `.nii.gz`, as written by `write_volume`.
fn base_files() -> (Vec<u8>, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let (plain, gz) = (dir.path().join("v.nii"), dir.path().join("v.nii.gz"));
    nifti::write_volume(&base_volume(), &plain).unwrap();
    nifti::write_volume(&base_volume(), &gz).unwrap();
    let (plain, gz) = (std::fs::read(plain).unwrap(), std::fs::read(gz).unwrap());
    // The header fields below are patched as little endian: check the file is (dim[0] = 4).
    assert_eq!(i16::from_le_bytes([plain[40], plain[41]]), 4);
    assert_eq!(plain.len(), 352 + 96, "i16 voxels right after the header");
    (plain, gz)
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// A header field set to a value (little endian), at its NIfTI-1 byte offset.
#[derive(Debug, Clone, Copy)]
enum Field {
    I16(usize, i16),
    I32(usize, i32),
    F32(usize, f32),
    Bytes(usize, [u8; 4]),
}

const HOSTILE_F32: &[f32] = &[
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    -1.0,
    1e38,
    -1e38,
    1e-38,
    1e-45,
    2.0,
];

/// Dimensions: `dim[0]` (rank) and `dim[1..=7]` with zero, "negative" (read unsigned: 65535,
/// 32768) and huge sizes.
fn dim_field() -> impl Strategy<Value = Field> {
    let sizes = vec![-1i16, 0, 1, 2, 3, 5, 255, 32767, -32768];
    prop_oneof![
        prop::sample::select(vec![-1i16, 0, 1, 2, 3, 4, 5, 7, 8, 256, 32767])
            .prop_map(|v| Field::I16(40, v)),
        (1usize..8, prop::sample::select(sizes)).prop_map(|(k, v)| Field::I16(40 + 2 * k, v)),
    ]
}

/// Datatype, bitpix and vox_offset: what says where the voxels are and how big they are.
fn layout_field() -> impl Strategy<Value = Field> {
    prop_oneof![
        prop::sample::select(vec![
            0i16, 1, 2, 4, 8, 16, 32, 64, 128, 255, 256, 512, 768, 1024, 1280, 1536, 1792, 2048,
            2304, -1, 32767,
        ])
        .prop_map(|v| Field::I16(70, v)),
        prop::sample::select(vec![0i16, 1, 7, 8, 9, 16, 32, 64, -8, 32767, -32768])
            .prop_map(|v| Field::I16(72, v)),
        prop::sample::select(vec![
            f32::NAN,
            f32::INFINITY,
            -1.0,
            0.0,
            348.0,
            351.0,
            352.5,
            353.0,
            399.0,
            400.0,
            401.0,
            1e9,
            3.4e38,
        ])
        .prop_map(|v| Field::F32(108, v)),
    ]
}

/// Any header field that matters: the above, and pixdim, scaling, transform codes, quaternion,
/// sform rows, magic, sizeof_hdr and the extender.
fn header_field() -> impl Strategy<Value = Field> {
    let float = || prop::sample::select(HOSTILE_F32);
    prop_oneof![
        3 => dim_field(),
        3 => layout_field(),
        1 => (0usize..8, float()).prop_map(|(k, v)| Field::F32(76 + 4 * k, v)),
        1 => (prop::sample::select(vec![112usize, 116]), float()).prop_map(|(o, v)| Field::F32(o, v)),
        1 => (
            prop::sample::select(vec![252usize, 254]),
            prop::sample::select(vec![-1i16, 0, 1, 2, 4, 5, 32767])
        )
            .prop_map(|(o, v)| Field::I16(o, v)),
        1 => (0usize..6, float()).prop_map(|(k, v)| Field::F32(256 + 4 * k, v)),
        1 => (0usize..12, float()).prop_map(|(k, v)| Field::F32(280 + 4 * k, v)),
        1 => prop::sample::select(vec![*b"ni1\0", *b"n+2\0", [0; 4], *b"n+1 "])
            .prop_map(|m| Field::Bytes(344, m)),
        1 => prop::sample::select(vec![0i32, -1, 540, 1 << 30]).prop_map(|v| Field::I32(0, v)),
        1 => prop::sample::select(vec![[1u8, 0, 0, 0], [255; 4]]).prop_map(|m| Field::Bytes(348, m)),
    ]
}

#[derive(Debug, Clone, Copy)]
enum NiftiEdit {
    /// XOR a byte of the 352-byte header and extender.
    FlipHeader {
        at: usize,
        xor: u8,
    },
    /// XOR a byte after the header.
    FlipData {
        at: usize,
        xor: u8,
    },
    Truncate {
        at: usize,
    },
    Set(Field),
}

fn apply_nifti(base: &[u8], edits: &[NiftiEdit]) -> Vec<u8> {
    let mut b = base.to_vec();
    for edit in edits {
        let n = b.len();
        match *edit {
            NiftiEdit::FlipHeader { at, xor } if n > 0 => b[at % n.min(352)] ^= xor,
            NiftiEdit::FlipData { at, xor } if n > 352 => b[352 + at % (n - 352)] ^= xor,
            NiftiEdit::Truncate { at } => b.truncate(at % (n + 1)),
            NiftiEdit::Set(field) => {
                let (at, bytes): (usize, Vec<u8>) = match field {
                    Field::I16(at, v) => (at, v.to_le_bytes().to_vec()),
                    Field::I32(at, v) => (at, v.to_le_bytes().to_vec()),
                    Field::F32(at, v) => (at, v.to_le_bytes().to_vec()),
                    Field::Bytes(at, v) => (at, v.to_vec()),
                };
                if at + bytes.len() <= n {
                    b[at..at + bytes.len()].copy_from_slice(&bytes);
                }
            }
            _ => {}
        }
    }
    b
}

fn nifti_edit() -> impl Strategy<Value = NiftiEdit> {
    prop_oneof![
        2 => (any::<usize>(), 1u8..).prop_map(|(at, xor)| NiftiEdit::FlipHeader { at, xor }),
        1 => (any::<usize>(), 1u8..).prop_map(|(at, xor)| NiftiEdit::FlipData { at, xor }),
        1 => any::<usize>().prop_map(|at| NiftiEdit::Truncate { at }),
        4 => header_field().prop_map(NiftiEdit::Set),
    ]
}

/// Edits that leave the voxel-to-world transform alone (for reslicing, whose work grows with
/// the grid that transform implies, see `nifti_read_damage_is_ok_or_a_named_error`).
fn layout_edit() -> impl Strategy<Value = NiftiEdit> {
    prop_oneof![
        (any::<usize>(), 1u8..).prop_map(|(at, xor)| NiftiEdit::FlipData { at, xor }),
        any::<usize>().prop_map(|at| NiftiEdit::Truncate { at }),
        dim_field().prop_map(NiftiEdit::Set),
        layout_field().prop_map(NiftiEdit::Set),
    ]
}

/// Reads `bytes` written to `path`; bounded by `SLACK + PER_NIFTI_BYTE × justified`; `Ok` is a
/// consistent volume, an error is a NIfTI error naming the file.
fn check_nifti(
    path: &Path,
    bytes: &[u8],
    justified: usize,
) -> std::result::Result<Option<LabelVolume>, TestCaseError> {
    std::fs::write(path, bytes).unwrap();
    let owned = path.to_path_buf();
    let (result, largest) = guarded("nifti::read_volume", move || nifti::read_volume(&owned));
    bounded("nifti::read_volume", largest, justified, PER_NIFTI_BYTE)?;
    match result {
        Ok(v) => {
            prop_assert!(v.dims.iter().all(|&d| d > 0) && v.frames > 0, "{:?}", v);
            prop_assert_eq!(v.labels.len(), v.dims.iter().product::<usize>() * v.frames);
            prop_assert!(v.affine.iter().flatten().all(|x| x.is_finite()));
            prop_assert!(v.frame_interval.is_finite() && v.frame_interval > 0.0);
            Ok(Some(v))
        }
        Err(e) => {
            prop_assert!(matches!(e.kind, ErrorKind::Nifti(_)), "{}", e);
            let name = path.file_name().unwrap().to_str().unwrap();
            names(&e, name)?;
            Ok(None)
        }
    }
}

#[test]
fn nifti_controls_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, gz) = base_files();
    let path = dir.path().join("control.nii");
    let v = check_nifti(&path, &plain, plain.len()).unwrap();
    assert_eq!(v, Some(base_volume()));
    let v = check_nifti(&path, &gz, plain.len()).unwrap();
    assert_eq!(v, Some(base_volume()));
    // Compressed by this file's `gzip` helper, as the properties below do.
    let v = check_nifti(&path, &gzip(&plain), plain.len()).unwrap();
    assert_eq!(v, Some(base_volume()));
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn nii_damage_is_ok_or_a_named_error(edits in prop::collection::vec(nifti_edit(), 1..5)) {
        thread_local! {
            static BASE: (Vec<u8>, tempfile::TempDir) = (base_files().0, tempfile::tempdir().unwrap());
        }
        let (bytes, path) = BASE.with(|(b, dir)| (apply_nifti(b, &edits), dir.path().join("mutated.nii")));
        check_nifti(&path, &bytes, bytes.len())?;
    }
}

proptest! {
    #![proptest_config(config(128))]

    /// Header damage under gzip: hostile sizes must not make the reader decompress or reserve
    /// more than the stream holds.
    #[test]
    fn nii_gz_damage_is_ok_or_a_named_error(edits in prop::collection::vec(nifti_edit(), 1..5)) {
        thread_local! {
            static BASE: (Vec<u8>, tempfile::TempDir) = (base_files().0, tempfile::tempdir().unwrap());
        }
        let (raw, path) = BASE.with(|(b, dir)| (apply_nifti(b, &edits), dir.path().join("mutated.nii.gz")));
        let bytes = gzip(&raw);
        check_nifti(&path, &bytes, bytes.len().max(raw.len()))?;
    }

    /// Damage to the compressed stream itself is detected (deflate errors, the CRC) or harmless
    /// (e.g. the gzip header's time stamp): never silently different labels.
    #[test]
    fn nii_gz_stream_damage_is_detected_or_harmless(
        flips in prop::collection::vec((any::<usize>(), 1u8..), 0..3),
        cut in prop::option::of(any::<usize>()),
    ) {
        prop_assume!(!flips.is_empty() || cut.is_some());
        thread_local! {
            static BASE: (Vec<u8>, usize, tempfile::TempDir) = {
                let (plain, gz) = base_files();
                (gz, plain.len(), tempfile::tempdir().unwrap())
            };
        }
        let (bytes, plain_len, path) = BASE.with(|(gz, plain_len, dir)| {
            let mut b = gz.clone();
            for &(at, xor) in &flips {
                let n = b.len();
                b[at % n] ^= xor;
            }
            if let Some(at) = cut {
                b.truncate(at % b.len());
            }
            (b, *plain_len, dir.path().join("damaged.nii.gz"))
        });
        if let Some(v) = check_nifti(&path, &bytes, bytes.len().max(plain_len))? {
            prop_assert_eq!(v, base_volume());
        }
    }
}

/// Dimensions far beyond a 400-byte file (32767³ voxels, 2 frames, of u8 and of i64, and
/// "negative" sizes read as 65535): an error naming the dims, before reserving or decompressing
/// anything for them.
#[test]
fn nifti_hostile_dims_fail_without_reserving_them() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, _) = base_files();
    let set = |fields: &[Field]| {
        apply_nifti(
            &plain,
            &fields
                .iter()
                .map(|&f| NiftiEdit::Set(f))
                .collect::<Vec<_>>(),
        )
    };
    let dims = |d: [i16; 4]| {
        let mut f = vec![Field::I16(40, 4)];
        f.extend((0..4).map(|k| Field::I16(42 + 2 * k, d[k])));
        f
    };
    let int64 = [Field::I16(70, 1024), Field::I16(72, 64)];
    let cases = [
        set(&dims([32767, 32767, 32767, 2])),
        set(&[dims([32767, 32767, 32767, 32767]), int64.to_vec()].concat()),
        set(&dims([-1, -1, -1, -1])),
        set(&dims([4, 3, 2, 32767])),
        set(&dims([4, 3, 3, 2])),
    ];
    for (i, bytes) in cases.iter().enumerate() {
        for gz in [false, true] {
            let bytes = if gz { gzip(bytes) } else { bytes.clone() };
            let path = dir
                .path()
                .join(format!("huge{i}.nii{}", if gz { ".gz" } else { "" }));
            let v = check_nifti(&path, &bytes, plain.len()).unwrap();
            assert!(v.is_none(), "case {i} (gz: {gz}) was read");
            let e = nifti::read_volume(&path).unwrap_err();
            assert!(e.to_string().contains("dim "), "{e}");
        }
    }
}

/// The voxels are read at `vox_offset`, whatever lies between the header and there: padding, or
/// an extension whose size field claims 2 GiB. An offset beyond the file is an error.
#[test]
fn nifti_voxels_are_read_at_vox_offset() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, _) = base_files();
    let with_gap = |extender: [u8; 4], gap: &[u8]| {
        let mut b = plain[..348].to_vec();
        b[108..112].copy_from_slice(&(352.0 + gap.len() as f32).to_le_bytes());
        b.extend(extender);
        b.extend(gap);
        b.extend(&plain[352..]);
        b
    };
    let mut extension = Vec::new();
    extension.extend(0x7fff_0000i32.to_le_bytes()); // esize: 2 GiB
    extension.extend(6i32.to_le_bytes()); // ecode: comment
    extension.extend(*b"hi there");
    let files = [
        with_gap([0; 4], &[0; 16]),
        with_gap(
            [1, 0, 0, 0],
            &[16, 0, 0, 0, 6, 0, 0, 0, b'h', b'i', 0, 0, 0, 0, 0, 0],
        ),
        with_gap([1, 0, 0, 0], &extension),
    ];
    for (i, bytes) in files.iter().enumerate() {
        for gz in [false, true] {
            let bytes = if gz { gzip(bytes) } else { bytes.clone() };
            let path = dir.path().join(format!("offset{i}.nii"));
            let v = check_nifti(&path, &bytes, plain.len() + 16).unwrap();
            assert_eq!(v, Some(base_volume()), "file {i} (gz: {gz})");
        }
    }
    for offset in [401.0f32, 1e9, f32::NAN, -1.0] {
        let mut bytes = plain.clone();
        bytes[108..112].copy_from_slice(&offset.to_le_bytes());
        let path = dir.path().join("beyond.nii");
        assert!(check_nifti(&path, &bytes, plain.len()).unwrap().is_none());
        let e = nifti::read_volume(&path).unwrap_err();
        assert!(e.to_string().contains("vox_offset"), "{offset}: {e}");
    }
}

/// Every truncation of a valid file, plain or gzipped (down to its last trailer byte), is an
/// error.
#[test]
fn nifti_every_truncation_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, gz) = base_files();
    for (bytes, name) in [(&plain, "cut.nii"), (&gz, "cut.nii.gz")] {
        let path = dir.path().join(name);
        for len in 0..bytes.len() {
            let v = check_nifti(&path, &bytes[..len], plain.len()).unwrap();
            assert!(v.is_none(), "{name} cut to {len} bytes was read");
        }
    }
}

proptest! {
    #![proptest_config(config(48))]

    /// `nifti::read` (read and reslice) on damaged layouts and voxels: `Ok` is a valid sequence,
    /// an error names the file. The transform is left alone here (reslicing is real work that
    /// grows with the box's extent); `nifti_read_anisotropic_voxels_stay_small` checks that a
    /// hostile one stays bounded.
    #[test]
    fn nifti_read_damage_is_ok_or_a_named_error(edits in prop::collection::vec(layout_edit(), 1..4)) {
        thread_local! {
            static BASE: (Vec<u8>, tempfile::TempDir) = (base_files().0, tempfile::tempdir().unwrap());
        }
        let (bytes, path) = BASE.with(|(b, dir)| (apply_nifti(b, &edits), dir.path().join("resliced.nii")));
        std::fs::write(&path, &bytes).unwrap();
        let owned: PathBuf = path.clone();
        let (result, _) = guarded("nifti::read", move || {
            nifti::read(&owned, &ResliceOptions::default(), &LabelTable::default())
        });
        match result {
            Ok(seq) => revalidates(&seq)?,
            Err(e) => names(&e, "resliced.nii")?,
        }
    }
}

#[test]
fn nifti_read_control_reslices() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("control.nii");
    std::fs::write(&path, base_files().0).unwrap();
    let seq = nifti::read(&path, &ResliceOptions::default(), &LabelTable::default()).unwrap();
    assert_eq!(seq.classes().len(), 3, "labels 1, 2, 3");
    revalidates(&seq).unwrap();
}

/// Voxels a thousand times longer on two axes than on the third: half the smallest spacing
/// over the labelled box would be a grid of about 12000 × 10000 points per plane (beyond the
/// per-axis limit, and gigabytes of sampling stencils for 24 voxels); the default pixel is
/// coarsened to at most 1536 points along the box's diagonal, so this reslices, quickly.
#[test]
fn nifti_read_anisotropic_voxels_stay_small() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("anisotropic.nii");
    let mut volume = base_volume();
    volume.affine = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1024.0, 0.0, 0.0],
        [0.0, 0.0, 1024.0, 0.0],
    ];
    nifti::write_volume(&volume, &path).unwrap();
    let owned = path.clone();
    let (result, _) = guarded("nifti::read", move || {
        nifti::read(&owned, &ResliceOptions::default(), &LabelTable::default())
    });
    let seq = result.unwrap();
    revalidates(&seq).unwrap();
    assert_eq!(seq.classes().len(), 3, "labels 1, 2, 3");
    // An explicit pixel that fine is still refused, with the grid and the limits named.
    let fine = ResliceOptions {
        pixel: Some(0.5),
        ..ResliceOptions::default()
    };
    let e = nifti::read(&path, &fine, &LabelTable::default()).unwrap_err();
    assert!(e.to_string().contains("grid per plane"), "{e}");
}
