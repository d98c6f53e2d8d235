//! Closed polygons in plane coordinates: area, containment, intersection tests and the
//! orientation convention every other module relies on.
//!
//! Convention: after [`orient_by_nesting`], every polygon has the region of its class on its
//! left. Outer boundaries run counter-clockwise in (u, v) plane coordinates (i.e. about the plane
//! normal u×v), holes clockwise — the `.csl` convention. The outward normal of an edge with
//! direction (dx, dy) is then (dy, −dx)/len, and the sign of the distance near a vertex follows
//! from the two adjacent edge normals (see [`crate::sdf`]).

use std::ops::ControlFlow;

use crate::bucket_grid::for_each_near_pair;
use crate::Point2;

/// A closed polygon: vertices in order, the last joined to the first (no repeated closing vertex).
pub type Polygon = Vec<Point2>;

/// The signed area (shoelace formula), positive for counter-clockwise polygons.
pub fn signed_area(poly: &[Point2]) -> f64 {
    let n = poly.len();
    let mut a = 0.0;
    for i in 0..n {
        let p = poly[i];
        let q = poly[(i + 1) % n];
        a += p[0] * q[1] - q[0] * p[1];
    }
    0.5 * a
}

/// Whether `p` is inside `poly` by the crossing rule (points exactly on an edge may go either way).
pub fn contains(poly: &[Point2], p: Point2) -> bool {
    let n = poly.len();
    let mut inside = false;
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let a = poly[i];
        let b = poly[j];
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Whether `p` is inside the region bounded by `polys` under the even-odd rule, which is what the
/// region of a set of non-crossing polygons (outer boundaries and holes, any nesting) means.
pub fn contains_even_odd(polys: &[Polygon], p: Point2) -> bool {
    polys.iter().filter(|poly| contains(poly, p)).count() % 2 == 1
}

fn cross(o: Point2, a: Point2, b: Point2) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

fn on_segment(a: Point2, b: Point2, p: Point2) -> bool {
    p[0] >= a[0].min(b[0])
        && p[0] <= a[0].max(b[0])
        && p[1] >= a[1].min(b[1])
        && p[1] <= a[1].max(b[1])
}

/// Whether closed segments `ab` and `cd` share at least one point.
pub fn segments_intersect(a: Point2, b: Point2, c: Point2, d: Point2) -> bool {
    let d1 = cross(c, d, a);
    let d2 = cross(c, d, b);
    let d3 = cross(a, b, c);
    let d4 = cross(a, b, d);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on_segment(c, d, a))
        || (d2 == 0.0 && on_segment(c, d, b))
        || (d3 == 0.0 && on_segment(a, b, c))
        || (d4 == 0.0 && on_segment(a, b, d))
}

/// Two edges that cross or touch, found by [`find_crossing`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Polygon and edge index of the first edge (edge i joins vertex i to vertex i+1).
    pub first: (usize, usize),
    /// Polygon and edge index of the second edge.
    pub second: (usize, usize),
    /// A point near the contact (midpoint of the first edge), for messages.
    pub near: Point2,
}

/// Every edge of `rings` as (ring, edge index, start, end), the closing edge included.
pub fn ring_edges<R: AsRef<[Point2]>>(rings: &[R]) -> Vec<(usize, usize, Point2, Point2)> {
    rings
        .iter()
        .enumerate()
        .flat_map(|(pi, ring)| {
            let poly = ring.as_ref();
            let n = poly.len();
            (0..n).map(move |i| (pi, i, poly[i], poly[(i + 1) % n]))
        })
        .collect()
}

