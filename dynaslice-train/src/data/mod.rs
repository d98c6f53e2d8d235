//! Cross-section data: the data model ([`model`]), its readers and writer, and their errors.
//!
//! | source | entry point |
//! | --- | --- |
//! | native JSON (`docs/data-format.md`) | [`native::read`], [`native::write`] |
//! | `.csl` file or manifest | [`csl::read`], [`csl::read_sequence`] |
//! | NIfTI label volume, resliced | [`nifti::read`] with [`reslice::ResliceOptions`] |
//!
//! Every reader returns a validated [`Sequence`] or a [`DataError`] that names the file, line,
//! timestep, plane, class and what is wrong. Nothing panics on input and nothing is dropped
//! silently.

pub mod csl;
pub mod error;
pub mod labels;
pub mod model;
pub mod native;
pub mod nifti;
pub mod reslice;

pub use error::{DataError, ErrorKind, Location, Result};
pub use labels::LabelNames;
pub use model::{Aabb, Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
