//! DynaSlice's input side: the sequence of annotated cross-sections ([`Sequence`]), its readers
//! and writers, the 2D geometry of contours, frame selections and time series, and the synthetic
//! 4D benchmark.
//!
//! | source | entry point |
//! | --- | --- |
//! | native JSON (`docs/data-format.md`) | [`native::read`], [`native::write`] |
//! | any input, one or several, by file name | [`input::read`] |
//! | opening any input file: regular files only, reads capped by the format | [`input_file`] |
//! | `.csl` file | [`csl::read`] |
//! | `.seq` manifest | [`manifest::read`], read through [`input::read`] |
//! | NIfTI label volume, resliced | [`nifti::read`] with [`reslice::ResliceOptions`] |
//! | label names and colours (text, NIfTI XML, Slicer `.ctbl`, ITK-SNAP) | [`LabelTable`] |
//! | DICOM RT Structure Set (RTSTRUCT) | [`rtstruct::read`] |
//! | the synthetic benchmark | [`synth::slice_sequence`], [`synth::write_benchmark`] |
//!
//! Every reader returns a validated [`Sequence`] or a [`DataError`] that names the file, line,
//! timestep, plane, class and what is wrong. Nothing panics on input and nothing is dropped
//! silently.

#![warn(missing_docs)]

pub mod atomic;
pub mod color_table;
pub mod combine;
pub mod csl;
pub mod drawn_slices;
pub mod error;
pub mod frame_range;
pub mod geometry;
pub mod input;
pub mod input_file;
pub mod input_spec;
pub mod label_table;
pub mod manifest;
pub mod native;
pub mod nifti;
pub mod nifti_stream;
pub mod nrrd;
pub mod palette;
pub mod reslice;
pub mod rtstruct;
pub mod sequence;
pub mod space;
pub mod synth;
pub mod time_series;
pub mod voxel_type;

pub use error::{DataError, ErrorKind, Location, Result};
pub use frame_range::FrameRange;
pub use label_table::LabelTable;
pub use sequence::{Aabb, Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
pub use space::{Space, Units};
pub use time_series::TimeSeries;
