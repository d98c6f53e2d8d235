//! Reading and writing model files (and checkpoints) on disk.

use anyhow::{Context, Result};
use std::path::Path;

/// Reads a model file into a buffer aligned for the core's zero-copy weights (8-byte words).
pub fn read_model_bytes(path: &Path) -> Result<AlignedBytes> {
    let raw =
        std::fs::read(path).with_context(|| format!("cannot read model {}", path.display()))?;
    Ok(AlignedBytes::copy_from(&raw))
}

/// Bytes stored in `u64` words so that they start 8-byte aligned.
pub struct AlignedBytes {
    words: Vec<u64>,
    len: usize,
}

impl AlignedBytes {
    /// Copies `bytes` into an aligned buffer.
    pub fn copy_from(bytes: &[u8]) -> AlignedBytes {
        let mut words = vec![0u64; bytes.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        AlignedBytes {
            words,
            len: bytes.len(),
        }
    }
}

impl std::ops::Deref for AlignedBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.len]
    }
}
