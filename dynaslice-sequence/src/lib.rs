//! DynaSlice's data model: the sequence of annotated cross-sections ([`Sequence`]) that every
//! reader produces and the trainer consumes.
//!
//! | concept | here |
//! | --- | --- |
//! | the sequence, its frames, planes, annotations and classes, and their validation | [`sequence`] |
//! | what is wrong with an input, and exactly where | [`DataError`] |
//! | classes drawn one inside another, and how the model records it | [`nesting`] |
//! | the native JSON form (`docs/data-format.md`) | [`native::read`], [`native::write`] |
//! | opening a user's file: regular files only, reads capped by the format | [`input_file`] |
//! | the patient frame and units coordinates and times come in | [`Space`], [`Units`], [`TimeUnit`] |
//! | the class colours every output shares | [`palette`] |
//!
//! The file formats users bring (`.csl`, NIfTI, NRRD, DICOM RT Structure Sets) are read by
//! `dynaslice-data` into this type; nothing here depends on them, so meshing, the model service
//! and the trainer need no DICOM or NIfTI code.

#![warn(missing_docs)]

pub mod error;
pub mod input_file;
pub mod native;
pub mod nesting;
pub mod palette;
pub mod sequence;
pub mod space;

pub use error::{DataError, ErrorKind, Location, Result};
pub use nesting::Nested;
pub use sequence::{Aabb, Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
pub use space::{Space, TimeUnit, Units};
