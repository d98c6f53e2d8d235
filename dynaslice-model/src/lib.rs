//! The model service: everything a front end needs to use a trained model file besides
//! evaluating it, in one place, so that the command line, the Python package and the C ABI
//! cannot disagree.
//!
//! - [`ModelFile`]: open and validate a model file (regular files only, size bounded), its
//!   classes with names and the input's colours, its input's frame ([`dynaslice_sequence::Space`])
//!   and units, whether it is static, and the one time rule
//!   ([`dynaslice_core::Domain::contains_time`]: a time outside the range is an error).
//! - [`resolve_classes`]: class keys (numbers or names) to channels.
//! - [`class_colors`]: the metadata line recording the input's class colours.

#![warn(missing_docs)]

pub mod class_colors;
mod classes;
mod model_file;

pub use class_colors::{class_colors_line, parse_class_colors, recorded_class_colors};
pub use classes::resolve_classes;
pub use model_file::ModelFile;
