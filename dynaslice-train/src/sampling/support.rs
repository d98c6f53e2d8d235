//! Where each class's own data holds its surface: within one plane gap of the class's contours
//! at the bracketing frames. There the minimum-surface term exp(−α|f|) of Eq. 8 is switched
//! off, so that it acts, as the paper states, "away from observed slices".
//!
//! Why: with ‖∇f‖ = 1 the term's integral is (2/α)·area of the zero set, a surface-area
//! penalty. Between a class's planes and beyond its outermost one nothing else holds the
//! surface, so once the planes are fitted the term keeps shrinking what they leave free (a
//! small ball's caps, a thin tube between its sections) for as long as training runs: longer
//! runs gave smaller tumours (lab/notes/2026-12-05-training-length.md). Far from a class's
//! contours the term still removes spurious zero-crossings, its purpose.

use std::collections::HashMap;

use super::index::SamplingIndex;

/// Contour points of one (frame, class), bucketed in cubes of side `radius` so that every point
/// within `radius` of a query lies in the 27 cubes around it.
#[derive(Debug, Default)]
struct Buckets {
    cells: HashMap<[i32; 3], Vec<[f32; 3]>>,
}

/// Per frame and class, the class's contour points in the network's normalised frame, for the
/// test "is (x, t) within the gap radius of a contour of class k at a bracketing frame?".
#[derive(Debug)]
pub struct SupportGate {
    /// Gap radius, normalised units.
    radius: f32,
    /// Frame times, normalised, ascending.
    times: Vec<f32>,
    /// `buckets[frame][class]`.
    buckets: Vec<Vec<Buckets>>,
}

/// Lattice points per axis of the region of interest on which the plane gap is measured.
const GAP_LATTICE: usize = 16;

/// Ceiling on the gap radius, normalised units (the domain's half-width is 1): a frame with
/// one or two planes would otherwise switch the term off over most of the domain.
const MAX_RADIUS: f64 = 0.25;

impl SupportGate {
    /// The gate for the sequence behind `index`, its points mapped by `normalise` (world → the
    /// network's frame, whose unit is `scale` world units) and its frame times by
    /// `normalise_time`. The radius is the plane gap: twice the largest distance from a point
    /// of the region of interest `roi` (world box) to the nearest plane of its frame, the
    /// largest over frames, at most [`MAX_RADIUS`].
    pub fn new(
        index: &SamplingIndex,
        roi: ([f64; 3], [f64; 3]),
        scale: f64,
        normalise: impl Fn([f64; 3]) -> [f32; 3],
        normalise_time: impl Fn(f64) -> f32,
    ) -> SupportGate {
        let mut times: Vec<f64> = index.planes.iter().map(|p| p.time).collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        let frame_of = |t: f64| times.partition_point(|&u| u < t);
        // The plane gap: how far a point can be from every plane of its frame.
        let mut gap = 0.0f64;
        for &t in &times {
            let planes: Vec<_> = index
                .planes
                .iter()
                .filter(|p| p.time == t)
                .map(|p| (p.plane.origin, p.plane.normal()))
                .collect();
            for i in 0..GAP_LATTICE.pow(3) {
                let c = [
                    i % GAP_LATTICE,
                    (i / GAP_LATTICE) % GAP_LATTICE,
                    i / GAP_LATTICE.pow(2),
                ];
                let x: [f64; 3] = std::array::from_fn(|d| {
                    let s = (c[d] as f64 + 0.5) / GAP_LATTICE as f64;
                    roi.0[d] + s * (roi.1[d] - roi.0[d])
                });
                let near = planes
                    .iter()
                    .map(|(o, n)| (0..3).map(|d| (x[d] - o[d]) * n[d]).sum::<f64>().abs())
                    .fold(f64::INFINITY, f64::min);
                gap = gap.max(2.0 * near);
            }
        }
        let radius = (gap / scale).clamp(1e-6, MAX_RADIUS) as f32;
        let classes = index.classes.len();
        let mut buckets: Vec<Vec<Buckets>> = (0..times.len())
            .map(|_| (0..classes).map(|_| Buckets::default()).collect())
            .collect();
        // Contour points a quarter of the radius apart: every contour point is within an
        // eighth of the radius of one of them.
        let step = 0.25 * radius as f64 * scale;
        for a in &index.annotations {
            let Some(sdf) = &a.sdf else { continue };
            let entry = &index.planes[a.plane];
            let b = &mut buckets[frame_of(entry.time)][a.class as usize];
            let n = (sdf.perimeter() / step).ceil().max(1.0) as usize;
            for j in 0..n {
                let (p, _) = sdf.point_at_arc_length(sdf.perimeter() * j as f64 / n as f64);
                let x = normalise(entry.plane.to_world(p));
                b.cells.entry(cell(x, radius)).or_default().push(x);
            }
        }
        SupportGate {
            radius,
            times: times.into_iter().map(normalise_time).collect(),
            buckets,
        }
    }

    /// The gap radius, normalised units.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Writes, for each point of `x` (normalised x, y, z, t) and each of the `k` classes, 0
    /// where the point is within the radius of a contour of the class at a bracketing frame
    /// (the frames just before and after its time), 1 elsewhere; `out` is `x.len() × k`,
    /// point-major.
    pub fn fill(&self, x: &[[f32; 4]], k: usize, out: &mut Vec<f32>) {
        out.clear();
        out.resize(x.len() * k, 1.0);
        let r2 = self.radius * self.radius;
        for (i, p) in x.iter().enumerate() {
            let after = self.times.partition_point(|&u| u < p[3]);
            let frames = [
                after.checked_sub(1),
                (after < self.times.len()).then_some(after),
            ];
            let q = [p[0], p[1], p[2]];
            let c0 = cell(q, self.radius);
            for (c, g) in out[i * k..(i + 1) * k].iter_mut().enumerate() {
                let near = frames.iter().flatten().any(|&f| {
                    let cells = &self.buckets[f][c].cells;
                    (0..27i32).any(|j| {
                        let key = [
                            c0[0] + j % 3 - 1,
                            c0[1] + (j / 3) % 3 - 1,
                            c0[2] + j / 9 - 1,
                        ];
                        cells.get(&key).is_some_and(|pts| {
                            pts.iter().any(|s| {
                                (0..3).map(|d| (s[d] - q[d]) * (s[d] - q[d])).sum::<f32>() <= r2
                            })
                        })
                    })
                });
                if near {
                    *g = 0.0;
                }
            }
        }
    }
}

/// The cube of side `r` holding `x`.
fn cell(x: [f32; 3], r: f32) -> [i32; 3] {
    x.map(|v| (v / r).floor() as i32)
}
