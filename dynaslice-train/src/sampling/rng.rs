//! The samplers' random numbers: PCG-64 with an explicit seed and stream, so a batch depends only
//! on (sequence, counts, seed, stream) — identical across platforms, builds and thread counts.
//! Floats are built from integer bits here rather than through a distribution crate, whose
//! algorithms may change between versions.

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;

/// Deterministic generator for the samplers.
#[derive(Debug, Clone)]
pub struct SampleRng(Pcg64);

impl SampleRng {
    /// A generator for `seed`; different `stream`s give independent sequences (e.g. one per
    /// training step or per worker thread).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut bytes = [0u8; 32];
        bytes[..8].copy_from_slice(&seed.to_le_bytes());
        bytes[8..16].copy_from_slice(&stream.to_le_bytes());
        bytes[16..24].copy_from_slice(&0x853c_49e6_748f_ea9bu64.to_le_bytes());
        bytes[24..].copy_from_slice(&(stream.wrapping_mul(2) | 1).to_le_bytes());
        SampleRng(Pcg64::from_seed(bytes))
    }

    /// Uniform in [0, 1), 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    #[inline]
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in [0, n) for n > 0 (Lemire's multiply-shift; the bias is below 2⁻³²
    /// for any n this crate uses).
    #[inline]
    pub fn below(&mut self, n: usize) -> usize {
        ((self.0.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// A standard normal pair (Box–Muller).
    #[inline]
    pub fn normal_pair(&mut self) -> (f64, f64) {
        let r = (-2.0 * (1.0 - self.uniform()).ln()).sqrt();
        let a = std::f64::consts::TAU * self.uniform();
        (r * a.cos(), r * a.sin())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproducible_and_streams_differ() {
        let a: Vec<u64> = (0..4).map(|_| SampleRng::new(7, 1).0.next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        let mut x = SampleRng::new(7, 1);
        let mut y = SampleRng::new(7, 2);
        assert_ne!(x.uniform(), y.uniform());
        let mut z = SampleRng::new(7, 1);
        for _ in 0..1000 {
            let u = z.uniform();
            assert!((0.0..1.0).contains(&u));
            assert!(z.below(3) < 3);
        }
    }
}
