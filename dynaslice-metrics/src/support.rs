//! Components the data does not support: for a model and the cross-sections it was trained on,
//! the connected components of each class's Eq. 11 label region, at every annotated frame, that
//! stand farther than a distance from every contour of their class on that frame's planes, or
//! reach outside the data's box (the planes' regions of interest) by more than a margin.
//!
//! ```no_run
//! # fn demo(model: &dynaslice_core::Model, seq: &dynaslice_data::Sequence) -> anyhow::Result<()> {
//! use dynaslice_metrics::support::{unsupported_components, SupportOptions};
//! for c in unsupported_components(model, seq, &SupportOptions::default())? {
//!     eprintln!("class {} at t = {}: {} mm³ {} mm from its contours", c.class, c.time,
//!               c.volume, c.distance);
//! }
//! # Ok(()) }
//! ```
//!
//! Distances are from voxel centres: a component touching its contour is within half a voxel
//! diagonal of it. The label region is that of `dynaslice labels` on an axis-aligned grid over the
//! model's domain.

use anyhow::{ensure, Result};
use dynaslice_core::Model;
use dynaslice_data::{Aabb, Sequence};
use dynaslice_volume::{label_indices, VoxelGrid};
use kiddo::{ImmutableKdTree, SquaredEuclidean};

/// What counts as unsupported, and the grid it is looked for on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportOptions {
    /// A component whose nearest voxel is farther than this from every contour of its class on
    /// the frame's planes is unsupported (world units; default 5, mm for medical data).
    pub max_distance: f64,
    /// A component reaching farther than this outside the data's box is unsupported (world
    /// units; default 10).
    pub max_outside: f64,
    /// Voxels along the longest side of the model's domain (default 128).
    pub resolution: usize,
}

impl Default for SupportOptions {
    fn default() -> Self {
        SupportOptions {
            max_distance: 5.0,
            max_outside: 10.0,
            resolution: 128,
        }
    }
}

/// One unsupported component.
#[derive(Debug, Clone, PartialEq)]
pub struct Unsupported {
    /// Class index (0-based, model order).
    pub class: usize,
    /// Index of the sequence's frame.
    pub frame: usize,
    /// The frame's time.
    pub time: f64,
    /// Voxels of the component.
    pub voxels: usize,
    /// Its volume (world units³).
    pub volume: f64,
    /// Its voxels' mean world position.
    pub centroid: [f64; 3],
    /// Distance from its nearest voxel to the nearest contour of its class on the frame (∞
    /// where the frame has no contour of the class).
    pub distance: f64,
    /// How far its farthest voxel lies outside the data's box (0 inside).
    pub outside: f64,
}

/// Every component of every class of `model`, at each frame of `seq` (the input it was trained
/// on, class for class), that is farther than `options.max_distance` from every contour of its
/// class on that frame or leaves the data's box ([`Sequence::roi_bounding_box`]) by more than
/// `options.max_outside`; in frame, then class order. An error if the classes disagree or the
/// model is not finite on the grid.
pub fn unsupported_components(
    model: &Model,
    seq: &Sequence,
    options: &SupportOptions,
) -> Result<Vec<Unsupported>> {
    ensure!(
        model.num_classes() == seq.classes().len(),
        "the model has {} classes, the input {}",
        model.num_classes(),
        seq.classes().len()
    );
    ensure!(options.resolution >= 2, "resolution below 2 voxels");
    let (lo, hi) = model.domain().bounds();
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
    let spacing = side / options.resolution as f64;
    let data_box = seq.roi_bounding_box();
    let mut found = Vec::new();
    for (fi, frame) in seq.frames().iter().enumerate() {
        let grid = VoxelGrid::from_bounds(lo, hi, [spacing; 3], vec![frame.time])?;
        let mut labels = vec![0u32; grid.voxels_per_frame()];
        label_indices(model, &grid, frame.time, &mut labels)?;
        for class in 0..model.num_classes() {
            let contour = contour_points(seq, fi, class, 0.5 * spacing);
            let tree = (!contour.is_empty())
                .then(|| ImmutableKdTree::<f64, 3>::new_from_slice(&contour).ok())
                .flatten();
            for voxels in components(&labels, grid.dims, class as u32 + 1) {
                let world: Vec<[f64; 3]> = voxels
                    .iter()
                    .map(|&v| {
                        let (i, j, k) = unravel(v, grid.dims);
                        grid.world(i, j, k)
                    })
                    .collect();
                let distance = tree.as_ref().map_or(f64::INFINITY, |t| {
                    t.query_batch(&world)
                        .nearest_one::<SquaredEuclidean<f64>>()
                        .execute()
                        .iter()
                        .map(|n| n.distance)
                        .fold(f64::INFINITY, f64::min)
                        .sqrt()
                });
                let outside = world
                    .iter()
                    .map(|x| outside_box(&data_box, *x))
                    .fold(0.0, f64::max);
                if distance > options.max_distance || outside > options.max_outside {
                    let n = world.len() as f64;
                    found.push(Unsupported {
                        class,
                        frame: fi,
                        time: frame.time,
                        voxels: world.len(),
                        volume: n * grid.voxel_volume(),
                        centroid: std::array::from_fn(|a| {
                            world.iter().map(|x| x[a]).sum::<f64>() / n
                        }),
                        distance,
                        outside,
                    });
                }
            }
        }
    }
    Ok(found)
}

