//! DynaSlice's optimiser state, kept apart from the trainer's numerics:
//!
//! - [`adam`]: Adam (the paper's optimiser) and its moments;
//! - [`schedule_plan`]: where a timed run's cosine learning-rate schedule stands at each step;
//! - [`checkpoint`]: the file that holds both with the parameters, so a killed run resumes bit
//!   for bit.

#![warn(missing_docs)]

pub mod adam;
pub mod checkpoint;
pub mod schedule_plan;
