//! Closed contours of `{f < 0}` from a scalar field sampled on a regular grid, with sub-sample
//! placement by linear interpolation along grid edges.
//!
//! Used twice: on the interpolated class indicator of a resliced label volume (NIfTI reader, where
//! `f = 0.5 − indicator`) and on an analytic SDF sampled over a plane (synthetic benchmark).
//!
//! Properties the rest of the crate relies on:
//! - The grid is treated as surrounded by outside samples, so every contour closes.
//! - Contours never cross or touch: each cell emits at most two segments, saddles are resolved by
//!   the cell-centre average, and a crossing is never placed exactly on a grid node.
//! - Each contour has the inside on its left (outer boundaries counter-clockwise, holes
//!   clockwise), matching [`crate::polygon::orient_by_nesting`].

use crate::polygon::Polygon;

/// Keeps crossings off grid nodes: a node where `f == 0` exactly would otherwise be shared by up
/// to four crossings, making zero-length edges or contours touching at a point.
const NODE_CLEARANCE: f64 = 1e-6;

/// Extracts the closed contours of `{f < 0}`. `values` holds `nx × ny` samples in row-major
/// order (`values[j * nx + i]` at grid point (i, j)); the result is in grid units (sample (i, j)
/// at (i, j)). A NaN sample counts as outside.
pub fn contours(values: &[f64], nx: usize, ny: usize) -> Vec<Polygon> {
    debug_assert_eq!(values.len(), nx * ny);
    // Pad with one outside sample on every side so all contours close.
    let (px, py) = (nx + 2, ny + 2);
    let at = |i: usize, j: usize| -> f64 {
        if i == 0 || j == 0 || i > nx || j > ny {
            1.0
        } else {
            let v = values[(j - 1) * nx + (i - 1)];
            if v.is_nan() {
                1.0
            } else {
                v
            }
        }
    };
    // Edge ids: horizontal edge (i,j)-(i+1,j) is j*(px-1)+i; vertical (i,j)-(i,j+1) is H+j*px+i.
    let h_edges = (px - 1) * py;
    let edge_count = h_edges + px * (py - 1);
    let mut next = vec![u32::MAX; edge_count];
    let mut point = vec![[0.0f64; 2]; edge_count];
    let crossing = |a: f64, b: f64| (a / (a - b)).clamp(NODE_CLEARANCE, 1.0 - NODE_CLEARANCE);
    for j in 0..py - 1 {
        for i in 0..px - 1 {
            // Corners counter-clockwise, and the edges between them in the same order.
            let corner = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let f = corner.map(|(ci, cj)| at(ci, cj));
            let inside = f.map(|v| v < 0.0);
            if inside.iter().all(|&x| x) || inside.iter().all(|&x| !x) {
                continue;
            }
            let edge_id = [
                j * (px - 1) + i,
                h_edges + j * px + i + 1,
                (j + 1) * (px - 1) + i,
                h_edges + j * px + i,
            ];
            // Walking the cell boundary counter-clockwise, an "exit" goes inside → outside and an
            // "entry" outside → inside. The contour runs from an exit to an entry with the inside
            // on its left.
            let mut exits = [0usize; 2];
            let mut entries = [0usize; 2];
            let (mut ne, mut nn) = (0, 0);
            for k in 0..4 {
                let (a, b) = (k, (k + 1) % 4);
                if inside[a] == inside[b] {
                    continue;
                }
                let t = crossing(f[a], f[b]);
                let (pa, pb) = (corner[a], corner[b]);
                point[edge_id[k]] = [
                    pa.0 as f64 + t * (pb.0 as f64 - pa.0 as f64) - 1.0,
                    pa.1 as f64 + t * (pb.1 as f64 - pa.1 as f64) - 1.0,
                ];
                if inside[a] {
                    exits[ne] = k;
                    ne += 1;
                } else {
                    entries[nn] = k;
                    nn += 1;
                }
            }
            if ne == 1 {
                next[edge_id[exits[0]]] = edge_id[entries[0]] as u32;
                continue;
            }
            // Saddle: the inside corners are joined through the cell when the centre is inside,
            // in which case each exit connects to the entry that follows it counter-clockwise;
            // otherwise to the entry that precedes it.
            let centre_inside = f.iter().sum::<f64>() < 0.0;
            for &x in &exits {
                let follows = |e: usize| (e + 4 - x) % 4;
                let pick = if centre_inside {
                    *entries
                        .iter()
                        .min_by_key(|&&e| follows(e))
                        .unwrap_or(&entries[0])
                } else {
                    *entries
                        .iter()
                        .max_by_key(|&&e| follows(e))
                        .unwrap_or(&entries[0])
                };
                next[edge_id[x]] = edge_id[pick] as u32;
            }
        }
    }
    let mut seen = vec![false; edge_count];
    let mut loops = Vec::new();
    for start in 0..edge_count {
        if next[start] == u32::MAX || seen[start] {
            continue;
        }
        let mut poly = Vec::new();
        let mut e = start;
        while !seen[e] {
            seen[e] = true;
            poly.push(point[e]);
            e = next[e] as usize;
        }
        loops.push(poly);
    }
    loops
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polygon::{find_crossing, signed_area};

    fn field(nx: usize, ny: usize, f: impl Fn(f64, f64) -> f64) -> Vec<f64> {
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (i, j)))
            .map(|(i, j)| f(i as f64, j as f64))
            .collect()
    }

    #[test]
    fn disc_gives_one_ccw_loop_at_sub_sample_accuracy() {
        let v = field(40, 40, |x, y| ((x - 20.0).hypot(y - 19.5)) - 10.3);
        let loops = contours(&v, 40, 40);
        assert_eq!(loops.len(), 1);
        assert!(signed_area(&loops[0]) > 0.0);
        for p in &loops[0] {
            assert!(((p[0] - 20.0).hypot(p[1] - 19.5) - 10.3).abs() < 0.02);
        }
    }

    #[test]
    fn annulus_and_island_holes_clockwise() {
        let v = field(60, 40, |x, y| {
            let r = (x - 20.0).hypot(y - 20.0);
            let ring = (r - 12.0).max(6.0 - r);
            let island = (x - 50.0).hypot(y - 20.0) - 5.0;
            ring.min(island)
        });
        let loops = contours(&v, 60, 40);
        assert_eq!(loops.len(), 3);
        let negative = loops.iter().filter(|l| signed_area(l) < 0.0).count();
        assert_eq!(negative, 1, "exactly one hole");
        assert!(find_crossing(&loops).is_none());
    }

    #[test]
    fn saddles_and_exact_zeros_never_touch() {
        // Checkerboard of ±1 with zeros on nodes: the hardest case for touching contours.
        let v = field(9, 9, |x, y| {
            let s = ((x as i64 + y as i64) % 2) as f64;
            if (x as i64) % 3 == 0 {
                0.0
            } else {
                1.0 - 2.0 * s
            }
        });
        let loops = contours(&v, 9, 9);
        assert!(!loops.is_empty());
        assert!(find_crossing(&loops).is_none());
        for l in &loops {
            assert!(l.len() >= 4);
        }
    }

    #[test]
    fn contour_touching_the_border_is_closed() {
        let v = field(5, 5, |_, _| -1.0);
        let loops = contours(&v, 5, 5);
        assert_eq!(loops.len(), 1);
        // Crossings halfway to the padding: a 5×5 square with its four corners cut by 1/8 each.
        assert!((signed_area(&loops[0]) - 24.5).abs() < 1e-9);
    }
}
