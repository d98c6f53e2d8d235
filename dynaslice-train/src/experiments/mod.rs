//! The paper's experiments, reproduced (`dynaslice results`).
//!
//! - [`synthetic`]: Table 3's layout on the synthetic benchmark: 4D SIREN, + orientation and
//!   full DynaSlice, trained for the same wall time, scored by 3D IoU against the exact shapes.

pub mod synthetic;
