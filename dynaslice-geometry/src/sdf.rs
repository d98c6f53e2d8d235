//! Exact signed distance to a class's polygon set on one plane, and its outward normals.
//!
//! [`PolygonSdf`] answers "how far is this plane point from the class's contours, and is it inside"
//! exactly (up to floating point), negative inside, holes respected. It is the in-plane 2D SDF
//! **f**ᵢ of the paper's data term (Eq. 7) and provides the in-plane normals **n**ᵢ of the
//! orientation term (Eq. 6) for contour samples.
//!
//! Speed: the trainer resamples every step, so queries must cost well under a microsecond. At
//! construction every grid cell gets the list of segments that can be nearest to *some* point of
//! the cell (those within `d(centre) + half-diagonal` of the cell, a bound that holds for every
//! point in it), sorted by their distance to the cell; a query walks its cell's list and stops at
//! the first segment that cannot beat the best distance so far. Points outside the grid (the
//! plane's region of interest grown to cover the contours) fall back to a scan of all segments.
//!
//! Sign: the polygons must be oriented by [`crate::polygon::orient_by_nesting`] (region on the
//! left). The sign then comes from the nearest feature: the side of the nearest edge, or, when the
//! nearest point is a vertex, the side of the sum of the two adjacent edge normals (the 2D
//! angle-weighted pseudo-normal, Bærentzen & Aanæs 2005), which is exact for closest points.

use crate::bucket_grid::BucketGrid;
use crate::polygon::Polygon;
use crate::Point2;

#[derive(Debug, Clone, Copy)]
struct Seg {
    a: Point2,
    d: Point2,
    inv_len2: f64,
    /// Outward unit normal (the region is on the left of `d`).
    normal: Point2,
    prev: u32,
    next: u32,
}

impl Seg {
    /// Squared distance from `p` and the clamped projection parameter.
    #[inline]
    fn dist2(&self, p: Point2) -> (f64, f64) {
        let w = [p[0] - self.a[0], p[1] - self.a[1]];
        let t = ((w[0] * self.d[0] + w[1] * self.d[1]) * self.inv_len2).clamp(0.0, 1.0);
        let e = [w[0] - t * self.d[0], w[1] - t * self.d[1]];
        (e[0] * e[0] + e[1] * e[1], t)
    }

    fn b(&self) -> Point2 {
        [self.a[0] + self.d[0], self.a[1] + self.d[1]]
    }
}

/// Exact 2D signed distance and contour normals for one class on one plane. See the
/// [module docs](self).
#[derive(Debug, Clone)]
pub struct PolygonSdf {
    segs: Vec<Seg>,
    grid: BucketGrid,
    /// `cand_start[c]..cand_start[c + 1]` indexes `cands` for grid cell `c`.
    cand_start: Vec<u32>,
    /// (lower bound on the distance from the cell to the segment, segment index), ascending.
    cands: Vec<(f64, u32)>,
    /// Arc length at the end of each segment, for sampling by arc length.
    cum_len: Vec<f64>,
}

