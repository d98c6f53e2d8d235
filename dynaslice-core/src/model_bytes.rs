//! An owned model file, aligned so that [`Model::from_bytes`] reads its weights in place.
//!
//! A `Vec<u8>` is only 1-byte aligned, so weights in it may be rejected as
//! [`Error::Misaligned`]. [`ModelBytes`] stores the file in 8-byte words, which satisfies every
//! weight type (f32 needs 4, f16 needs 2), and is the one way the `std` side of DynaSlice holds
//! a model file in memory.

use crate::{format, Error, Model};
use std::boxed::Box;
use std::path::Path;
use std::vec;

/// Model file bytes in 8-byte aligned owned storage.
///
/// Invariant: `words` holds at least `len` bytes; bytes past `len` are zero.
#[derive(Clone, PartialEq, Eq)]
pub struct ModelBytes {
    words: Box<[u64]>,
    len: usize,
}

impl ModelBytes {
    /// Copies `bytes` (any alignment) into aligned storage. Nothing is validated: see
    /// [`ModelBytes::model`].
    pub fn copy_from(bytes: &[u8]) -> ModelBytes {
        let mut words = vec![0u64; bytes.len().div_ceil(8)].into_boxed_slice();
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        ModelBytes {
            words,
            len: bytes.len(),
        }
    }

    /// Reads the file at `path`, refusing anything that is not a regular file or is larger than
    /// any model can be ([`format::max_file_size`]) before reading it. Nothing is validated: see
    /// [`ModelBytes::model`].
    ///
    /// The file type is checked before the open (opening a FIFO for reading blocks until a
    /// writer comes) and again on the opened file (a path replaced in between).
    pub fn read(path: &Path) -> std::io::Result<ModelBytes> {
        use std::io::{Error as IoError, ErrorKind, Read};
        let not_regular = || {
            IoError::new(
                ErrorKind::InvalidInput,
                "not a regular file (a FIFO, device or directory)",
            )
        };
        if !std::fs::metadata(path)?.is_file() {
            return Err(not_regular());
        }
        let file = std::fs::File::open(path)?;
        let meta = file.metadata()?;
        if !meta.is_file() {
            return Err(not_regular());
        }
        let max = format::max_file_size();
        if meta.len() > max {
            return Err(IoError::new(
                ErrorKind::InvalidData,
                std::format!(
                    "{} bytes, larger than any model file ({max} at most)",
                    meta.len()
                ),
            ));
        }
        let mut bytes = vec::Vec::with_capacity(meta.len() as usize);
        // `take` bounds the read even if the file grows after `metadata`.
        file.take(max + 1).read_to_end(&mut bytes)?;
        if bytes.len() as u64 > max {
            return Err(IoError::new(
                ErrorKind::InvalidData,
                "the file grew past the largest model file while it was read",
            ));
        }
        Ok(ModelBytes::copy_from(&bytes))
    }

    /// The bytes, 8-byte aligned.
    pub fn as_bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.len]
    }

    /// The validated model these bytes hold ([`Model::from_bytes`]).
    pub fn model(&self) -> Result<Model<'_>, Error> {
        Model::from_bytes(self.as_bytes())
    }
}

impl core::ops::Deref for ModelBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_bytes()
    }
}

impl core::fmt::Debug for ModelBytes {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "ModelBytes({} bytes)", self.len)
    }
}

/// A model file in owned aligned storage, validated once (CRC, every weight) when made, and the
/// [`Model`] view into it: the one owned model type of the `std` side (the model service, the
/// Python package and the C ABI hold it). [`OwnedModel::model`] costs nothing, however often
/// it is called.
pub struct OwnedModel {
    /// Borrows `*storage`. The `'static` is a private lie made sound by the ownership below:
    /// the borrow is never handed out with a lifetime longer than `&self`, see
    /// [`OwnedModel::model`].
    model: Model<'static>,
    /// The model bytes, from `Box::into_raw`, freed in `Drop`. Held as a raw pointer rather than
    /// as a `ModelBytes` (or a `Box` of one) so that moving an `OwnedModel` never moves the
    /// `Box` inside `ModelBytes`, which would assert unique ownership of memory that `model`
    /// still borrows under Rust's aliasing rules.
    storage: *mut ModelBytes,
}

