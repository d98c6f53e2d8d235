//! Checkpoints: everything needed to continue a run bit for bit after a kill.
//!
//! The samples of step s are a pure function of (seed, s), so the state is just the step, the
//! parameters and Adam's moments; a fingerprint of the run's options guards against resuming
//! with different ones. A timed run's planned schedule length is kept too, so that a resumed run
//! follows the same learning rates. Format (little-endian): magic `DSCKPT02`, u64 fingerprint,
//! u64 step, u64 Adam t, u64 n, u64 planned schedule length (0: none), then n f32 parameters,
//! n f32 m, n f32 v, and a CRC-32 of all that. `DSCKPT01` files (the same without the planned
//! length) are still read. It is written atomically (temporary file, fsync, rename), so a kill
//! mid-write leaves the previous checkpoint intact.

use super::adam::Adam;
use anyhow::{bail, Context, Result};
use dynaslice_data::atomic::write_atomically;
use std::path::Path;

const MAGIC: &[u8; 8] = b"DSCKPT02";
/// The first format, without the planned schedule length.
const MAGIC_V1: &[u8; 8] = b"DSCKPT01";

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
    /// The learning-rate schedule's length planned by a timed run
    /// ([`crate::trainer::TrainOptions::time_limit`]), once planned.
    pub planned_steps: Option<u64>,
}

impl Checkpoint {
    /// Serialises and writes atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let n = self.params.len();
        let mut out = Vec::with_capacity(48 + 12 * n + 4);
        out.extend_from_slice(MAGIC);
        let planned = self.planned_steps.unwrap_or(0);
        for v in [self.fingerprint, self.step, self.adam.t, n as u64, planned] {
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
        let header = match bytes.get(..8) {
            Some(m) if m == MAGIC => 48,
            Some(m) if m == MAGIC_V1 => 40,
            _ => bail!(what("not a DynaSlice checkpoint")),
        };
        let expected = header + 12 * n + 4;
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
        let planned_steps = (header == 48 && word(4) > 0).then(|| word(4));
        let floats: Vec<f32> = body[header..]
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
            planned_steps,
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
            planned_steps: Some(1234),
        };
        c.save(&path).unwrap();
        assert_eq!(Checkpoint::load(&path, 42, 3, &adam).unwrap(), c);
        // A first-format file (no planned length) still reads.
        let v2 = std::fs::read(&path).unwrap();
        let mut v1 = [MAGIC_V1.as_slice(), &v2[8..40], &v2[48..v2.len() - 4]].concat();
        v1.extend_from_slice(&dynaslice_core::crc32(&v1).to_le_bytes());
        std::fs::write(&path, &v1).unwrap();
        let old = Checkpoint::load(&path, 42, 3, &adam).unwrap();
        assert_eq!(
            old,
            Checkpoint {
                planned_steps: None,
                ..c.clone()
            }
        );
        c.save(&path).unwrap();
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
