//! Buckets of line segments on grids: the dense uniform grid of the signed distance
//! ([`crate::sdf`]) and the sparse grid of the crossing tests ([`for_each_near_pair`]:
//! [`crate::polygon::find_crossing`], [`crate::repair::find_contacts`]).
//!
//! A uniform grid suits cross-section contours: segments are short and of similar length, so about
//! one segment per cell keeps every bucket small with no tree to balance.

use std::ops::ControlFlow;

use crate::Point2;

/// Segments bucketed by the cells their bounding boxes overlap (a conservative cover).
#[derive(Debug, Clone)]
pub struct BucketGrid {
    origin: Point2,
    cell: f64,
    nx: usize,
    ny: usize,
    /// `start[c]..start[c + 1]` indexes `items` for cell `c = j * nx + i`.
    start: Vec<u32>,
    items: Vec<u32>,
}

/// Most cells per axis: bounds memory for pathological inputs (one huge and many tiny segments).
const MAX_CELLS_PER_AXIS: usize = 256;

impl BucketGrid {
    /// Buckets `segments` (endpoint pairs, indexed in iteration order) over the union of their
    /// bounding box and `region`, with about one cell per segment. `None` when there are no
    /// segments. Coordinates must be finite.
    pub fn new<I>(segments: I, region: Option<(Point2, Point2)>) -> Option<Self>
    where
        I: Iterator<Item = (Point2, Point2)> + Clone,
    {
        let n = segments.clone().count();
        if n == 0 {
            return None;
        }
        let (mut lo, mut hi) = region.unwrap_or(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]));
        for (a, b) in segments.clone() {
            for p in [a, b] {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
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
        let mut grid = BucketGrid {
            origin: lo,
            cell,
            nx,
            ny,
            start: vec![0; nx * ny + 1],
            items: Vec::new(),
        };
        // Two passes (count, then fill) give a compact CSR layout.
        for (a, b) in segments.clone() {
            let start = &mut grid.start;
            cells_of(lo, cell, nx, ny, a, b, |c| start[c] += 1);
        }
        let mut acc = 0u32;
        for s in grid.start.iter_mut() {
            let c = *s;
            *s = acc;
            acc += c;
        }
        grid.items = vec![0; acc as usize];
        let mut fill = grid.start.clone();
        for (idx, (a, b)) in segments.enumerate() {
            let items = &mut grid.items;
            cells_of(lo, cell, nx, ny, a, b, |c| {
                items[fill[c] as usize] = idx as u32;
                fill[c] += 1;
            });
        }
        Some(grid)
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.nx * self.ny
    }

    /// Cells per axis.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Cell side length.
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Segment indices bucketed in cell `c`.
    pub fn bucket(&self, c: usize) -> &[u32] {
        &self.items[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// The cell holding `p`, or `None` outside the grid.
    pub fn cell_of(&self, p: Point2) -> Option<(usize, usize)> {
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
        (i < self.nx && j < self.ny).then_some((i, j))
    }

    /// Lower and upper corners of cell (i, j).
    pub fn cell_rect(&self, i: usize, j: usize) -> (Point2, Point2) {
        let lo = [
            self.origin[0] + i as f64 * self.cell,
            self.origin[1] + j as f64 * self.cell,
        ];
        (lo, [lo[0] + self.cell, lo[1] + self.cell])
    }
}

/// Calls `visit(i, j)`, i < j, for every two of `segments` (endpoint pairs, finite) that share
/// a cell of a sparse grid whose cell is their mean length: every two segments that touch or
/// cross are visited (a pair sharing several cells is visited once per cell); `visit` stops the
/// walk by returning [`ControlFlow::Break`].
///
/// The crossing tests' grid. A dense grid of about one cell per segment over the bounding box
/// puts a ring of n segments in about √n cells, √n segments each: n^1.5 pairs (with the dense
/// grid's cap of 256 cells per axis, n²/1000). Here a cell is about one segment long and only the
/// cells a segment passes through are kept, sorted: for real contours each cell holds a few
/// segments, so the cost is O(n log n) in time and O(n) in memory, however long the contour.
pub fn for_each_near_pair(
    segments: &[(Point2, Point2)],
    mut visit: impl FnMut(usize, usize) -> ControlFlow<()>,
) {
    if segments.len() < 2 {
        return;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut total = 0.0;
    for &(a, b) in segments {
        for k in 0..2 {
            lo[k] = lo[k].min(a[k]).min(b[k]);
            hi[k] = hi[k].max(a[k]).max(b[k]);
        }
        total += (b[0] - a[0]).hypot(b[1] - a[1]);
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    // At most 2³⁰ cells per axis, so a cell's key fits in a u64 and its indices in f64.
    let cell = (total / segments.len() as f64).max(extent / (1u64 << 30) as f64);
    if !(cell > 0.0 && cell.is_finite()) {
        // Every segment is one point: all in one cell.
        let all: Vec<usize> = (0..segments.len()).collect();
        let _ = visit_run(&all, &mut visit);
        return;
    }
    let index = |v: f64, o: f64| ((v - o) / cell).floor().max(0.0) as u64;
    // Each segment is cut into pieces at most one cell long; a piece's bounding box, widened by
    // far more than the rounding of the cut points, covers at most 3×3 cells.
    let widen = cell * 1e-6;
    let mut entries: Vec<(u64, u32)> = Vec::with_capacity(4 * segments.len());
    for (s, &(a, b)) in segments.iter().enumerate() {
        let pieces = ((b[0] - a[0]).hypot(b[1] - a[1]) / cell).ceil().max(1.0) as usize;
        let at = |t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        for p in 0..pieces {
            let (u, w) = (
                at(p as f64 / pieces as f64),
                at((p + 1) as f64 / pieces as f64),
            );
            let (i0, i1) = (
                index(u[0].min(w[0]) - widen, lo[0]),
                index(u[0].max(w[0]) + widen, lo[0]),
            );
            let (j0, j1) = (
                index(u[1].min(w[1]) - widen, lo[1]),
                index(u[1].max(w[1]) + widen, lo[1]),
            );
            for j in j0..=j1 {
                for i in i0..=i1 {
                    entries.push(((j << 32) | i, s as u32));
                }
            }
        }
    }
    entries.sort_unstable();
    entries.dedup();
    let mut run: Vec<usize> = Vec::new();
    for chunk in entries.chunk_by(|x, y| x.0 == y.0) {
        run.clear();
        run.extend(chunk.iter().map(|&(_, s)| s as usize));
        if visit_run(&run, &mut visit).is_break() {
            return;
        }
    }
}

/// Visits every pair of one cell's segments (ascending, distinct).
fn visit_run(
    run: &[usize],
    visit: &mut impl FnMut(usize, usize) -> ControlFlow<()>,
) -> ControlFlow<()> {
    for (k, &i) in run.iter().enumerate() {
        for &j in &run[k + 1..] {
            visit(i, j)?;
        }
    }
    ControlFlow::Continue(())
}

fn cells_of(
    origin: Point2,
    cell: f64,
    nx: usize,
    ny: usize,
    a: Point2,
    b: Point2,
    mut f: impl FnMut(usize),
) {
    let idx = |v: f64, o: f64, n: usize| (((v - o) / cell).floor().max(0.0) as usize).min(n - 1);
    let (i0, i1) = (
        idx(a[0].min(b[0]), origin[0], nx),
        idx(a[0].max(b[0]), origin[0], nx),
    );
    let (j0, j1) = (
        idx(a[1].min(b[1]), origin[1], ny),
        idx(a[1].max(b[1]), origin[1], ny),
    );
    for j in j0..=j1 {
        for i in i0..=i1 {
            f(j * nx + i);
        }
    }
}
