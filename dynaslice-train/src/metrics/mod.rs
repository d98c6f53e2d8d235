//! Accuracy measures against ground truth.
//!
//! - [`iou`]: 3D intersection over union of the Eq. 11 label partition on a grid.
//! - [`spheres`]: a hand-built model of growing spheres, a closed-form ground truth for tests.

pub mod iou;
pub mod spheres;
