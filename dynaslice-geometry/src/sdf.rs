//! Exact signed distance to a class's polygon set on one plane, and its outward normals.
//!
//! [`PolygonSdf`] answers "how far is this plane point from the class's contours, and is it inside"
//! exactly (up to floating point), negative inside, holes respected. It is the in-plane 2D SDF
//! **f**ᵢ of the paper's data term (Eq. 7) and provides the in-plane normals **n**ᵢ of the
//! orientation term (Eq. 6) for contour samples.
//!
//! Speed: the trainer resamples every step, so queries must cost well under a microsecond, and
//! building must stay linear (n log n at worst) in the number of points however dense one contour
//! is (a 200 000-point RTSTRUCT contour once took 93 s). Two structures:
//! - a tree of bounding boxes over runs of consecutive segments (`SegmentTree`): contour order
//!   already keeps neighbours together, so it is built in O(n) without sorting and answers an
//!   exact nearest-segment query by branch and bound in O(log n) near the contour (far from a
//!   densely sampled smooth contour the distance is flat around the nearest point, and the
//!   boxes leave O(√n) segments to check: 13 µs at 200 000 points, see the bench);
//! - in front of it, a uniform grid of about one cell per segment (at most 256 per axis) where
//!   each cell keeps the list of segments that can be nearest to *some* point of the cell (those
//!   within `d(centre) + half-diagonal` of the cell, a bound that holds for every point in it),
//!   sorted by their distance to the cell; a query walks its cell's list and stops at the first
//!   segment that cannot beat the best distance so far. The lists are found with the tree. A cell
//!   whose list would be longer than `MAX_CANDIDATES` (256: near a contour far denser than the
//!   grid, where a list would grow with the point count) keeps none and is answered by the tree,
//!   as are points outside the grid (the plane's region of interest grown to cover the
//!   contours).
//!
//! Both paths return the least squared distance over all segments, ties going to the lower
//! segment index, so a query's answer does not depend on which path served it.
//!
//! Sign: the polygons must be oriented by [`crate::polygon::orient_by_nesting`] (region on the
//! left). The sign then comes from the nearest feature: the side of the nearest edge, or, when the
//! nearest point is a vertex, the side of the sum of the two adjacent edge normals (the 2D
//! angle-weighted pseudo-normal, Bærentzen & Aanæs 2005), which is exact for closest points.

use crate::polygon::Polygon;
use crate::Point2;

/// Longest candidate list a grid cell keeps. With segments about as long as a cell (realistic
/// contours: the bench's annotation needs 59 at the median, 157 at the 99th percentile) lists
/// stay short; near a contour of many short segments a list would hold them all (thousands per
/// cell at 200 000 points), so such a cell keeps none and is answered by the tree.
const MAX_CANDIDATES: usize = 256;

/// Segments per leaf of the [`SegmentTree`].
const LEAF: usize = 8;

