//! Buckets of line segments on a sparse grid, for the crossing tests ([`for_each_near_pair`]:
//! [`crate::polygon::find_crossing`], [`crate::repair::find_contacts`]).
//!
//! A uniform grid suits cross-section contours: segments are short and of similar length, so a
//! cell about one segment long keeps every bucket small with no tree to balance. (The signed
//! distance, whose queries may fall anywhere in the plane, has its own tree and grid:
//! [`crate::sdf`].)

use std::ops::ControlFlow;

use crate::Point2;

/// Calls `visit(i, j)`, i < j, for every two of `segments` (endpoint pairs, finite) that share
/// a cell of a sparse grid whose cell is their mean length: every two segments that touch or
/// cross are visited (a pair sharing several cells is visited once per cell); `visit` stops the
/// walk by returning [`ControlFlow::Break`].
///
/// The crossing tests' grid. A dense grid of about one cell per segment over the bounding box
/// puts a ring of n segments in about √n cells, √n segments each: n^1.5 pairs (with a cap of 256
/// cells per axis, n²/1000). Here a cell is about one segment long and only the
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
