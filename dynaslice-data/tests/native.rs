//! Native JSON format: exact round trip, the documented example, and located errors.

use std::path::Path;

use dynaslice_data::{ErrorKind, Sequence};
use dynaslice_sequence::native;

mod common;

use common::sample;

#[test]
fn round_trips_exactly_through_text_and_files() {
    let seq = sample();
    let text = native::to_json(&seq);
    let back = native::from_json(&text).unwrap();
    assert_eq!(back, seq);
    assert_eq!(native::to_json(&back), text, "writing is deterministic");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.json");
    native::write(&seq, &path).unwrap();
    assert_eq!(native::read(&path).unwrap(), seq);
}

#[test]
fn documented_example_parses() {
    let doc = include_str!("../../docs/data-format.md");
    let start = doc
        .find("```json\n")
        .expect("docs/data-format.md has a JSON example")
        + 8;
    let end = start + doc[start..].find("```").unwrap();
    let seq = native::from_json(&doc[start..end]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(seq.classes().len(), 2);
}

#[test]
fn errors_name_path_line_and_problem() {
    let text = native::to_json(&sample());
    let e =
        native::from_json(&text.replacen("\"origin\":[0.1", "\"origin\":[\"x\"", 1)).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("frames[0].planes[0].origin") && m.contains("line 1"),
        "{m}"
    );
    let e = native::from_json(&text.replacen("\"time\"", "\"tmie\"", 1)).unwrap_err();
    assert!(e.to_string().contains("tmie"), "{e}");
    let e = native::from_json(&text.replacen("dynaslice-sections", "other", 1)).unwrap_err();
    assert!(e.to_string().contains("format"), "{e}");
    let e = native::from_json(&text.replacen("\"version\":1", "\"version\":9", 1)).unwrap_err();
    assert!(e.to_string().contains("version"), "{e}");
    // A validation error carries timestep and plane.
    let e = native::from_json(&text.replacen("\"u\":[0.6", "\"u\":[0.7", 1)).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::AxesNotOrthonormal { .. }),
        "{e}"
    );
    assert!(
        e.to_string().contains("timestep 0") && e.to_string().contains("plane 0"),
        "{e}"
    );
    let e = native::read(Path::new("/nonexistent/x.json")).unwrap_err();
    assert!(e.to_string().starts_with("/nonexistent/x.json"), "{e}");
    let e = native::from_json("").unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Syntax(_)), "{e}");
}

/// The digest is the FNV-1a hash of the JSON text (streamed), so equal sequences agree and a
/// moved vertex or a renamed class changes it.
#[test]
fn digest_hashes_the_document() {
    let seq = sample();
    let fnv = native::to_json(&seq)
        .bytes()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
        });
    assert_eq!(native::digest(&seq), fnv);
    let back = native::from_json(&native::to_json(&seq)).unwrap();
    assert_eq!(native::digest(&back), fnv);
    let (mut classes, mut frames) = seq.clone().into_parts();
    frames[0].planes[0].annotations[0].polygons[0][0][0] += 1e-9;
    let moved = Sequence::new(classes.clone(), frames).unwrap();
    assert_ne!(native::digest(&moved), fnv);
    classes[0].name.push('!');
    let renamed = Sequence::new(classes, seq.frames().to_vec()).unwrap();
    assert_ne!(native::digest(&renamed), fnv);
}
