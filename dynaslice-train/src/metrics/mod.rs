//! Accuracy measures against ground truth.
//!
//! - [`iou`]: 3D intersection over union of the Eq. 11 label partition on a grid.

pub mod iou;