/// The contours of `class` on frame `frame`'s planes as world points at most `step` apart.
fn contour_points(seq: &Sequence, frame: usize, class: usize, step: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for plane in &seq.frames()[frame].planes {
        let Some(a) = plane.annotation(class) else {
            continue;
        };
        for poly in &a.polygons {
            for (i, p) in poly.iter().enumerate() {
                let q = poly[(i + 1) % poly.len()];
                let n = ((q[0] - p[0]).hypot(q[1] - p[1]) / step).ceil().max(1.0) as usize;
                for s in 0..n {
                    let f = s as f64 / n as f64;
                    out.push(plane.to_world([p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])]));
                }
            }
        }
    }
    out
}

/// Distance from `x` to the box (0 inside).
fn outside_box(b: &Aabb, x: [f64; 3]) -> f64 {
    (0..3)
        .map(|a| (b.min[a] - x[a]).max(x[a] - b.max[a]).max(0.0).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// (i, j, k) of voxel index `v`, x fastest.
fn unravel(v: usize, dims: [usize; 3]) -> (usize, usize, usize) {
    (v % dims[0], v / dims[0] % dims[1], v / (dims[0] * dims[1]))
}

/// The 26-connected components of the voxels labelled `label`, each a list of voxel indices.
fn components(labels: &[u32], dims: [usize; 3], label: u32) -> Vec<Vec<usize>> {
    let mut seen = vec![false; labels.len()];
    let mut out = Vec::new();
    for start in 0..labels.len() {
        if labels[start] != label || seen[start] {
            continue;
        }
        seen[start] = true;
        let mut component = vec![start];
        let mut next = 0;
        while next < component.len() {
            let (i, j, k) = unravel(component[next], dims);
            next += 1;
            for dk in -1i64..=1 {
                for dj in -1i64..=1 {
                    for di in -1i64..=1 {
                        let (a, b, c) = (i as i64 + di, j as i64 + dj, k as i64 + dk);
                        if a < 0 || b < 0 || c < 0 {
                            continue;
                        }
                        let (a, b, c) = (a as usize, b as usize, c as usize);
                        if a >= dims[0] || b >= dims[1] || c >= dims[2] {
                            continue;
                        }
                        let w = a + dims[0] * (b + dims[1] * c);
                        if labels[w] == label && !seen[w] {
                            seen[w] = true;
                            component.push(w);
                        }
                    }
                }
            }
        }
        out.push(component);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two blobs of label 1 touching only diagonally are one component; a third apart is
    /// another; label 2 is not counted.
    #[test]
    fn components_are_26_connected() {
        let dims = [5, 5, 5];
        let mut labels = vec![0u32; 125];
        let at = |i: usize, j: usize, k: usize| i + 5 * (j + 5 * k);
        labels[at(0, 0, 0)] = 1;
        labels[at(1, 1, 1)] = 1;
        labels[at(4, 4, 4)] = 1;
        labels[at(2, 2, 2)] = 2;
        let mut c = components(&labels, dims, 1);
        c.iter_mut().for_each(|v| v.sort());
        assert_eq!(c, vec![vec![at(0, 0, 0), at(1, 1, 1)], vec![at(4, 4, 4)]]);
        assert_eq!(unravel(at(1, 2, 3), dims), (1, 2, 3));
    }

    #[test]
    fn distance_outside_a_box() {
        let b = Aabb {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        assert_eq!(outside_box(&b, [0.5, 0.5, 0.5]), 0.0);
        assert_eq!(outside_box(&b, [0.5, 0.5, 3.0]), 2.0);
        assert!((outside_box(&b, [2.0, 2.0, 0.5]) - 2f64.sqrt()).abs() < 1e-12);
    }
}
