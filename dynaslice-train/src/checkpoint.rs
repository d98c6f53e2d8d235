//! Checkpoints: everything needed to continue a run bit for bit after a kill.
//!
//! The samples of step s are a pure function of (seed, s), so the state is just the step, the
//! parameters and Adam's moments; a fingerprint of the run's options guards against resuming
//! with different ones. Format (little-endian): magic `DSCKPT01`, u64 fingerprint, u64 step,
//! u64 Adam t, u64 n, then n f32 parameters, n f32 m, n f32 v, and a CRC-32 of all that. It is
//! written atomically (temporary file, fsync, rename), so a kill mid-write leaves the previous
//! checkpoint intact.

use super::adam::Adam;
use anyhow::{bail, Context, Result};
use dynaslice_data::atomic::write_atomically;
use std::path::Path;

const MAGIC: &[u8; 8] = b"DSCKPT01";

/// A training state.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Fingerprint of the options and data the run was started with.
    pub fingerprint: u64,
    /// Steps completed.
    pub step: u64,
    /// Network parameters.
    pub params: Vec<f32>,
    /// Optimiser state.
    pub adam: Adam,
}

impl Checkpoint {
    /// Serialises and writes atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let n = self.params.len();
        let mut out = Vec::with_capacity(40 + 12 * n + 4);
        out.extend_from_slice(MAGIC);
        for v in [self.fingerprint, self.step, self.adam.t, n as u64] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in self.params.iter().chain(&self.adam.m).chain(&self.adam.v) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        let crc = dynaslice_core::crc32(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        write_atomically(path, &out)
    }

    /// Reads a checkpoint, checking its integrity and that it belongs to a run with
    /// `fingerprint` and `n` parameters; `adam` supplies the hyper-parameters.
    pub fn load(path: &Path, fingerprint: u64, n: usize, adam: &Adam) -> Result<Checkpoint> {
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read checkpoint {}", path.display()))?;
        let what = |msg: &str| format!("checkpoint {}: {msg}", path.display());
        let expected = 40 + 12 * n + 4;
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            bail!(what("not a DynaSlice checkpoint"));
        }
        if bytes.len() != expected {
            bail!(what(&format!(
                "{} bytes, expected {expected} for {n} parameters",
                bytes.len()
            )));
        }
        let (body, crc) = bytes.split_at(expected - 4);
        if dynaslice_core::crc32(body) != u32::from_le_bytes(crc.try_into()?) {
            bail!(what("CRC mismatch (corrupt file)"));
        }
        let word = |i: usize| u64::from_le_bytes(body[8 + 8 * i..16 + 8 * i].try_into().unwrap());
        if word(0) != fingerprint {
            bail!(what(
                "written by a run with other options or data; start afresh without --resume"
            ));
        }
        if word(3) != n as u64 {
            bail!(what("parameter count differs from this network"));
        }
        let floats: Vec<f32> = body[40..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let mut adam = adam.clone();
        adam.t = word(2);
        adam.m = floats[n..2 * n].to_vec();
        adam.v = floats[2 * n..].to_vec();
        Ok(Checkpoint {
            fingerprint,
            step: word(1),
            params: floats[..n].to_vec(),
            adam,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adam::AdamConfig;

    #[test]
    fn round_trip_and_rejections() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.ckpt");
        let mut adam = Adam::new(3, AdamConfig::default());
        adam.step(&mut [1.0, 2.0, 3.0], &[0.1, -0.2, 0.3], 1e-3);
        let c = Checkpoint {
            fingerprint: 42,
            step: 7,
            params: vec![1.5, -2.0, 0.25],
            adam: adam.clone(),
        };
        c.save(&path).unwrap();
        assert_eq!(Checkpoint::load(&path, 42, 3, &adam).unwrap(), c);
        let err = Checkpoint::load(&path, 43, 3, &adam)
            .unwrap_err()
            .to_string();
        assert!(err.contains("other options"), "{err}");
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[50] ^= 4;
        std::fs::write(&path, &bytes).unwrap();
        let err = Checkpoint::load(&path, 42, 3, &adam)
            .unwrap_err()
            .to_string();
        assert!(err.contains("CRC mismatch"), "{err}");
        std::fs::write(&path, &bytes[..30]).unwrap();
        assert!(Checkpoint::load(&path, 42, 3, &adam).is_err());
    }
}
