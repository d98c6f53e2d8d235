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
            && message.contains("more than the whole file"),
        "{message}"
    );
}

/// An RTSTRUCT with an item header outside any sequence: dicom-parser's lazy reader panicked
/// ("item header should be read only inside an existing sequence"). Now an error naming the file.
#[test]
fn rtstruct_with_an_item_outside_a_sequence_is_an_error() {
    let path = regression("rtstruct-item-outside-sequence.dcm");
    let e = read(std::slice::from_ref(&path), &InputOptions::default()).unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("rtstruct-item-outside-sequence.dcm")
            && message.contains("not a readable DICOM file"),
        "{message}"
    );
}