// SAFETY: `storage` is only written when dropped (with `&mut self`), and `Model` and
// `ModelBytes` are `Sync` and `Send`: the raw pointer is all that stops the compiler from
// deriving these.
unsafe impl Send for OwnedModel {}
// SAFETY: as above; every method takes `&self` and only reads.
unsafe impl Sync for OwnedModel {}

impl OwnedModel {
    /// Validates `bytes` ([`Model::from_bytes`]) and keeps them with their view.
    pub fn new(bytes: ModelBytes) -> Result<OwnedModel, Error> {
        let storage = Box::into_raw(Box::new(bytes));
        // SAFETY: `storage` is a live allocation that nothing else references and nothing
        // writes; it is freed only by `Drop`, after the last use of `model`.
        let view: &'static ModelBytes = unsafe { &*storage };
        match view.model() {
            Ok(model) => Ok(OwnedModel { model, storage }),
            Err(e) => {
                // SAFETY: from `Box::into_raw` above; `view` is not used after this.
                drop(unsafe { Box::from_raw(storage) });
                Err(e)
            }
        }
    }

    /// The model, borrowed no longer than `self` (which owns its bytes).
    pub fn model(&self) -> &Model<'_> {
        &self.model
    }

    /// The file's bytes.
    pub fn bytes(&self) -> &ModelBytes {
        // SAFETY: `storage` is live until `Drop` and only ever read.
        unsafe { &*self.storage }
    }
}

impl Drop for OwnedModel {
    fn drop(&mut self) {
        // SAFETY: `storage` came from `Box::into_raw` in `new` and is freed only here; `model`
        // (a plain view without `Drop`) is never used again.
        drop(unsafe { Box::from_raw(self.storage) });
    }
}

impl core::fmt::Debug for OwnedModel {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "OwnedModel({} bytes)", self.bytes().len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::ModelWriter;

    #[test]
    fn copies_are_aligned_and_exact() {
        let file = ModelWriter::random_siren(&[16, 16], 2, 3).to_bytes();
        let mut shifted = vec![0u8; file.len() + 1];
        shifted[1..].copy_from_slice(&file);
        let bytes = ModelBytes::copy_from(&shifted[1..]);
        assert_eq!(bytes.as_ptr() as usize % 8, 0);
        assert_eq!(&bytes[..], &file[..]);
        assert_eq!(bytes.model().unwrap().num_classes(), 2);
    }

    /// Validation happens once, in `new`: a bad file is refused there, and the view of a good
    /// one outlives moves of its owner.
    #[test]
    fn owned_models_validate_once_and_move_freely() {
        let file = ModelWriter::random_siren(&[8, 8], 3, 5).to_bytes();
        let mut bad = file.clone();
        bad[300] ^= 1;
        assert!(matches!(
            OwnedModel::new(ModelBytes::copy_from(&bad)),
            Err(Error::CrcMismatch { .. })
        ));
        let owned = OwnedModel::new(ModelBytes::copy_from(&file)).unwrap();
        let moved = std::vec![owned];
        let owned = &moved[0];
        assert_eq!(owned.model().num_classes(), 3);
        assert_eq!(&owned.bytes()[..], &file[..]);
        let mut f = [0.0f32; 3];
        owned.model().eval([0.1, 0.2, 0.3], 0.5, &mut f).unwrap();
        assert!(f.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn read_refuses_directories_and_reads_files() {
        let dir = std::env::temp_dir().join(std::format!("dsm-bytes-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(
            ModelBytes::read(&dir).unwrap_err().kind(),
            std::io::ErrorKind::InvalidInput
        );
        let path = dir.join("m.dsm");
        let file = ModelWriter::random_siren(&[8], 1, 1).to_bytes();
        std::fs::write(&path, &file).unwrap();
        assert_eq!(&ModelBytes::read(&path).unwrap()[..], &file[..]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
