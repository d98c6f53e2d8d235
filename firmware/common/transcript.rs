//! The query transcript shared by the host reference (`modelgen`, std build) and the firmware
//! builds (`freestanding`, `cortex-m4`, no_std): the same source evaluated on each platform, so
//! any difference between their outputs is a difference of platform, not of test code.
//!
//! Included with `#[path]` rather than built as a crate so that each firmware project stays one
//! self-contained Cargo project with `dynaslice-core` as its only DynaSlice dependency.
//!
//! The transcript is a list of 32-bit words: for each model, for each query point, the K values
//! f, the 3K gradient components ∇ₓf, the K time derivatives ∂f/∂t, the 3 components of the
//! displacement u (zero for a model without motion; all as IEEE bits) and the Eq. 11 label. Single-point evaluation uses the portable kernels on every target and Rust never
//! contracts `a * b + c` into a fused multiply-add, so the words are expected to match bit for
//! bit across x86-64 and Cortex-M4F (both IEEE binary32, round to nearest, subnormals kept).

use dynaslice_core::format::MAX_CLASSES;
use dynaslice_core::{Error, Model};

/// World points (millimetres) and times (seconds) inside and around the generated models'
/// domain (see `modelgen`): centre, corners, a far-away point and the time-range ends.
pub const QUERIES: [([f32; 3], f32); 8] = [
    ([10.0, -20.0, 5.0], 0.4),
    ([0.0, 0.0, 0.0], 0.0),
    ([-30.0, 25.5, 40.0], 0.95),
    ([70.0, -90.0, 60.0], 0.2),
    ([-69.5, 49.5, -59.5], 0.8999),
    ([12.25, -3.125, 18.0], 0.1),
    ([500.0, 500.0, -500.0], 0.5),
    ([1.0e-3, -1.0e-3, 2.5], 0.6),
];

/// Words one model contributes: per query 5K + 3 + 1.
// Sizes static buffers in modelgen and cortex-m4; the freestanding library takes its size from C.
#[allow(dead_code)]
pub const fn words_per_model(k: usize) -> usize {
    QUERIES.len() * (5 * k + 4)
}

/// Why a transcript could not be produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TranscriptError {
    /// Model `index` was refused by `Model::from_bytes` or a query failed.
    Model(usize, Error),
    /// `out` is too short.
    OutputTooShort,
}

/// Evaluates every model at every query point, writing the words to `out`; returns how many.
pub fn transcript(models: &[&[u8]], out: &mut [u32]) -> Result<usize, TranscriptError> {
    let mut n = 0;
    let mut push = |word: u32| -> Result<(), TranscriptError> {
        *out.get_mut(n).ok_or(TranscriptError::OutputTooShort)? = word;
        n += 1;
        Ok(())
    };
    for (index, bytes) in models.iter().enumerate() {
        let fail = |e| TranscriptError::Model(index, e);
        let model = Model::from_bytes(bytes).map_err(fail)?;
        let k = model.num_classes();
        let mut f = [0.0f32; MAX_CLASSES];
        let mut grad = [[0.0f32; 3]; MAX_CLASSES];
        let mut dfdt = [0.0f32; MAX_CLASSES];
        for &(x, t) in &QUERIES {
            model
                .eval_jacobian(x, t, &mut f[..k], &mut grad[..k], &mut dfdt[..k])
                .map_err(fail)?;
            for v in &f[..k] {
                push(v.to_bits())?;
            }
            for v in grad[..k].iter().flatten() {
                push(v.to_bits())?;
            }
            for v in &dfdt[..k] {
                push(v.to_bits())?;
            }
            for v in model.displacement(x, t).map_err(fail)? {
                push(v.to_bits())?;
            }
            push(model.label(x, t))?;
        }
    }
    Ok(n)
}
