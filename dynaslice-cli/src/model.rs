//! Opening a model file (.dsm): the one way every subcommand reads a model.

use anyhow::{anyhow, Context, Result};
use dynaslice_core::{Model, ModelBytes};
use std::path::Path;

/// A model file read from disk and validated.
pub struct ModelFile {
    /// Valid: [`ModelFile::open`] checked them.
    bytes: ModelBytes,
}

impl ModelFile {
    /// Reads and validates the model file at `path`; every error names the file.
    pub fn open(path: &Path) -> Result<ModelFile> {
        let bytes = ModelBytes::read(path)
            .with_context(|| format!("cannot read model {}", path.display()))?;
        bytes
            .model()
            .map_err(|e| anyhow!("{}: {e}", path.display()))?;
        Ok(ModelFile { bytes })
    }

    /// The model.
    pub fn model(&self) -> Model<'_> {
        self.bytes.model().expect("validated by open")
    }

    /// The file's size in bytes.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }
}
