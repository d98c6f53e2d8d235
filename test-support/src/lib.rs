//! DynaSlice's shared test fixtures, a dev-dependency of the workspace's crates and never part of
//! the product: hand-built model files with closed-form answers ([`spheres`]), input files and
//! process helpers for command-line tests ([`fixtures`]).

pub mod fixtures;
pub mod spheres;
