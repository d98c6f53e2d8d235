//! Exact 2D geometry on a cross-section plane: polygons and their orientation convention
//! ([`polygon`]), a bucket grid over segments ([`bucket_grid`]), the exact signed distance with
//! outward normals ([`sdf`]), contour extraction from sampled fields ([`marching_squares`]), and the
//! even-odd repair of crossing contours ([`repair`]).

pub mod bucket_grid;
pub mod marching_squares;
pub mod polygon;
pub mod repair;
pub mod sdf;

pub use polygon::{Point2, Polygon};
pub use sdf::PolygonSdf;
