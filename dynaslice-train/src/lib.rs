//! DynaSlice's trainer side: cross-section readers, 2D geometry, samplers, the trainer, exporters
//! and metrics. The `dynaslice` command line is a thin layer over this library.

pub mod data;
pub mod geometry;
pub mod sampling;
pub mod synth;
pub mod train;
pub mod cli;
pub mod model_file;
pub mod plot;
pub mod frame_range;