/// Most cells per axis of the grid: bounds its memory (the tree serves what a coarse grid cannot).
const MAX_CELLS_PER_AXIS: usize = 256;

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
    tree: SegmentTree,
    grid: Grid,
    /// `cand_start[c]..cand_start[c + 1]` indexes `cands` for grid cell `c`; empty for a cell
    /// answered by the tree (a kept list is never empty: it holds the segment nearest to the
    /// cell's centre).
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
    /// O(n log n) in the number of vertices n (see the [module docs](self)).
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
        if segs.is_empty() {
            return None;
        }
        let tree = SegmentTree::new(&segs);
        let grid = Grid::new(tree.boxes[1], region, segs.len());
        let mut cum_len = Vec::with_capacity(segs.len());
        let mut acc = 0.0;
        for s in &segs {
            acc += (s.d[0] * s.d[0] + s.d[1] * s.d[1]).sqrt();
            cum_len.push(acc);
        }
        let mut sdf = PolygonSdf {
            segs,
            tree,
            grid,
            cand_start: Vec::new(),
            cands: Vec::new(),
            cum_len,
        };
        sdf.build_candidates();
        Some(sdf)
    }

    /// Fills the cells' candidate lists: per cell, one nearest query and one range query on the
    /// tree, the latter stopped after [`MAX_CANDIDATES`]: O(log n + MAX_CANDIDATES) a cell.
    fn build_candidates(&mut self) {
        let (nx, ny) = (self.grid.nx, self.grid.ny);
        let mut list: Vec<(f64, u32)> = Vec::new();
        self.cand_start.reserve(nx * ny + 1);
        for j in 0..ny {
            for i in 0..nx {
                let (lo, hi) = self.grid.cell_rect(i, j);
                let centre = [(lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5];
                // Every point of the cell is within `bound` of the centre's nearest segment, so
                // only segments within `bound` of the cell can be nearest to a point in it.
                let (best, _, _) = self.tree.nearest(&self.segs, centre);
                let bound = best.sqrt() + self.grid.cell * std::f64::consts::FRAC_1_SQRT_2;
                list.clear();
                self.cand_start.push(self.cands.len() as u32);
                if self
                    .tree
                    .near_rect(&self.segs, (lo, hi), bound, MAX_CANDIDATES, &mut list)
                {
                    list.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                    self.cands.extend_from_slice(&list);
                }
            }
        }
        self.cand_start.push(self.cands.len() as u32);
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

    /// (squared distance, segment, projection parameter) of the nearest contour point: from the
    /// cell's candidate list where it has one, else from the tree.
    #[inline]
    fn nearest(&self, p: Point2) -> (f64, usize, f64) {
        if let Some(c) = self.grid.cell_of(p) {
            let list = &self.cands[self.cand_start[c] as usize..self.cand_start[c + 1] as usize];
            if !list.is_empty() {
                let mut best = NONE;
                for &(lb, s) in list {
                    if lb * lb > best.0 {
                        break;
                    }
                    offer(&mut best, s as usize, self.segs[s as usize].dist2(p));
                }
                return best;
            }
        }
        self.tree.nearest(&self.segs, p)
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

/// No segment yet: any finite distance beats it.
const NONE: (f64, usize, f64) = (f64::INFINITY, usize::MAX, 0.0);

/// Keeps in `best` the nearer of it and segment `s` at (squared distance, parameter), ties going
/// to the lower index: the answer is then the same whichever order (list or tree) offers them.
#[inline]
fn offer(best: &mut (f64, usize, f64), s: usize, (d2, t): (f64, f64)) {
    if d2 < best.0 || (d2 == best.0 && s < best.1) {
        *best = (d2, s, t);
    }
}

/// An axis-aligned box (lower corner, upper corner); empty when the lower corner is +∞.
type Aabb = (Point2, Point2);

const EMPTY: Aabb = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);

fn union(a: Aabb, b: Aabb) -> Aabb {
    (
        [a.0[0].min(b.0[0]), a.0[1].min(b.0[1])],
        [a.1[0].max(b.1[0]), a.1[1].max(b.1[1])],
    )
}

/// Squared distance between two boxes (a point is the box (p, p)); +∞ to an empty box.
#[inline]
fn gap2(a: Aabb, b: Aabb) -> f64 {
    let dx = (a.0[0] - b.1[0]).max(b.0[0] - a.1[0]).max(0.0);
    let dy = (a.0[1] - b.1[1]).max(b.0[1] - a.1[1]).max(0.0);
    dx * dx + dy * dy
}

/// Bounding boxes of runs of [`LEAF`] consecutive segments and of their unions: a complete binary
/// tree in heap order (node 1 the root, node k's children 2k and 2k + 1, leaf k the node
/// `leaves + k`, holding segments `LEAF·k..LEAF·(k + 1)`; leaves past the last segment are
/// empty). Consecutive contour segments are neighbours in the plane, so the boxes are tight
/// without any sorting: built in O(n); a branch-and-bound query visits O(log n) nodes near a
/// contour (see the [module docs](self) for points far from a dense one).
#[derive(Debug, Clone)]
struct SegmentTree {
    /// Number of leaves, a power of two.
    leaves: usize,
    /// The box of every node; index 0 is unused.
    boxes: Vec<Aabb>,
}

/// Deepest a depth-first walk of a [`SegmentTree`] goes is log₂ of its leaf count (< 32 for
/// `u32` segment indices); each level leaves at most one sibling pending on the stack.
const STACK: usize = 64;

impl SegmentTree {
    fn new(segs: &[Seg]) -> Self {
        let leaves = segs.len().div_ceil(LEAF).next_power_of_two();
        let mut boxes = vec![EMPTY; 2 * leaves];
        for (k, run) in segs.chunks(LEAF).enumerate() {
            boxes[leaves + k] = run.iter().fold(EMPTY, |acc, s| {
                let b = s.b();
                union(
                    acc,
                    (
                        [s.a[0].min(b[0]), s.a[1].min(b[1])],
                        [s.a[0].max(b[0]), s.a[1].max(b[1])],
                    ),
                )
            });
        }
        for node in (1..leaves).rev() {
            boxes[node] = union(boxes[2 * node], boxes[2 * node + 1]);
        }
        SegmentTree { leaves, boxes }
    }

    /// The segments of leaf node `node`.
    fn run(&self, node: usize, n: usize) -> std::ops::Range<usize> {
        let first = (node - self.leaves) * LEAF;
        first.min(n)..(first + LEAF).min(n)
    }

    /// (squared distance, segment, projection parameter) of the segment nearest to `p`: depth
    /// first, nearer child first, skipping boxes farther than the best so far.
    fn nearest(&self, segs: &[Seg], p: Point2) -> (f64, usize, f64) {
        let mut best = NONE;
        let mut stack = [(0.0, 0usize); STACK];
        stack[0] = (0.0, 1);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (d2, node) = stack[top];
            if d2 > best.0 {
                continue;
            }
            if node >= self.leaves {
                for s in self.run(node, segs.len()) {
                    offer(&mut best, s, segs[s].dist2(p));
                }
                continue;
            }
            let (l, r) = (2 * node, 2 * node + 1);
            let (dl, dr) = (gap2(self.boxes[l], (p, p)), gap2(self.boxes[r], (p, p)));
            let (near, far) = if dl <= dr {
                ((dl, l), (dr, r))
            } else {
                ((dr, r), (dl, l))
            };
            stack[top] = far;
            stack[top + 1] = near;
            top += 2;
        }
        best
    }

    /// Pushes onto `out` every segment whose distance to the rectangle `rect`
    /// ([`rect_segment_distance`]) is at most `bound`, with that distance. Returns false, `out`
    /// unfinished, as soon as it holds more than `limit`.
    fn near_rect(
        &self,
        segs: &[Seg],
        rect: Aabb,
        bound: f64,
        limit: usize,
        out: &mut Vec<(f64, u32)>,
    ) -> bool {
        // Boxes and segment distances round differently: the slack keeps every segment that
        // the exact test below accepts.
        let reach2 = (bound * (1.0 + 1e-9)).powi(2);
        let mut stack = [0usize; STACK];
        stack[0] = 1;
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = stack[top];
            if gap2(self.boxes[node], rect) > reach2 {
                continue;
            }
            if node >= self.leaves {
                for s in self.run(node, segs.len()) {
                    let lb = rect_segment_distance(rect.0, rect.1, segs[s].a, segs[s].b());
                    if lb <= bound {
                        out.push((lb, s as u32));
                        if out.len() > limit {
                            return false;
                        }
                    }
                }
                continue;
            }
            stack[top] = 2 * node;
            stack[top + 1] = 2 * node + 1;
            top += 2;
        }
        true
    }
}

