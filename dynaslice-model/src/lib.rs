//! The model service: everything a front end needs to use a trained model file besides
//! evaluating it, in one place, so that the command line and the Python package cannot
//! disagree (the C ABI holds the same validated model type, [`dynaslice_core::OwnedModel`]).
//!
//! - [`ModelFile`]: open and validate a model file (regular files only, size bounded), its
//!   classes with names and the input's colours, its input's frame ([`dynaslice_sequence::Space`])
//!   and units, whether it is static, and the one time rule
//!   ([`dynaslice_core::Domain::contains_time`]: a time outside the range is an error).
//! - [`resolve_classes`]: class keys (numbers or names) to channels.
//! - [`describe`]: what `dynaslice info` says of a model, line by line.
//! - [`RunRecord`]: the model's metadata typed, every key the trainer writes, with the one rule
//!   for models written before a key existed; the trainer writes through it and every reader
//!   reads through it.

#![warn(missing_docs)]

mod classes;
mod description;
mod model_file;
pub mod run_record;

pub use classes::resolve_classes;
pub use description::describe;
pub use model_file::ModelFile;
pub use run_record::{recorded_class_colors, RunRecord, SampleRecord};
