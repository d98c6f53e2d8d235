//! Exact 2D geometry on a cross-section plane: polygons and their orientation convention
//! ([`polygon`]), a bucket grid over segments ([`bucket_grid`]), the exact signed distance with
//! outward normals ([`sdf`]), contour extraction from sampled fields ([`marching_squares`]), the
//! even-odd repair of crossing contours ([`repair`]), and region differences and overlaps
//! ([`boolean`]).
//!
//! Nothing here knows about files or sequences: readers (`dynaslice-data`) validate and repair
//! contours with it, the trainer samples its distances, and meshing and pictures extract
//! contours with it.

#![warn(missing_docs)]

pub mod boolean;
pub mod bucket_grid;
pub mod marching_squares;
pub mod polygon;
pub mod repair;
pub mod sdf;

/// A point (u, v) in plane coordinates.
pub type Point2 = [f64; 2];

pub use polygon::Polygon;
pub use sdf::PolygonSdf;