/// The uniform grid of the candidate lists: square cells, about one per segment, over the
/// contours' bounding box and the region, at most [`MAX_CELLS_PER_AXIS`] per axis.
#[derive(Debug, Clone)]
struct Grid {
    origin: Point2,
    cell: f64,
    nx: usize,
    ny: usize,
}

impl Grid {
    /// A grid over `bounds` (finite) and `region`, for `n` segments.
    fn new(bounds: Aabb, region: Option<Aabb>, n: usize) -> Self {
        let (lo, hi) = union(bounds, region.unwrap_or(EMPTY));
        let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
        let mut cell = if w > 0.0 && h > 0.0 {
            (w * h / n as f64).sqrt()
        } else {
            w.max(h) / n as f64
        };
        if cell <= 0.0 || !cell.is_finite() {
            cell = 1.0;
        }
        cell = cell
            .max(w / MAX_CELLS_PER_AXIS as f64)
            .max(h / MAX_CELLS_PER_AXIS as f64);
        let nx = ((w / cell).ceil() as usize).clamp(1, MAX_CELLS_PER_AXIS);
        let ny = ((h / cell).ceil() as usize).clamp(1, MAX_CELLS_PER_AXIS);
        Grid {
            origin: lo,
            cell,
            nx,
            ny,
        }
    }

    /// The index (j · nx + i) of the cell holding `p`, or `None` outside the grid.
    #[inline]
    fn cell_of(&self, p: Point2) -> Option<usize> {
        let x = (p[0] - self.origin[0]) / self.cell;
        let y = (p[1] - self.origin[1]) / self.cell;
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let (i, j) = (x as usize, y as usize);
        // The far border belongs to the last cell.
        let i = if i == self.nx && x <= self.nx as f64 {
            i - 1
        } else {
            i
        };
        let j = if j == self.ny && y <= self.ny as f64 {
            j - 1
        } else {
            j
        };
        (i < self.nx && j < self.ny).then_some(j * self.nx + i)
    }

