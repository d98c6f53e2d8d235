//! Repair of contours that cross or touch themselves or each other, by the even-odd rule.
//!
//! Hand-drawn contours loop over themselves, touch themselves at a point and cross their
//! neighbours. Read with the even-odd rule (a point is inside when a ray from it crosses the
//! contours an odd number of times) such a set of rings still bounds one well-defined region, the
//! one a scanline rasteriser fills, and it is the rule `Sequence::new` (dynaslice-sequence)
//! already applies to nested rings (nesting parity decides outer boundaries and holes). So the
//! repair replaces the rings by simple rings bounding the same even-odd region.
//!
//! The boolean work is done by `i_overlay` (the polygon engine behind `geo`'s boolean ops) with
//! the even-odd fill rule and its 64-bit integer engine: a power-of-two scale onto an `i64` grid
//! keeps input vertices exact to well below f64 rounding of the contours' extent, and collinear
//! input points are kept, so repaired rings keep the drawn vertices and gain only the points where
//! contours cross. A hand-written split at self-intersections would need its own robust handling
//! of collinear overlaps, T-junctions and crossings between rings; the crate has it.
//!
//! Only what `Sequence::new` (dynaslice-sequence) would refuse is repaired: rings that merely
//! share a vertex without crossing there (a pinch) are left to the validator, which separates them
//! itself (see `separate_pinches` in `sequence.rs`).

use std::collections::{HashMap, HashSet};
use std::ops::ControlFlow;

use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::solver::Solver;
use i_overlay::float::overlay::OverlayOptions;
use i_overlay::float::simplify::SimplifyShape;

use crate::bucket_grid::for_each_near_pair;
use crate::polygon::{ring_edges, segments_intersect, signed_area, Polygon};
use crate::Point2;

/// Where the rings of one annotation cross or touch in a way only an even-odd repair resolves.
#[derive(Debug, Clone, PartialEq)]
pub struct Contacts {
    /// Indices of the polygons involved, increasing.
    pub polygons: Vec<usize>,
    /// Whether two different polygons are involved in one contact (not only self-contacts).
    pub between_polygons: bool,
    /// A point at (or on an edge at) the first contact found, for messages.
    pub near: Point2,
}

/// The rings as the validator will see them: a closing vertex equal to the first is dropped.
/// `None` when a ring is malformed in a way the validator reports itself (fewer than 3 vertices,
/// a non-finite coordinate, a zero-length edge): those are refused, never repaired.
fn well_formed(polys: &[Polygon]) -> Option<Vec<&[Point2]>> {
    polys
        .iter()
        .map(|p| {
            let p: &[Point2] = if p.len() > 3 && p.first() == p.last() {
                &p[..p.len() - 1]
            } else {
                p
            };
            let n = p.len();
            let ok = n >= 3
                && p.iter().flatten().all(|x| x.is_finite())
                && (0..n).all(|i| p[i] != p[(i + 1) % n]);
            ok.then_some(p)
        })
        .collect()
}

