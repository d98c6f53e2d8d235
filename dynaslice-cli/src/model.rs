//! Opening a model file: the model service's [`ModelFile`], the one way every subcommand
//! reads a model and checks a time against its range.

pub use dynaslice_model::ModelFile;
