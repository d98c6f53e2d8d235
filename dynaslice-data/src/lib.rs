//! DynaSlice's input side: the readers and writers of the file formats users bring, which turn
//! them into a [`Sequence`] of annotated cross-sections (`dynaslice-sequence`, whose types are
//! re-exported here as every reader returns them), and the policy that turns label maps into
//! planes (reslicing, drawn-slice detection, combining several inputs).
//!
//! | source | entry point |
//! | --- | --- |
//! | native JSON (`docs/data-format.md`) | `dynaslice_sequence::native`, read through [`input::read`] |
//! | any input, one or several, by file name | [`input::read`] |
//! | `.csl` file | [`csl::read`] |
//! | `.seq` manifest | [`manifest::read`], read through [`input::read`] |
//! | NIfTI label volume, resliced | [`nifti::read`] with [`reslice::ResliceOptions`] |
//! | label names and colours (text, NIfTI XML, Slicer `.ctbl`, ITK-SNAP) | [`LabelTable`] |
//! | a label map's classes counted, and refused past a model's limit, before any plane is cut | [`label_census`] |
//! | DICOM RT Structure Set (RTSTRUCT) | [`rtstruct::read`] |
//! | classes drawn one inside another: found, made disjoint for training | [`nesting`] |
//! | a label map's planes: reslicing, drawn slices, several inputs in one | [`reslice`], [`drawn_slices`], [`combine`] |
//!
//! Every reader returns a validated [`Sequence`] or a [`DataError`] that names the file, line,
//! timestep, plane, class and what is wrong. Nothing panics on input and nothing is dropped
//! silently.

#![warn(missing_docs)]

pub mod color_table;
pub mod combine;
pub mod csl;
pub mod drawn_slices;
pub mod frame_range;
pub mod input;
pub mod input_flags;
pub mod input_kind;
pub mod input_spec;
pub mod label_census;
pub mod label_map;
pub mod label_table;
pub mod label_volume;
pub mod limit;
pub mod manifest;
pub mod nesting;
pub mod nifti;
pub mod nifti_stream;
pub mod nrrd;
pub mod reslice;
pub mod rtstruct;
pub mod time_series;
pub mod voxel_type;

pub use dynaslice_sequence::{
    Aabb, Annotation, ClassInfo, DataError, ErrorKind, Frame, Location, Plane, Rect, Result,
    Sequence, Space, TimeUnit, Units,
};
pub use frame_range::FrameRange;
pub use label_table::LabelTable;
pub use time_series::TimeSeries;
