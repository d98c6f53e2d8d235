//! DynaSlice's trainer: exact hand-written gradients of the DynaSlice loss (Eq. 5–8, 10) and Adam.
//!
//! - [`network`]: parameters in the core's layout, SIREN initialisation.
//! - [`temporal_bound`]: Eq. 4, the bound ω_t^max = c·π/Δt, its initialisation and projection;
//!   [`spatial_bound`]: the same across parallel planes.
//! - [`extent_bound`]: each class's extent (its contours' box), beyond which it is held outside.
//! - [`passes`]: forward with spatial tangents and the matching backward pass.
//! - [`reverse_over_reverse`]: the second scheme for ∇ₓf losses, cheaper for K ≤ 2.
//! - [`loss`]: the loss terms and their gradients with respect to f and ∇ₓf.
//! - [`sampling`]: area-uniform contour, plane and space-time samples of a sequence;
//!   [`data_sampler`]: those samples in the network's normalised frame, per step.
//! - [`objective`]: the loss and gradient of one batch over worker threads.
//! - the optimiser (Adam) and the resumable state (checkpoints): the `dynaslice-optim` crate.
//! - [`mod@bench`]: step throughput against the machine's sgemm peak.
//! - [`trainer`]: the loop, with its schedule, time limit and checkpoints.
//! - [`flags`]: the table of training options (name, help, default, limit);
//!   [`spec`]: every option of a run, its default and its allowed range; [`fit`]: the one
//!   training entry (checks, frame, sampler, loop, loss [`journal`], model bytes) that the
//!   command line, Python and the lab adapt; [`job`]: the whole run with its files (input,
//!   outputs, checkpoint, loss log and curve, extent warnings) that `dynaslice train` and
//!   Python's `dynaslice.train` call, each passing the one function that draws the curve.
//! - [`model_file`]: a trained network's model file and the metadata it records.

#![warn(missing_docs)]

pub mod bench;
pub mod data_sampler;
pub mod extent_bound;
pub mod fit;
pub mod flags;
pub mod job;
pub mod journal;
pub mod loss;
mod matmul;
pub mod model_file;
pub mod network;
pub mod objective;
pub mod passes;
pub mod reverse_over_reverse;
pub mod sampling;
mod simd;
pub mod spatial_bound;
pub mod spec;
pub mod temporal_bound;
pub mod trainer;
pub mod warp;

#[cfg(test)]
mod gradient_check;
