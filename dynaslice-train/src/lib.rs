//! DynaSlice's trainer side: cross-section readers, 2D geometry, samplers, the trainer, exporters
//! and metrics. The `dynaslice` command line is a thin layer over this library.

pub mod cli;
pub mod data;
pub mod experiments;
pub mod frame_range;
pub mod geometry;
pub mod labels;
pub mod mesh;
pub mod metrics;
pub mod model_file;
pub mod picture;
pub mod plot;
pub mod sampling;
pub mod synth;
pub mod train;
