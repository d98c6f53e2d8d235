//! A uniform grid of buckets over line segments, the acceleration structure shared by the
//! crossing test ([`super::polygon::find_crossing`]) and the signed distance ([`super::sdf`]).
//!
//! A uniform grid suits cross-section contours: segments are short and of similar length, so about
//! one segment per cell keeps every bucket small with no tree to balance.

use super::polygon::Point2;

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
