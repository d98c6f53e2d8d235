//! The synthetic 4D benchmark: dynamic shapes with exact analytic SDFs ([`shapes`]) and the
//! writer of their slices and ground truth ([`benchmark`]), as in the paper's synthetic
//! evaluation (Sec. 4). `dynaslice synth -o DIR` runs [`write_data_sets`]; metrics evaluate
//! [`Shape::sdf`] directly.

#![warn(missing_docs)]

pub mod benchmark;
pub mod shapes;

pub use benchmark::{
    label_volume, slice_sequence, write_benchmark, write_data_sets, BenchmarkFiles,
    BenchmarkOptions,
};
pub use shapes::Shape;
