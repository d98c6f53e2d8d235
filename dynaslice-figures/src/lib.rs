//! DynaSlice's figures: PNG line charts with a bundled font ([`plot`]) and a model's labels with
//! the input contours on an input plane ([`picture`]).

#![warn(missing_docs)]

pub mod picture;
pub mod plot;
