//! The trainer: exact hand-written gradients of the DynaSlice loss (Eq. 5–8, 10) and Adam.
//!
//! - [`network`]: parameters in the core's layout, SIREN initialisation, ω_t clamp (Eq. 4).
//! - [`passes`]: forward with spatial tangents and the matching backward pass.
//! - [`reverse_over_reverse`]: the second scheme for ∇ₓf losses, cheaper for K ≤ 2.
//! - [`loss`]: the loss terms and their gradients with respect to f and ∇ₓf.
//! - [`data_sampler`]: samples from cross-section data in the normalised frame.
//! - [`objective`]: the loss and gradient of one batch over worker threads.
//! - [`adam`]: the optimiser; [`checkpoint`]: resumable state.
//! - [`mod@bench`]: step throughput against the machine's sgemm peak.
//! - [`trainer`]: the loop, with its schedule, time limit and checkpoints.

pub mod adam;
pub mod bench;
pub mod checkpoint;
pub mod data_sampler;
pub mod loss;
mod matmul;
pub mod network;
pub mod objective;
pub mod passes;
pub mod reverse_over_reverse;
mod simd;
pub mod trainer;

#[cfg(test)]
mod gradient_check;