    /// Lower and upper corners of cell (i, j).
    fn cell_rect(&self, i: usize, j: usize) -> Aabb {
        let lo = [
            self.origin[0] + i as f64 * self.cell,
            self.origin[1] + j as f64 * self.cell,
        ];
        (lo, [lo[0] + self.cell, lo[1] + self.cell])
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

    /// Each edge of `poly` cut into `k` equal pieces: the same region with k times the points.
    fn densify(poly: &Polygon, k: usize) -> Polygon {
        let n = poly.len();
        (0..n)
            .flat_map(|i| {
                let (a, b) = (poly[i], poly[(i + 1) % n]);
                (0..k).map(move |j| {
                    let t = j as f64 / k as f64;
                    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                })
            })
            .collect()
    }

    #[test]
    fn dense_contours_are_answered_by_the_tree_exactly() {
        // 12 000 points on one ring in a wide region: cells far coarser than the segments, so
        // most lists would hold hundreds of segments and the tree answers instead.
        let radii: Vec<f64> = (0..400)
            .map(|k| 20.0 + 3.0 * (k as f64 * 0.37).sin())
            .collect();
        let mut polys = vec![densify(&star([3.0, -2.0], &radii, 0.1), 30)];
        orient_by_nesting(&mut polys);
        let sdf = PolygonSdf::new(&polys, Some(([-60.0, -60.0], [60.0, 60.0]))).unwrap();
        let cells = sdf.cand_start.len() - 1;
        let by_tree = (0..cells)
            .filter(|&c| sdf.cand_start[c] == sdf.cand_start[c + 1])
            .count();
        assert!(
            by_tree > cells / 10,
            "{by_tree} of {cells} cells answered by the tree"
        );
        for k in 0..3000 {
            // Spread over and beyond the region (points outside the grid use the tree too).
            let p = [
                -70.0 + 140.0 * (k as f64 * 0.754_877_666_246_692_7).fract(),
                -70.0 + 140.0 * (k as f64 * 0.569_840_290_998_053_3).fract(),
            ];
            let (got, want) = (sdf.distance(p), brute(&polys, p));
            assert!(
                (got.abs() - want.abs()).abs() < 1e-12,
                "{got} vs {want} at {p:?}"
            );
            assert!(
                want.abs() < 1e-9 || (got < 0.0) == (want < 0.0),
                "sign at {p:?}"
            );
            // The two paths agree exactly: least squared distance, ties to the lower index.
            assert_eq!(sdf.nearest(p), sdf.tree.nearest(&sdf.segs, p), "at {p:?}");
        }
    }

    #[test]
    fn realistic_contours_keep_lists() {
        // Segments about as long as a cell (a planning system's contour in its field): all but
        // a few cells keep their list, the fast path.
        let radii: Vec<f64> = (0..640)
            .map(|k| 35.0 + 5.0 * (k as f64 * 0.05).sin())
            .collect();
        let hole: Vec<f64> = radii[..128].iter().map(|r| r * 0.3).collect();
        let mut polys = vec![star([0.0, 0.0], &radii, 0.0), star([0.0, 0.0], &hole, 0.5)];
        orient_by_nesting(&mut polys);
        let sdf = PolygonSdf::new(&polys, Some(([-100.0, -100.0], [100.0, 100.0]))).unwrap();
        let cells = sdf.cand_start.len() - 1;
        let kept = sdf.cand_start.windows(2).filter(|w| w[1] > w[0]).count();
        assert!(
            kept * 100 >= cells * 95,
            "{kept} of {cells} cells keep a list"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn matches_brute_force(
            outer in prop::collection::vec(2.0f64..3.0, 3..40),
            inner in prop::collection::vec(0.5f64..1.5, 3..20),
            other in prop::collection::vec(0.3f64..0.9, 3..12),
            phase in 0.0f64..6.3,
            dense in 1usize..40,
            wide in any::<bool>(),
            queries in prop::collection::vec((-5.0f64..9.0, -5.0f64..5.0), 200),
        ) {
            // An outer star with a star hole, and a separate island; edges cut into `dense`
            // pieces and a `wide` region make cells coarse against the segments, so that lists
            // grow long and the tree answers.
            let polys = vec![
                star([0.0, 0.0], &outer, phase),
                star([0.0, 0.0], &inner, -phase),
                star([5.5, 0.0], &other, 0.0),
            ];
            prop_assume!(find_crossing(&polys).is_none());
            let mut polys: Vec<Polygon> = polys.iter().map(|p| densify(p, dense)).collect();
            orient_by_nesting(&mut polys);
            let region = if wide {
                ([-400.0, -400.0], [400.0, 400.0])
            } else {
                ([-4.0, -4.0], [7.0, 4.0])
            };
            let sdf = PolygonSdf::new(&polys, Some(region)).unwrap();
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