impl PolygonSdf {
    /// Builds the distance structure for `polys`, which must be validated (closed, ≥ 3 distinct
    /// vertices, no crossings) and oriented by [`crate::polygon::orient_by_nesting`]. The grid
    /// covers `region` (e.g. the plane's region of interest) and the contours. `None` when
    /// `polys` is empty (the class is absent on the plane: there is no distance to give).
    pub fn new(polys: &[Polygon], region: Option<(Point2, Point2)>) -> Option<Self> {
        let mut segs = Vec::new();
        for poly in polys {
            let n = poly.len();
            let base = segs.len() as u32;
            for i in 0..n {
                let a = poly[i];
                let b = poly[(i + 1) % n];
                let d = [b[0] - a[0], b[1] - a[1]];
                let len2 = d[0] * d[0] + d[1] * d[1];
                let len = len2.sqrt();
                segs.push(Seg {
                    a,
                    d,
                    inv_len2: if len2 > 0.0 { 1.0 / len2 } else { 0.0 },
                    normal: if len > 0.0 {
                        [d[1] / len, -d[0] / len]
                    } else {
                        [0.0, 0.0]
                    },
                    prev: base + ((i + n - 1) % n) as u32,
                    next: base + ((i + 1) % n) as u32,
                });
            }
        }
        let grid = BucketGrid::new(segs.iter().map(|s| (s.a, s.b())), region)?;
        let mut cum_len = Vec::with_capacity(segs.len());
        let mut acc = 0.0;
        for s in &segs {
            acc += (s.d[0] * s.d[0] + s.d[1] * s.d[1]).sqrt();
            cum_len.push(acc);
        }
        let mut sdf = PolygonSdf {
            segs,
            grid,
            cand_start: Vec::new(),
            cands: Vec::new(),
            cum_len,
        };
        sdf.build_candidates();
        Some(sdf)
    }