fn sub(a: Point2, b: Point2) -> Point2 {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross2(u: Point2, w: Point2) -> f64 {
    u[0] * w[1] - u[1] * w[0]
}

fn dot2(u: Point2, w: Point2) -> f64 {
    u[0] * w[0] + u[1] * w[1]
}

/// Whether the directions `u` and `w` from a common point overlap (same ray).
fn same_ray(u: Point2, w: Point2) -> bool {
    cross2(u, w) == 0.0 && dot2(u, w) > 0.0
}

/// Contacts between the rings of `polys` (one class on one plane) that the validator would
/// refuse: edges that cross, a vertex lying on another edge, overlapping collinear edges, a ring
/// folding back on itself, and rings passing through a shared vertex so that they cross there.
/// `None` when there are none, or when a ring is malformed (left to the validator's errors).
///
/// O(n log n) for real contours (see [`for_each_near_pair`]).
pub fn find_contacts(polys: &[Polygon]) -> Option<Contacts> {
    let rings = well_formed(polys)?;
    let edges = ring_edges(&rings);
    if edges.is_empty() {
        return None;
    }
    let segments: Vec<(Point2, Point2)> = edges.iter().map(|e| (e.2, e.3)).collect();
    let mut involved: HashSet<usize> = HashSet::new();
    let mut between = false;
    let mut near = None;
    // Shared vertices: decided below, once every ring passing through them is known.
    let mut pinches: HashSet<[u64; 2]> = HashSet::new();
    let mut hit = |pa: usize, pb: usize, p: Point2| {
        involved.insert(pa);
        involved.insert(pb);
        between |= pa != pb;
        near.get_or_insert(p);
    };
    for_each_near_pair(&segments, |ei, ej| {
        let (pa, ia, a, b) = edges[ei];
        let (pb, ib, c, d) = edges[ej];
        let n = rings[pa].len();
        if pa == pb && ib == (ia + 1) % n {
            if same_ray(sub(a, b), sub(d, c)) {
                hit(pa, pb, b);
            }
            return ControlFlow::Continue(());
        }
        if pa == pb && ia == (ib + 1) % n {
            if same_ray(sub(b, a), sub(c, d)) {
                hit(pa, pb, a);
            }
            return ControlFlow::Continue(());
        }
        if !segments_intersect(a, b, c, d) {
            return ControlFlow::Continue(());
        }
        // A contact only at one common endpoint is a pinch, unless the two edges also
        // overlap along a common ray from it.
        let shared = [(a, b), (b, a)]
            .into_iter()
            .flat_map(|(s, p)| [(s, p, c, d), (s, p, d, c)])
            .find(|&(s, _, t, _)| s == t);
        match shared {
            Some((s, p, _, q)) if !same_ray(sub(p, s), sub(q, s)) => {
                pinches.insert(s.map(f64::to_bits));
            }
            _ => hit(pa, pb, [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5]),
        }
        ControlFlow::Continue(())
    });
    if !pinches.is_empty() {
        for (s, (pa, pb)) in crossing_pinches(&rings, &pinches) {
            hit(pa, pb, s);
        }
    }
    let near = near?;
    let mut polygons: Vec<usize> = involved.into_iter().collect();
    polygons.sort_unstable();
    Some(Contacts {
        polygons,
        between_polygons: between,
        near,
    })
}

/// Shared vertices where the rings passing through cross rather than touch: around the vertex,
/// the two edge ends of each pass must not interleave with another pass's (balanced like
/// parentheses in angular order). Returns the vertex and two of the passes' polygons.
fn crossing_pinches(
    rings: &[&[Point2]],
    pinches: &HashSet<[u64; 2]>,
) -> Vec<(Point2, (usize, usize))> {
    let mut passes: HashMap<[u64; 2], Vec<(usize, Point2, Point2)>> = HashMap::new();
    for (pi, r) in rings.iter().enumerate() {
        let n = r.len();
        for (vi, &s) in r.iter().enumerate() {
            let key = s.map(f64::to_bits);
            if pinches.contains(&key) {
                let (prev, next) = (r[(vi + n - 1) % n], r[(vi + 1) % n]);
                passes
                    .entry(key)
                    .or_default()
                    .push((pi, sub(prev, s), sub(next, s)));
            }
        }
    }
    let mut out = Vec::new();
    for (key, ps) in passes {
        let s = key.map(f64::from_bits);
        let mut ends: Vec<(f64, usize)> = ps
            .iter()
            .enumerate()
            .flat_map(|(k, &(_, u, w))| [(u[1].atan2(u[0]), k), (w[1].atan2(w[0]), k)])
            .collect();
        ends.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut stack: Vec<usize> = Vec::new();
        for &(_, k) in &ends {
            if stack.last() == Some(&k) {
                stack.pop();
            } else {
                stack.push(k);
            }
        }
        // A cyclic order is balanced iff some rotation of it is; a linear scan that leaves
        // a stack which itself cancels in pairs cyclically (e.g. "a b ... b a" split at the
        // angle origin) is still balanced, so reduce the leftover cyclically.
        let balanced = reduce_cyclic(stack).is_empty();
        if !balanced {
            out.push((s, (ps[0].0, ps[ps.len() - 1].0)));
        }
    }
    out
}

/// Cancels equal neighbours of a cyclic sequence until none are left.
fn reduce_cyclic(mut seq: Vec<usize>) -> Vec<usize> {
    loop {
        let n = seq.len();
        if n < 2 {
            return seq;
        }
        match (0..n).find(|&i| seq[i] == seq[(i + 1) % n]) {
            Some(i) if i + 1 < n => {
                seq.drain(i..i + 2);
            }
            Some(_) => {
                seq.pop();
                seq.remove(0);
            }
            None => return seq,
        }
    }
}

/// Simple rings bounding the even-odd region of `polys`: where rings cross they are split at the
/// crossing points, overlapping collinear stretches cancel, and what remains is a set of rings
/// that do not cross (they may still share a vertex, which the validator separates). Vertices of
/// the input are kept (collinear ones too); ring orientation and order are the engine's (the
/// validator reorients by nesting). Rings of zero area are dropped. `None` when a coordinate is
/// not finite or beyond ±2^500, the engine's float range (no cross-section comes near it).
pub fn even_odd_rings(polys: &[Polygon]) -> Option<Vec<Polygon>> {
    let limit = 2f64.powi(500);
    if !polys.iter().flatten().flatten().all(|x| x.abs() <= limit) {
        return None;
    }
    let mut options = OverlayOptions::<f64, i64>::default();
    options.preserve_input_collinear = true;
    options.preserve_output_collinear = true;
    let rings = polys
        .simplify_shape_custom_as::<i64>(FillRule::EvenOdd, options, Solver::default())
        .into_iter()
        .flatten()
        .filter(|r| r.len() >= 3 && signed_area(r) != 0.0)
        .collect();
    Some(rings)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(polys: &[Polygon]) -> f64 {
        // Even-odd area of non-crossing rings: outer minus holes, by nesting parity.
        let mut v = polys.to_vec();
        crate::polygon::orient_by_nesting(&mut v);
        v.iter().map(|p| signed_area(p)).sum()
    }

    #[test]
    fn bowtie_becomes_two_triangles() {
        let bowtie = vec![[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        let c = find_contacts(std::slice::from_ref(&bowtie)).expect("it crosses itself");
        assert_eq!(c.polygons, [0]);
        assert!(!c.between_polygons);
        let rings = even_odd_rings(&[bowtie]).unwrap();
        assert_eq!(rings.len(), 2);
        assert!((area(&rings) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn pinches_are_left_to_the_validator_but_crossings_through_a_vertex_are_not() {
        // Two squares sharing a corner: a pinch.
        let a = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let b = vec![[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]];
        assert!(find_contacts(&[a.clone(), b.clone()]).is_none());
        // One ring through the shared corner twice, touching: also a pinch.
        let touching = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [2.0, 1.0],
            [2.0, 2.0],
            [1.0, 2.0],
            [1.0, 1.0],
            [0.0, 1.0],
        ];
        assert!(find_contacts(&[touching]).is_none());
        // A figure 8 whose two passes through the shared vertex cross there.
        let eight = vec![
            [0.0, 0.0],
            [1.0, 1.0],
            [2.0, 2.0],
            [0.0, 2.0],
            [1.0, 1.0],
            [2.0, 0.0],
        ];
        let c = find_contacts(std::slice::from_ref(&eight)).expect("crossing at a vertex");
        assert_eq!(c.near, [1.0, 1.0]);
        let rings = even_odd_rings(&[eight]).unwrap();
        assert_eq!(rings.len(), 2);
        assert!((area(&rings) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn t_junctions_overlaps_and_fold_backs_are_found() {
        let sq = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        // A triangle whose apex lies on the square's bottom edge (from outside).
        let t = vec![[1.0, 0.0], [1.5, -1.0], [0.5, -1.0]];
        let c = find_contacts(&[sq.clone(), t]).expect("T-junction");
        assert!(c.between_polygons && c.polygons == [0, 1]);
        let spike = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(find_contacts(&[spike]).is_some());
        // Disjoint rings: nothing.
        let far = vec![[5.0, 5.0], [6.0, 5.0], [6.0, 6.0]];
        assert!(find_contacts(&[sq, far]).is_none());
        // Malformed rings are the validator's business.
        assert!(find_contacts(&[vec![[0.0, 0.0], [1.0, 0.0]]]).is_none());
    }

    #[test]
    fn extreme_coordinates_do_not_panic() {
        // (Below ~1e-154 the shoelace area underflows to 0 and such rings count as degenerate.)
        for s in [1e150, 1e-150, 1e15] {
            let bowtie = vec![
                [0.0, 0.0],
                [2.0 * s, 2.0 * s],
                [2.0 * s, 0.0],
                [0.0, 2.0 * s],
            ];
            assert!(find_contacts(std::slice::from_ref(&bowtie)).is_some());
            let rings = even_odd_rings(&[bowtie]).expect("within the engine's range");
            assert_eq!(rings.len(), 2, "{s}");
            assert!(rings.iter().flatten().flatten().all(|x| x.is_finite()));
        }
        let mixed = vec![
            [-1e308, -1e308],
            [1e308, 1e308],
            [1e308, -1e308],
            [-1e308, 1e308],
        ];
        // Cross products overflow here, so whether a contact is seen is unspecified; no panic.
        let _ = find_contacts(std::slice::from_ref(&mixed));
        assert_eq!(even_odd_rings(&[mixed]), None);
    }

    #[test]
    fn overlapping_squares_read_even_odd() {
        let a = vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        let b = vec![[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]];
        assert!(find_contacts(&[a.clone(), b.clone()]).is_some());
        let rings = even_odd_rings(&[a, b]).unwrap();
        // 4 + 4 - 2 × overlap 1.
        assert!((area(&rings) - 6.0).abs() < 1e-12, "{rings:?}");
    }
}
