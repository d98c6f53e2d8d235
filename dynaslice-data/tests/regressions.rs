//! Inputs the fuzzers (`scripts/ci-fuzz.sh`) found, kept as tests so they stay fixed.

use std::path::{Path, PathBuf};

use dynaslice_data::input::{read, InputOptions};

fn regression(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/regressions")
        .join(name)
}

/// A NIfTI without sform or qform whose pixdim[3] is 5.9e-39: reslicing sent grid points to
/// voxel indices near 1e38 and overflowed `isize` adding the interpolation stencil. Such points
/// lie outside the volume (background); the read now ends in an ordinary result or error.
#[test]
fn nifti_with_a_denormal_voxel_size_does_not_panic() {
    let path = regression("nifti-tiny-pixdim.nii");
    if let Err(e) = read(std::slice::from_ref(&path), &InputOptions::default()) {
        assert!(e.to_string().contains("nifti-tiny-pixdim.nii"), "{e}");
    }
}

/// A 1 kB DICOM file whose file meta group declares a 3.4 GB element: dicom-object allocated
/// it before reading. Refused now from the element headers alone.
#[test]
fn rtstruct_declaring_a_huge_meta_element_is_refused_without_allocating_it() {
    let path = regression("rtstruct-huge-meta-length.dcm");
    let e = read(std::slice::from_ref(&path), &InputOptions::default()).unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("rtstruct-huge-meta-length.dcm")
            && message.contains("file meta element (0002,0003) declares 3402486221 bytes")
            && message.contains("more than the 852 bytes left in the file"),
        "{message}"
    );
}

/// An RTSTRUCT with an item header outside any sequence: dicom-parser's lazy reader panicked
/// ("item header should be read only inside an existing sequence"). The reader no longer uses
/// it; dicom-parser's data set reader takes the stray undefined-length item (FFFE,E000) for an
/// element, one past Pixel Data, where the data set ends, so the structure set has no
/// StructureSetROISequence: an error naming the file.
#[test]
fn rtstruct_with_an_item_outside_a_sequence_is_an_error() {
    let path = regression("rtstruct-item-outside-sequence.dcm");
    let e = read(std::slice::from_ref(&path), &InputOptions::default()).unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("rtstruct-item-outside-sequence.dcm")
            && message.contains("no StructureSetROISequence (3006,0020)"),
        "{message}"
    );
}

/// Found by CI's fuzzer after the two above were fixed (cargo fuzz tmin: 177 bytes). The file
/// meta group's length (0002,0000) says 0x410000BA bytes, and right after it comes an element
/// of group 0045. The length walk before parsing ended the meta group there, but
/// `FileMetaTable::from_reader` trusts the group length: it read on, into a (0002,0002) whose
/// VR is two zero bytes (taken as UN: a 4-byte length) declaring 3.9 GB, and reserved that.
/// The meta group is now read by the parse's own bounded decoder and ends where group 0002 ends.
#[test]
fn rtstruct_whose_meta_group_length_runs_past_another_group_is_refused() {
    let path = regression("rtstruct-meta-past-another-group.dcm");
    let e = read(std::slice::from_ref(&path), &InputOptions::default()).unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("rtstruct-meta-past-another-group.dcm")
            && message.contains(
                "the file meta group (which ends at byte 144, where element (0045,0001) \
                 begins) has no Transfer Syntax UID (0002,0010)"
            ),
        "{message}"
    );
}

/// The same path found separately (234 bytes after tmin): after (0002,0000) comes an element
/// of group 0000, then a (0002,0003) with the unknown VR `zz` declaring 2.05 GB (`zzzz`).
#[test]
fn rtstruct_with_a_meta_element_of_unknown_vr_past_another_group_is_refused() {
    let path = regression("rtstruct-meta-unknown-vr.dcm");
    let e = read(std::slice::from_ref(&path), &InputOptions::default()).unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("rtstruct-meta-unknown-vr.dcm")
            && message.contains("where element (0000,0001) begins) has no Transfer Syntax UID"),
        "{message}"
    );
}