    fn build_candidates(&mut self) {
        let (nx, ny) = self.grid.dims();
        let h = self.grid.cell_size();
        let mut stamp = vec![u32::MAX; self.segs.len()];
        let mut list: Vec<(f64, u32)> = Vec::new();
        self.cand_start.reserve(nx * ny + 1);
        for j in 0..ny {
            for i in 0..nx {
                let cell_id = (j * nx + i) as u32;
                let (lo, hi) = self.grid.cell_rect(i, j);
                let centre = [(lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5];
                // Nearest distance from the centre, by rings of cells: after ring r every
                // unvisited cell is at least (r + 0.5)·h from the centre.
                let mut best = f64::INFINITY;
                let max_ring = nx.max(ny);
                for r in 0..=max_ring {
                    self.for_ring(i, j, r, |s| {
                        best = best.min(self.segs[s as usize].dist2(centre).0);
                    });
                    if best.sqrt() <= (r as f64 + 0.5) * h {
                        break;
                    }
                }
                // Every point of the cell is within `bound` of the centre's nearest segment, so
                // only segments within `bound` of the cell can be nearest to a point in it. Cells
                // in ring r are at least (r − 1)·h from this cell.
                let bound = best.sqrt() + h * std::f64::consts::FRAC_1_SQRT_2;
                let rings = ((bound / h).floor() as usize + 1).min(max_ring);
                list.clear();
                for r in 0..=rings {
                    self.for_ring(i, j, r, |s| {
                        if stamp[s as usize] != cell_id {
                            stamp[s as usize] = cell_id;
                            let seg = &self.segs[s as usize];
                            let lb = rect_segment_distance(lo, hi, seg.a, seg.b());
                            if lb <= bound {
                                list.push((lb, s));
                            }
                        }
                    });
                }
                list.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                self.cand_start.push(self.cands.len() as u32);
                self.cands.extend_from_slice(&list);
            }
        }
        self.cand_start.push(self.cands.len() as u32);
    }

    /// Calls `f` for every bucketed segment of the cells at Chebyshev distance `r` from (i, j).
    fn for_ring(&self, i: usize, j: usize, r: usize, mut f: impl FnMut(u32)) {
        let (nx, ny) = self.grid.dims();
        let (i, j, r) = (i as isize, j as isize, r as isize);
        let mut visit = |ci: isize, cj: isize| {
            if ci >= 0 && cj >= 0 && (ci as usize) < nx && (cj as usize) < ny {
                for &s in self.grid.bucket(cj as usize * nx + ci as usize) {
                    f(s);
                }
            }
        };
        if r == 0 {
            visit(i, j);
            return;
        }
        for ci in i - r..=i + r {
            visit(ci, j - r);
            visit(ci, j + r);
        }
        for cj in j - r + 1..=j + r - 1 {
            visit(i - r, cj);
            visit(i + r, cj);
        }
    }

    /// Signed distance from plane point `p`: negative inside the class's region.
    #[inline]
    pub fn distance(&self, p: Point2) -> f64 {
        let (d2, seg, t) = self.nearest(p);
        let s = &self.segs[seg];
        let side = if t <= 0.0 {
            let n = add(s.normal, self.segs[s.prev as usize].normal);
            (p[0] - s.a[0]) * n[0] + (p[1] - s.a[1]) * n[1]
        } else if t >= 1.0 {
            let b = s.b();
            let n = add(s.normal, self.segs[s.next as usize].normal);
            (p[0] - b[0]) * n[0] + (p[1] - b[1]) * n[1]
        } else {
            (p[0] - s.a[0]) * s.normal[0] + (p[1] - s.a[1]) * s.normal[1]
        };
        let d = d2.sqrt();
        if side < 0.0 {
            -d
        } else {
            d
        }
    }

    /// (squared distance, segment, projection parameter) of the nearest contour point.
    #[inline]
    fn nearest(&self, p: Point2) -> (f64, usize, f64) {
        let mut best = (f64::INFINITY, 0usize, 0.0);
        match self.grid.cell_of(p) {
            Some((i, j)) => {
                let c = j * self.grid.dims().0 + i;
                let range = self.cand_start[c] as usize..self.cand_start[c + 1] as usize;
                for &(lb, s) in &self.cands[range] {
                    if lb * lb > best.0 {
                        break;
                    }
                    let (d2, t) = self.segs[s as usize].dist2(p);
                    if d2 < best.0 {
                        best = (d2, s as usize, t);
                    }
                }
            }
            None => {
                for (k, s) in self.segs.iter().enumerate() {
                    let (d2, t) = s.dist2(p);
                    if d2 < best.0 {
                        best = (d2, k, t);
                    }
                }
            }
        }
        best
    }

    /// Total contour length.
    pub fn perimeter(&self) -> f64 {
        self.cum_len.last().copied().unwrap_or(0.0)
    }

    /// The contour point at arc length `s` (wrapped into `[0, perimeter)`, polygons concatenated)
    /// and the outward unit normal there (the normal of the edge holding the point).
    #[inline]
    pub fn point_at_arc_length(&self, s: f64) -> (Point2, Point2) {
        let total = self.perimeter();
        let s = s.rem_euclid(total);
        let k = self
            .cum_len
            .partition_point(|&c| c <= s)
            .min(self.segs.len() - 1);
        let seg = &self.segs[k];
        let start = if k == 0 { 0.0 } else { self.cum_len[k - 1] };
        let len = self.cum_len[k] - start;
        let t = if len > 0.0 {
            ((s - start) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (
            [seg.a[0] + t * seg.d[0], seg.a[1] + t * seg.d[1]],
            seg.normal,
        )
    }
}

fn add(a: Point2, b: Point2) -> Point2 {
    [a[0] + b[0], a[1] + b[1]]
}

fn point_segment_distance(p: Point2, a: Point2, b: Point2) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let w = [p[0] - a[0], p[1] - a[1]];
    let t = if len2 > 0.0 {
        ((w[0] * d[0] + w[1] * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (w[0] - t * d[0]).hypot(w[1] - t * d[1])
}

fn point_rect_distance(p: Point2, lo: Point2, hi: Point2) -> f64 {
    let dx = (lo[0] - p[0]).max(0.0).max(p[0] - hi[0]);
    let dy = (lo[1] - p[1]).max(0.0).max(p[1] - hi[1]);
    dx.hypot(dy)
}

/// Distance between an axis-aligned rectangle and a segment: zero when they meet, otherwise
/// attained at a segment endpoint or a rectangle corner (both sets are convex).
fn rect_segment_distance(lo: Point2, hi: Point2, a: Point2, b: Point2) -> f64 {
    if segment_meets_rect(lo, hi, a, b) {
        return 0.0;
    }
    let corners = [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]];
    corners
        .iter()
        .map(|&c| point_segment_distance(c, a, b))
        .fold(
            point_rect_distance(a, lo, hi).min(point_rect_distance(b, lo, hi)),
            f64::min,
        )
}

/// Liang–Barsky clipping: whether segment ab has a point inside the closed rectangle.
fn segment_meets_rect(lo: Point2, hi: Point2, a: Point2, b: Point2) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
    }
    t0 <= t1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polygon::{contains_even_odd, find_crossing, orient_by_nesting};
    use proptest::prelude::*;

    /// Brute force: minimum over all edges, sign by the even-odd rule.
    fn brute(polys: &[Polygon], p: Point2) -> f64 {
        let d = polys
            .iter()
            .flat_map(|poly| (0..poly.len()).map(move |i| (poly[i], poly[(i + 1) % poly.len()])))
            .map(|(a, b)| point_segment_distance(p, a, b))
            .fold(f64::INFINITY, f64::min);
        if contains_even_odd(polys, p) {
            -d
        } else {
            d
        }
    }

    /// A star-shaped polygon around `c`: never self-intersecting, convex and reflex vertices.
    fn star(c: Point2, radii: &[f64], phase: f64) -> Polygon {
        let n = radii.len();
        (0..n)
            .map(|k| {
                let a = phase + std::f64::consts::TAU * k as f64 / n as f64;
                [c[0] + radii[k] * a.cos(), c[1] + radii[k] * a.sin()]
            })
            .collect()
    }

    #[test]
    fn square_with_hole() {
        let mut polys = vec![
            vec![[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]],
            vec![[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]],
        ];
        orient_by_nesting(&mut polys);
        let sdf = PolygonSdf::new(&polys, None).unwrap();
        assert_eq!(sdf.distance([0.5, 2.0]), -0.5);
        assert_eq!(sdf.distance([2.0, 2.0]), 1.0);
        assert_eq!(sdf.distance([-1.0, 2.0]), 1.0);
        assert_eq!(sdf.distance([7.0, 8.0]), 5.0);
        assert_eq!(sdf.perimeter(), 24.0);
        // Outward normals point away from the region: out of the outer square, into the hole.
        let (p, n) = sdf.point_at_arc_length(2.0);
        let probe = [p[0] + 0.1 * n[0], p[1] + 0.1 * n[1]];
        assert!(sdf.distance(probe) > 0.0);
        let (p, n) = sdf.point_at_arc_length(17.0);
        let probe = [p[0] + 0.1 * n[0], p[1] + 0.1 * n[1]];
        assert!(sdf.distance(probe) > 0.0);
        assert!((sdf.distance(p)).abs() < 1e-12);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn matches_brute_force(
            outer in prop::collection::vec(2.0f64..3.0, 3..40),
            inner in prop::collection::vec(0.5f64..1.5, 3..20),
            other in prop::collection::vec(0.3f64..0.9, 3..12),
            phase in 0.0f64..6.3,
            queries in prop::collection::vec((-5.0f64..9.0, -5.0f64..5.0), 200),
        ) {
            // An outer star with a star hole, and a separate island.
            let mut polys = vec![
                star([0.0, 0.0], &outer, phase),
                star([0.0, 0.0], &inner, -phase),
                star([5.5, 0.0], &other, 0.0),
            ];
            prop_assume!(find_crossing(&polys).is_none());
            orient_by_nesting(&mut polys);
            let sdf = PolygonSdf::new(&polys, Some(([-4.0, -4.0], [7.0, 4.0]))).unwrap();
            for (x, y) in queries {
                let got = sdf.distance([x, y]);
                let want = brute(&polys, [x, y]);
                prop_assert!((got.abs() - want.abs()).abs() < 1e-12, "|d| {} vs {} at {:?}", got, want, (x, y));
                if want.abs() > 1e-9 {
                    prop_assert_eq!(got < 0.0, want < 0.0, "sign at {:?}", (x, y));
                }
            }
        }
    }
}
