//! Checkpoints: everything needed to continue a run bit for bit after a kill.
//!
//! The samples of step s are a pure function of (seed, s), so the state is just the step, the
//! parameters and Adam's moments; a fingerprint of the run's options guards against resuming
//! with different ones. A timed run's schedule plan is kept too, so that a resumed run
//! follows the same learning rates. Format (little-endian): magic `DSCKPT03`, u64 fingerprint,
//! u64 step, u64 Adam t, u64 n, u64 planned schedule length (0: none), u64 the plan's anchor
//! step, f64 its anchor phase ([`SchedulePlan`]), then n f32 parameters, n f32 m, n f32 v, and
//! a CRC-32 of all that. `DSCKPT02` files (a plain plan: no anchor) and `DSCKPT01` files (no
//! plan) are still read. The file's size is checked against the network before it is read. It is written atomically (temporary file, fsync, rename), so a kill
//! mid-write leaves the previous checkpoint intact.

use crate::adam::Adam;
use crate::schedule_plan::SchedulePlan;
use anyhow::{bail, Context, Result};
use dynaslice_output::write_atomically;
use std::path::Path;

const MAGIC: &[u8; 8] = b"DSCKPT03";
/// The second format, with a plain plan's length only.
const MAGIC_V2: &[u8; 8] = b"DSCKPT02";
/// The first format, without a plan.
const MAGIC_V1: &[u8; 8] = b"DSCKPT01";
/// The header's size (magic and words) in the current format.
const HEADER: usize = 64;

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
    /// The learning-rate schedule planned by a timed run
    /// (`dynaslice_train::trainer::TrainOptions::time_limit`), once planned.
    pub plan: Option<SchedulePlan>,
}

impl Checkpoint {
    /// Serialises and writes atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let n = self.params.len();
        let mut out = Vec::with_capacity(HEADER + 12 * n + 4);
        out.extend_from_slice(MAGIC);
        let (length, anchor, phase) = self
            .plan
            .map_or((0, 0, 0.0), |p| (p.length, p.anchor_step, p.anchor_phase));
        for v in [
            self.fingerprint,
            self.step,
            self.adam.t,
            n as u64,
            length,
            anchor,
            phase.to_bits(),
        ] {
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
        let what = |msg: &str| format!("checkpoint {}: {msg}", path.display());
        let meta = std::fs::metadata(path)
            .with_context(|| format!("cannot read checkpoint {}", path.display()))?;
        if !meta.is_file() {
            bail!(what("not a regular file"));
        }
        // Every format's size for `n` parameters; anything else is refused before reading.
        if ![40, 48, HEADER]
            .map(|h| (h + 12 * n + 4) as u64)
            .contains(&meta.len())
        {
            bail!(what(&format!(
                "{} bytes: not a checkpoint of this network's {n} parameters",
                meta.len()
            )));
        }
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read checkpoint {}", path.display()))?;
        let header = match bytes.get(..8) {
            Some(m) if m == MAGIC => HEADER,
            Some(m) if m == MAGIC_V2 => 48,
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
        if header == HEADER && word(4) == 0 && (word(5) != 0 || word(6) != 0) {
            bail!(what("a schedule anchor without its length"));
        }
        let plan = match header {
            HEADER if word(4) > 0 => Some(SchedulePlan {
                length: word(4),
                anchor_step: word(5),
                anchor_phase: f64::from_bits(word(6)),
            }),
            48 if word(4) > 0 => Some(SchedulePlan::plain(word(4))),
            _ => None,
        };
        if plan.is_some_and(|p| !(0.0..=1.0).contains(&p.anchor_phase)) {
            bail!(what("the schedule's phase is outside [0, 1]"));
        }
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
            plan,
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
            plan: Some(SchedulePlan {
                anchor_step: 20,
                anchor_phase: 0.125,
                length: 1234,
            }),
        };
        c.save(&path).unwrap();
        assert_eq!(Checkpoint::load(&path, 42, 3, &adam).unwrap(), c);
        // Earlier formats still read: the second with a plain plan of its length, the first
        // with none.
        let v3 = std::fs::read(&path).unwrap();
        let older = |magic: &[u8; 8], header: usize| {
            let mut b = [magic.as_slice(), &v3[8..header], &v3[HEADER..v3.len() - 4]].concat();
            b.extend_from_slice(&dynaslice_core::crc32(&b).to_le_bytes());
            std::fs::write(&path, &b).unwrap();
            Checkpoint::load(&path, 42, 3, &adam).unwrap()
        };
        assert_eq!(
            older(MAGIC_V2, 48),
            Checkpoint {
                plan: Some(SchedulePlan::plain(1234)),
                ..c.clone()
            }
        );
        assert_eq!(
            older(MAGIC_V1, 40),
            Checkpoint {
                plan: None,
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
        // A file of another network's size is refused before it is read.
        std::fs::write(&path, vec![0u8; 1 << 20]).unwrap();
        let err = Checkpoint::load(&path, 42, 3, &adam)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a checkpoint of this network"), "{err}");
    }
}
