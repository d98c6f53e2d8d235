//! DynaSlice's shared test fixtures, a dev-dependency of the workspace's crates and never part of
//! the product: an independent f64 evaluation of the network ([`mod@reference`]), hand-built model
//! files with closed-form answers ([`spheres`]), input files and process helpers for
//! command-line tests ([`fixtures`]), headless Chromium ([`browser`]), and Python scripts with the users' libraries ([`python`]).

#![warn(missing_docs)]

pub mod browser;
pub mod fixtures;
pub mod python;
pub mod reference;
pub mod spheres;