/// Finds two edges of `polys` that cross or touch, other than consecutive edges of one polygon
/// meeting at their shared vertex. Consecutive edges that fold back onto each other (a spike) are
/// reported too. O(n log n) for real contours (see [`for_each_near_pair`]).
pub fn find_crossing(polys: &[Polygon]) -> Option<Crossing> {
    let edges = ring_edges(polys);
    let segments: Vec<(Point2, Point2)> = edges.iter().map(|e| (e.2, e.3)).collect();
    let mut found = None;
    for_each_near_pair(&segments, |ei, ej| {
        let (pa, ia, a, b) = edges[ei];
        let (pb, ib, c, d) = edges[ej];
        let n = polys[pa].len();
        let adjacent = pa == pb && (ib == (ia + 1) % n || ia == (ib + 1) % n);
        let hit = if adjacent {
            folds_back(a, b, c, d)
        } else {
            segments_intersect(a, b, c, d)
        };
        if !hit {
            return ControlFlow::Continue(());
        }
        found = Some(Crossing {
            first: (pa, ia),
            second: (pb, ib),
            near: [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5],
        });
        ControlFlow::Break(())
    });
    found
}

/// For consecutive edges (sharing one endpoint): whether they are collinear and overlap beyond
/// the shared vertex, i.e. the polygon doubles back on itself.
fn folds_back(a: Point2, b: Point2, c: Point2, d: Point2) -> bool {
    // Identify the shared vertex s and the two far ends p (of ab) and q (of cd).
    let (s, p, q) = if b == c {
        (b, a, d)
    } else if a == d {
        (a, b, c)
    } else if a == c {
        (a, b, d)
    } else {
        (b, a, c)
    };
    let u = [p[0] - s[0], p[1] - s[1]];
    let w = [q[0] - s[0], q[1] - s[1]];
    u[0] * w[1] - u[1] * w[0] == 0.0 && u[0] * w[0] + u[1] * w[1] > 0.0
}

/// Reorients `polys` (which must not cross) so the region lies on the left of every edge: a polygon
/// inside an even number of others is an outer boundary and runs counter-clockwise, one inside an
/// odd number is a hole and runs clockwise. Input orientation is not trusted, because formats and
/// tools disagree on it; nesting is what defines the region (even-odd rule).
pub fn orient_by_nesting(polys: &mut [Polygon]) {
    let depths: Vec<usize> = (0..polys.len())
        .map(|i| {
            let probe = polys[i][0];
            (0..polys.len())
                .filter(|&j| j != i && contains(&polys[j], probe))
                .count()
        })
        .collect();
    for (poly, depth) in polys.iter_mut().zip(depths) {
        let ccw = signed_area(poly) > 0.0;
        if ccw == (depth % 2 == 1) {
            poly.reverse();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, s: f64) -> Polygon {
        vec![[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s]]
    }

    #[test]
    fn area_sign_follows_orientation() {
        let mut sq = square(0.0, 0.0, 2.0);
        assert_eq!(signed_area(&sq), 4.0);
        sq.reverse();
        assert_eq!(signed_area(&sq), -4.0);
    }

    #[test]
    fn nesting_orients_outer_ccw_and_holes_cw() {
        let mut polys = vec![
            square(1.0, 1.0, 1.0),
            square(0.0, 0.0, 4.0),
            square(5.0, 5.0, 1.0),
        ];
        polys[1].reverse();
        polys[2].reverse();
        orient_by_nesting(&mut polys);
        assert!(signed_area(&polys[0]) < 0.0, "hole must be clockwise");
        assert!(signed_area(&polys[1]) > 0.0);
        assert!(signed_area(&polys[2]) > 0.0);
        assert!(contains_even_odd(&polys, [0.5, 0.5]));
        assert!(!contains_even_odd(&polys, [1.5, 1.5]));
    }

    #[test]
    fn crossings_are_found() {
        let bowtie = vec![[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        let c = find_crossing(&[bowtie]).expect("bow-tie crosses itself");
        assert_eq!((c.first.0, c.second.0), (0, 0));
        assert!(find_crossing(&[square(0.0, 0.0, 1.0), square(2.0, 0.0, 1.0)]).is_none());
        assert!(find_crossing(&[square(0.0, 0.0, 1.0), square(0.5, 0.5, 1.0)]).is_some());
        // Touching at a vertex counts: the region would be ambiguous there.
        assert!(find_crossing(&[square(0.0, 0.0, 1.0), square(1.0, 1.0, 1.0)]).is_some());
        let spike = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(find_crossing(&[spike]).is_some());
    }
}
