//! The kinds of input DynaSlice reads, told by file name (and by content where the name says
//! nothing, see [`InputKind::of`]).

use std::path::Path;

use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;

/// The kinds of input, by file name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// DynaSlice's native JSON sequence.
    Native,
    /// A `.csl` cross-section file.
    Csl,
    /// A `.seq` / `.cslseq` manifest of single-timestep inputs.
    Manifest,
    /// A NIfTI label map.
    Nifti,
    /// An NRRD label map or 3D Slicer segmentation.
    Nrrd,
    /// A DICOM RT Structure Set.
    RtStruct,
}

impl InputKind {
    /// The kind `path` names, or an error listing the kinds there are.
    pub fn of(path: &Path) -> Result<InputKind> {
        let name = path.to_string_lossy().to_ascii_lowercase();
        let kind = if name.ends_with(".nii") || name.ends_with(".nii.gz") {
            InputKind::Nifti
        } else if name.ends_with(".nrrd") || name.ends_with(".nhdr") {
            InputKind::Nrrd
        } else if name.ends_with(".dcm") {
            InputKind::RtStruct
        } else if name.ends_with(".json") {
            InputKind::Native
        } else if name.ends_with(".csl") {
            InputKind::Csl
        } else if name.ends_with(".seq") || name.ends_with(".cslseq") {
            InputKind::Manifest
        } else if has_dicom_marker(path)? {
            InputKind::RtStruct
        } else {
            return Err(DataError::new(ErrorKind::UnsupportedInput).in_file(path));
        };
        Ok(kind)
    }
}

/// Whether the file has DICOM's `DICM` marker, after the 128-byte preamble or (a file written
/// without one) at its start: DICOM files often have no extension (`RS.1.2.840…`). A path that
/// is there but not a regular file is an error naming it; one that cannot be opened has no
/// marker (the name then decides: an unsupported type).
fn has_dicom_marker(path: &Path) -> Result<bool> {
    use std::io::Read;
    let file = match input_file::open(path) {
        Ok((file, _)) => file,
        Err(e) if matches!(e.kind, ErrorKind::Io(_)) => return Ok(false),
        Err(e) => return Err(e),
    };
    let mut head = Vec::with_capacity(132);
    file.take(132)
        .read_to_end(&mut head)
        .map_err(|e| DataError::new(e.into()).in_file(path))?;
    Ok(head.get(128..132) == Some(b"DICM") || head.starts_with(b"DICM"))
}
