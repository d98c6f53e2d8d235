//! Label volumes without evaluating every voxel: coarse-to-fine blocks of voxels, pruned with
//! the SDF distance bound and verified by their corners.
//!
//! The label of a point is the Eq. 11 argmin over v = (0, f¹, …, f^K) (background 0). At an
//! evaluated voxel c with label w, the label can only change where some v_j overtakes v_w. If
//! every f^k is λ-Lipschitz (λ = 1 for an exact signed distance), v_j − v_w falls by at most
//! (λ_j + λ_w)·r at distance r (λ₀ = 0 for the constant background), so the label is w in the
//! open ball of radius
//!
//! ρ(c) = min_{j≠w} (v_j(c) − v_w(c)) / (s · (λ_j + λ_w)),
//!
//! with s ≥ 1 a safety factor for a network that is only approximately a distance.
//!
//! A frame is cut into cells whose corners are voxel centres (top cells of [`TOP`] voxels per
//! side, halved at each level). A cell is filled with one label, without evaluating its other
//! voxels, only when all of these hold:
//!
//! 1. the bound: every corner's ρ exceeds the cell's covering radius R (half its longest
//!    diagonal in world units: every point of the parallelepiped is within R of its nearest
//!    corner), so each voxel lies in some corner's certified ball;
//! 2. the verification: all its corners have the same label;
//! 3. the steepness check: no two corners have radii differing by more than s × their distance.
//!    ρ is a minimum of (v_j − v_w)/(λ_j + λ_w), each s-Lipschitz under the assumption below,
//!    so a larger difference shows the field is steeper there than the bound allows.
//!
//! Otherwise it is split in two along every axis longer than one voxel. Cells of at most two
//! voxel steps per axis are decided voxel by voxel, in three stages (edge midpoints, face
//! centres, the centre), each voxel one step from points evaluated before it: filled when the
//! cell's evaluated voxels pass 2 and 3 and one of them certifies it (ρ/s beyond its distance),
//! evaluated otherwise. Evaluated voxels get exactly the dense labels (the model's batch
//! evaluation is per point, whatever the batch), so the two can differ only at filled voxels.
//!
//! **Safety.** Under the assumption ‖∇f^k‖ ≤ s for every class (the bound's λ = 1 scaled by the
//! safety factor), the result equals the dense evaluation exactly. A trained SIREN is not
//! guaranteed to satisfy it: its channels approximate distances near the annotated contours
//! but may be steeper elsewhere. Checks 2 and 3 then still catch every label region that
//! reaches an evaluated point and every steepness visible between evaluated points; the
//! residual risk is a region (or a sliver of a boundary) lying wholly inside a filled cell,
//! touching none of its evaluated points, where the network is steeper than s times a distance
//! while its values at those points look like a distance's. `Evaluation::Dense` (`dynaslice
//! labels --dense`) is the check. The tests compare both evaluations on sphere models (whose
//! quadratic fields are steeper than distances away from their spheres) and random SIRENs (not
//! distances at all); the bench compares them on trained models.

use anyhow::{bail, ensure, Result};
use dynaslice_core::{argmin_label, Model, Scratch, UNDEFINED_LABEL};
use rayon::prelude::*;

use crate::VoxelGrid;

/// Voxels per side of a top-level cell (a power of two): its covering radius, ≈ 6.9 voxels, is
/// beyond which a region is cheap to prune (one evaluation per 512 voxels), and 8-voxel slabs
/// give the parallel loop many tasks even on an 80-slice grid.
pub const TOP: usize = 8;

/// Points per model batch call.
const CHUNK: usize = 4096;

/// The default safety factor s of the distance bound, the one `dynaslice mesh` uses.
pub const DEFAULT_SAFETY: f32 = 1.5;

/// Voxel states in a row's working arrays.
const UNSET: u8 = 0;
const FILLED: u8 = 1;
const QUEUED: u8 = 2;
const EVALUATED: u8 = 3;

/// How a frame's labels are computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Evaluation {
    /// The network at every voxel: the reference, and the check for [`Evaluation::Pruned`].
    Dense,
    /// Coarse to fine with the distance bound and corner verification (module documentation),
    /// with this safety factor s ≥ 1.
    Pruned {
        /// s: a cell is filled when every corner's certified radius, divided by s, exceeds it.
        safety: f32,
    },
}

impl Default for Evaluation {
    /// Pruned with [`DEFAULT_SAFETY`].
    fn default() -> Self {
        Evaluation::Pruned {
            safety: DEFAULT_SAFETY,
        }
    }
}

impl Evaluation {
    /// An error unless the safety factor is a finite number ≥ 1.
    pub fn validate(&self) -> Result<()> {
        if let Evaluation::Pruned { safety } = *self {
            ensure!(
                safety.is_finite() && safety >= 1.0,
                "safety factor {safety} must be a finite number ≥ 1"
            );
        }
        Ok(())
    }
}

/// A cell: voxel index ranges `lo[a]..=hi[a]` (x global, y and z local to the row).
#[derive(Clone, Copy, Debug)]
struct Cell {
    lo: [usize; 3],
    hi: [usize; 3],
}

impl Cell {
    /// The (up to 8) distinct corners.
    fn corners(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        (0..8usize).filter_map(move |c| {
            let pick = |a: usize| {
                if c >> a & 1 == 0 {
                    self.lo[a]
                } else {
                    self.hi[a]
                }
            };
            // A corner repeated because an axis has one voxel is listed once.
            let repeated = (0..3).any(|a| c >> a & 1 == 1 && self.lo[a] == self.hi[a]);
            (!repeated).then(|| [pick(0), pick(1), pick(2)])
        })
    }

    fn span(&self) -> [usize; 3] {
        std::array::from_fn(|a| self.hi[a] - self.lo[a])
    }
}

/// Half the longest diagonal of the parallelepiped spanned by `span[a]` voxel steps along each
/// affine column: the farthest any point of a cell is from its nearest corner.
fn covering_radius(affine: &[[f64; 4]; 3], span: [usize; 3]) -> f64 {
    let mut r2: f64 = 0.0;
    for signs in 0..4 {
        let sign = |a: usize| {
            if a > 0 && signs >> (a - 1) & 1 == 1 {
                -1.0
            } else {
                1.0
            }
        };
        let d2: f64 = (0..3)
            .map(|row| {
                (0..3)
                    .map(|a| sign(a) * span[a] as f64 * affine[row][a])
                    .sum::<f64>()
                    .powi(2)
            })
            .sum();
        r2 = r2.max(d2);
    }
    0.5 * r2.sqrt()
}

/// ρ (module documentation) at a point with channel values `f` and label `w`, without the
/// safety factor.
fn certified_radius(f: &[f32], w: u32) -> f32 {
    let value = |j: usize| if j == 0 { 0.0 } else { f[j - 1] };
    let lambda = |j: usize| if j == 0 { 0.0 } else { 1.0f32 };
    let w = w as usize;
    let mut rho = f32::INFINITY;
    for j in 0..=f.len() {
        if j != w {
            rho = rho.min((value(j) - value(w)) / (lambda(j) + lambda(w)));
        }
    }
    rho
}

/// Working memory of one row of top cells: (z, y, x) voxels, x over the whole grid.
struct Row {
    /// Voxels along x, y (local) and z (local) that the row's arrays hold.
    dims: [usize; 3],
    state: Vec<u8>,
    label: Vec<u32>,
    radius: Vec<f32>,
    /// Indices queued for the next batch, and the batch's points and outputs.
    pending: Vec<usize>,
    points: Vec<[f32; 3]>,
    f: Vec<f32>,
    scratch: Box<Scratch>,
}

impl Row {
    fn new(nx: usize, k: usize) -> Row {
        let n = nx * (TOP + 1) * (TOP + 1);
        Row {
            dims: [nx, TOP + 1, TOP + 1],
            state: vec![UNSET; n],
            label: vec![0; n],
            radius: vec![0.0; n],
            pending: Vec::new(),
            points: Vec::with_capacity(CHUNK),
            f: vec![0.0; CHUNK * k],
            scratch: Scratch::boxed(),
        }
    }

    #[inline]
    fn index(&self, v: [usize; 3]) -> usize {
        (v[2] * self.dims[1] + v[1]) * self.dims[0] + v[0]
    }
}

/// What one frame's pruned evaluation did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PruneStats {
    /// Points at which the network was evaluated.
    pub evaluated: u64,
    /// Voxels in the frame.
    pub voxels: u64,
}

/// The Eq. 11 label indices of every voxel of `grid` at time `t` into `out` (x fastest), pruned
/// with safety factor `safety` (module documentation). An error if the model is not finite at
/// an evaluated voxel.
pub fn pruned_label_indices(
    model: &Model,
    grid: &VoxelGrid,
    t: f64,
    safety: f32,
    out: &mut [u32],
) -> Result<PruneStats> {
    Evaluation::Pruned { safety }.validate()?;
    let [nx, ny, nz] = grid.dims;
    ensure!(
        out.len() == grid.voxels_per_frame(),
        "one label per voxel: {} labels for {} voxels",
        out.len(),
        grid.voxels_per_frame()
    );
    let k = model.num_classes();
    let metric = Metric::new(&grid.affine);
    let evaluated: u64 = out
        .par_chunks_mut(nx * ny * TOP)
        .enumerate()
        .map_init(
            || Row::new(nx, k),
            |row, (s, slab)| -> Result<u64> {
                let z0 = s * TOP;
                let z_hi = (z0 + TOP).min(nz - 1) - z0;
                let mut evaluated = 0;
                let mut first = true;
                for y0 in (0..ny.max(2) - 1).step_by(TOP) {
                    let y_hi = (y0 + TOP).min(ny - 1) - y0;
                    let carry = !first;
                    first = false;
                    evaluated += label_row(
                        model,
                        grid,
                        t,
                        safety,
                        &metric,
                        row,
                        [y0, z0],
                        [y_hi, z_hi],
                        carry,
                    )?;
                    // Owned voxels: y in [y0, y0 + TOP) (to ny for the last row), z in the slab.
                    let y_end = if y0 + TOP >= ny - 1 { ny } else { y0 + TOP };
                    for z in 0..slab.len() / (nx * ny) {
                        for y in y0..y_end {
                            let from = row.index([0, y - y0, z]);
                            slab[(z * ny + y) * nx..][..nx]
                                .copy_from_slice(&row.label[from..from + nx]);
                        }
                    }
                }
                Ok(evaluated)
            },
        )
        .try_reduce(|| 0, |a, b| Ok(a + b))?;
    Ok(PruneStats {
        evaluated,
        voxels: grid.voxels_per_frame() as u64,
    })
}

/// Labels one row of top cells (y local 0..=`hi[0]`, z local 0..=`hi[1]`, at grid offsets
/// `origin`) into `row.label`. With `carry`, the row's y = 0 plane keeps the evaluated voxels
/// of the previous row's last plane (the same voxels), so shared faces are evaluated once.
/// Returns the number of evaluations.
#[allow(clippy::too_many_arguments)]
fn label_row(
    model: &Model,
    grid: &VoxelGrid,
    t: f64,
    safety: f32,
    metric: &Metric,
    row: &mut Row,
    origin: [usize; 2],
    hi: [usize; 2],
    carry: bool,
) -> Result<u64> {
    let nx = grid.dims[0];
    let plane = row.dims[0] * row.dims[1];
    for z in 0..=hi[1] {
        let start = z * plane;
        if carry {
            // The previous row's y = TOP plane is this row's y = 0 plane.
            let from = row.index([0, TOP, z]);
            row.state.copy_within(from..from + nx, start);
            row.label.copy_within(from..from + nx, start);
            row.radius.copy_within(from..from + nx, start);
            let keep = &mut row.state[start..start + nx];
            keep.iter_mut()
                .filter(|s| **s != EVALUATED)
                .for_each(|s| *s = UNSET);
            row.state[start + nx..start + plane].fill(UNSET);
        } else {
            row.state[start..start + plane].fill(UNSET);
        }
    }
    let mut cells: Vec<Cell> = (0..nx.max(2) - 1)
        .step_by(TOP)
        .map(|x0| Cell {
            lo: [x0, 0, 0],
            hi: [(x0 + TOP).min(nx - 1), hi[0], hi[1]],
        })
        .collect();
    let mut next = Vec::new();
    let mut finals = Vec::new();
    let mut evaluated = 0;
    while !cells.is_empty() {
        row.pending.clear();
        for cell in &cells {
            for c in cell.corners() {
                let i = row.index(c);
                if row.state[i] != EVALUATED && row.state[i] != QUEUED {
                    row.state[i] = QUEUED;
                    row.pending.push(i);
                }
            }
        }
        evaluated += row.pending.len() as u64;
        evaluate_pending(model, grid, t, row, origin)?;
        next.clear();
        for cell in &cells {
            let span = cell.span();
            if span.iter().all(|&s| s <= 1) {
                continue; // every voxel is a corner
            }
            let mut labels = cell.corners().map(|c| row.label[row.index(c)]);
            let w = labels.next().expect("a cell has a corner");
            let agree = labels.all(|l| l == w);
            let bound = safety as f64 * covering_radius(&grid.affine, span);
            let mut corners = [([0usize; 3], 0f32); 8];
            let mut n = 0;
            for c in cell.corners() {
                corners[n] = (c, row.radius[row.index(c)]);
                n += 1;
            }
            let certified = agree
                && corners[..n].iter().all(|&(_, rho)| rho as f64 > bound)
                && !steep(&corners[..n], metric, safety);
            if certified {
                for z in cell.lo[2]..=cell.hi[2] {
                    for y in cell.lo[1]..=cell.hi[1] {
                        let start = row.index([cell.lo[0], y, z]);
                        for i in start..=start + span[0] {
                            if row.state[i] == UNSET {
                                row.state[i] = FILLED;
                                row.label[i] = w;
                            }
                        }
                    }
                }
                continue;
            }
            if span.iter().all(|&s| s <= 2) {
                // The last level: each remaining voxel is one step from a corner, so it is
                // filled when a corner's ball certifies it (corners agreeing) and evaluated
                // otherwise, instead of splitting into eight cells of single voxels.
                finals.push(*cell);
                continue;
            }
            let halves = |a: usize| {
                let (lo, hi) = (cell.lo[a], cell.hi[a]);
                if hi - lo >= 2 {
                    let mid = lo + (hi - lo) / 2;
                    [(lo, mid), (mid, hi)].into_iter().take(2)
                } else {
                    [(lo, hi), (lo, hi)].into_iter().take(1)
                }
            };
            for (zl, zh) in halves(2) {
                for (yl, yh) in halves(1) {
                    for (xl, xh) in halves(0) {
                        next.push(Cell {
                            lo: [xl, yl, zl],
                            hi: [xh, yh, zh],
                        });
                    }
                }
            }
        }
        // The last level, in three stages: edge midpoints (one step from a corner), then face
        // centres (one step from an edge midpoint), then cell centres, each stage's voxels
        // certified by the points evaluated before it.
        for stage in 1..=3 {
            for cell in &finals {
                decide_voxels(row, metric, safety, cell, stage);
            }
            evaluated += row.pending.len() as u64;
            evaluate_pending(model, grid, t, row, origin)?;
        }
        finals.clear();
        std::mem::swap(&mut cells, &mut next);
    }
    Ok(evaluated)
}

/// World distances between voxels: a table for the steps of a last-level cell (each axis
/// −2..=2), where they are needed per voxel pair.
struct Metric {
    affine: [[f64; 4]; 3],
    near: [f64; 125],
}

impl Metric {
    fn new(affine: &[[f64; 4]; 3]) -> Metric {
        let mut near = [0.0; 125];
        for (i, d) in near.iter_mut().enumerate() {
            let step = [i % 5, i / 5 % 5, i / 25].map(|v| v as f64 - 2.0);
            *d = Self::compute(affine, step);
        }
        Metric {
            affine: *affine,
            near,
        }
    }

    fn compute(affine: &[[f64; 4]; 3], step: [f64; 3]) -> f64 {
        affine
            .iter()
            .map(|r| (r[0] * step[0] + r[1] * step[1] + r[2] * step[2]).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// World distance between voxels `a` and `b`.
    #[inline]
    fn distance(&self, a: [usize; 3], b: [usize; 3]) -> f64 {
        let step: [isize; 3] = std::array::from_fn(|i| a[i] as isize - b[i] as isize);
        if step.iter().all(|s| s.abs() <= 2) {
            self.near[((step[2] + 2) * 25 + (step[1] + 2) * 5 + step[0] + 2) as usize]
        } else {
            Self::compute(&self.affine, step.map(|v| v as f64))
        }
    }
}

/// True when two of `points` (voxel, ρ), all with the same label, show the field steeper than
/// the bound assumes: ρ is a minimum of (v_j − v_w)/(λ_j + λ_w), each s-Lipschitz when every
/// ‖∇f^k‖ ≤ s, so |ρ(a) − ρ(b)| > s·|a − b| cannot happen under the assumption.
fn steep(points: &[([usize; 3], f32)], metric: &Metric, safety: f32) -> bool {
    points.iter().enumerate().any(|(i, &(a, ra))| {
        points[i + 1..]
            .iter()
            .any(|&(b, rb)| (ra - rb).abs() as f64 > safety as f64 * metric.distance(a, b))
    })
}

/// Fills or queues the voxels of a last-level `cell` (spans ≤ 2) that lie mid-way along
/// `stage` of its axes (1: edge midpoints, 2: face centres, 3: the centre) and are not yet
/// evaluated or queued. A voxel is filled when every evaluated voxel of the cell has the same
/// label (the verification) and one of them certifies it (ρ/s beyond its distance); it is queued
/// for evaluation otherwise.
fn decide_voxels(row: &mut Row, metric: &Metric, safety: f32, cell: &Cell, stage: usize) {
    let mut known = [([0usize; 3], 0f32); 27];
    let mut n = 0;
    let mut agreed = None;
    let mut agree = true;
    let voxels = || {
        (cell.lo[2]..=cell.hi[2]).flat_map(move |z| {
            (cell.lo[1]..=cell.hi[1])
                .flat_map(move |y| (cell.lo[0]..=cell.hi[0]).map(move |x| [x, y, z]))
        })
    };
    for v in voxels() {
        let i = row.index(v);
        if row.state[i] == EVALUATED {
            known[n] = (v, row.radius[i]);
            n += 1;
            agree &= *agreed.get_or_insert(row.label[i]) == row.label[i];
        }
    }
    let agreed = agreed.filter(|_| agree && !steep(&known[..n], metric, safety));
    for v in voxels() {
        let mid = (0..3)
            .filter(|&a| v[a] != cell.lo[a] && v[a] != cell.hi[a])
            .count();
        let i = row.index(v);
        if mid != stage || row.state[i] == EVALUATED || row.state[i] == QUEUED {
            continue;
        }
        let certified = agreed.filter(|_| {
            known[..n]
                .iter()
                .any(|&(c, rho)| rho as f64 > safety as f64 * metric.distance(v, c))
        });
        match certified {
            Some(w) => {
                if row.state[i] == UNSET {
                    row.state[i] = FILLED;
                    row.label[i] = w;
                }
            }
            None => {
                row.state[i] = QUEUED;
                row.pending.push(i);
            }
        }
    }
}

/// Evaluates the queued voxels of `row`: label and certified radius.
fn evaluate_pending(
    model: &Model,
    grid: &VoxelGrid,
    t: f64,
    row: &mut Row,
    origin: [usize; 2],
) -> Result<()> {
    let k = model.num_classes();
    let times = [t as f32; CHUNK];
    let pending = std::mem::take(&mut row.pending);
    for batch in pending.chunks(CHUNK) {
        row.points.clear();
        for &i in batch {
            let x = i % row.dims[0];
            let y = i / row.dims[0] % row.dims[1] + origin[0];
            let z = i / (row.dims[0] * row.dims[1]) + origin[1];
            row.points.push(grid.world(x, y, z).map(|v| v as f32));
        }
        let n = batch.len();
        model
            .eval_batch(
                &mut row.scratch,
                &row.points,
                &times[..n],
                &mut row.f[..n * k],
            )
            .expect("buffers are sized to the batch");
        for (p, (&i, f)) in batch.iter().zip(row.f.chunks_exact(k)).enumerate() {
            let w = argmin_label(f);
            if w == UNDEFINED_LABEL {
                bail!(
                    "the model is not finite at {:?}, time {t}: no label",
                    row.points[p]
                );
            }
            row.state[i] = EVALUATED;
            row.label[i] = w;
            row.radius[i] = certified_radius(f, w);
        }
    }
    row.pending = pending;
    row.pending.clear();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::label_indices_with;
    use dynaslice_core::format::ModelWriter;
    use dynaslice_test_support::spheres::{self, Sphere};

    /// A grid with `dims` voxels whose axes are rotated, sheared and anisotropic, centred on
    /// `centre` and covering about `extent` world units along each axis.
    fn oblique(dims: [usize; 3], centre: [f64; 3], extent: f64, times: Vec<f64>) -> VoxelGrid {
        let (a, b) = (0.5f64, 0.3f64);
        let rot = [
            [a.cos(), -a.sin(), 0.0],
            [a.sin() * b.cos(), a.cos() * b.cos(), -b.sin()],
            [a.sin() * b.sin(), a.cos() * b.sin(), b.cos()],
        ];
        let spacing =
            [1.0, 1.3, 0.8].map(|s| s * extent / dims.iter().max().copied().unwrap() as f64);
        let mut affine = [[0.0; 4]; 3];
        for r in 0..3 {
            for c in 0..3 {
                // A shear of 0.2 of y into x's column keeps the axes non-orthogonal.
                let shear = if c == 1 { 0.2 * rot[r][0] } else { 0.0 };
                affine[r][c] = (rot[r][c] + shear) * spacing[c];
            }
            let half: f64 = (0..3)
                .map(|c| affine[r][c] * (dims[c] as f64 - 1.0) / 2.0)
                .sum();
            affine[r][3] = centre[r] - half;
        }
        VoxelGrid {
            dims,
            affine,
            times,
        }
    }

    fn compare(model: &Model, grid: &VoxelGrid, safety: f32) -> (u64, u64) {
        let n = grid.voxels_per_frame();
        let (mut dense, mut pruned) = (vec![0u32; n], vec![7u32; n]);
        let (mut evaluated, mut voxels) = (0, 0);
        for &t in &grid.times {
            label_indices_with(model, grid, t, Evaluation::Dense, &mut dense).unwrap();
            let s = label_indices_with(model, grid, t, Evaluation::Pruned { safety }, &mut pruned)
                .unwrap();
            let differ = dense.iter().zip(&pruned).filter(|(a, b)| a != b).count();
            assert_eq!(
                differ, 0,
                "{differ} of {n} voxels differ at t = {t}, safety {safety}, {grid:?}"
            );
            evaluated += s.evaluated;
            voxels += s.voxels;
        }
        (evaluated, voxels)
    }

    /// A deterministic stream of numbers in [0, 1).
    fn uniform(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Sphere models are a hard case for the bound: their quadratic fields are up to 3× steeper
    /// than distances in these grids, so only the verification keeps the labels exact. The
    /// spheres (radius 5 to 10 mm, grid spacing 0.9 to 2.8 mm) are at least as large as a top
    /// cell's half-side, the scale below which such a field can hide a whole region inside a
    /// cell (the residual risk in the module documentation).
    #[test]
    fn pruned_labels_equal_dense_on_random_sphere_models() {
        let mut seed = 7;
        let mut evaluated_total = 0;
        let mut voxels_total = 0;
        for case in 0..6 {
            let k = 1 + case % 4;
            let spheres: Vec<Sphere> = (0..k)
                .map(|_| {
                    let c = [0; 3].map(|_| 0.8 * uniform(&mut seed) - 0.4);
                    let r = 0.25 + 0.25 * uniform(&mut seed);
                    Sphere::new(c, r, 0.3 * uniform(&mut seed) - 0.1)
                })
                .collect();
            let names: Vec<(String, i32)> =
                (0..k).map(|c| (format!("c{c}"), c as i32 + 1)).collect();
            let names: Vec<(&str, i32)> = names.iter().map(|(n, l)| (n.as_str(), *l)).collect();
            let bytes = spheres::model(&spheres, &names);
            let model = Model::from_bytes(&bytes).unwrap();
            let dims = [
                [31, 27, 23],
                [17, 40, 9],
                [1, 33, 18],
                [25, 1, 1],
                [17, 15, 16],
                [41, 37, 19],
            ][case];
            let grid = oblique(dims, [10.0, -5.0, 2.0], 36.0, vec![0.0, 0.7, 2.0]);
            for safety in [1.0, DEFAULT_SAFETY, 3.0] {
                let (e, v) = compare(&model, &grid, safety);
                if safety == 3.0 {
                    evaluated_total += e;
                    voxels_total += v;
                }
            }
        }
        // The pruning has to prune where the field is within the safety factor of a distance:
        // these quadratic fields are up to 3× steeper, so at s = 3 most voxels far from every
        // boundary are filled (at s = 1.5 the steepness check refuses most cells).
        assert!(
            evaluated_total * 3 < voxels_total * 2,
            "{evaluated_total} evaluations for {voxels_total} voxels"
        );
    }

    #[test]
    fn pruned_labels_equal_dense_on_random_sirens() {
        for (case, k) in [1u32, 2, 5].into_iter().enumerate() {
            let model_bytes = ModelWriter::random_siren(&[16, 16], k, 11 + case as u64).to_bytes();
            let model = Model::from_bytes(&model_bytes).unwrap();
            let dims = [[19, 14, 11], [8, 21, 5], [12, 12, 13]][case];
            let grid = oblique(dims, [0.1, -0.2, 0.0], 1.6, vec![0.25, 0.5]);
            for safety in [1.0, DEFAULT_SAFETY] {
                compare(&model, &grid, safety);
            }
        }
    }

    #[test]
    fn covering_radius_is_half_the_longest_diagonal() {
        let mut affine = [[0.0; 4]; 3];
        (affine[0][0], affine[1][1], affine[2][2]) = (1.0, 2.0, 3.0);
        let r = covering_radius(&affine, [2, 1, 1]);
        assert!((r - 0.5 * (4.0f64 + 4.0 + 9.0).sqrt()).abs() < 1e-12);
        // A sheared cell: the longer of its diagonals counts.
        affine[0][1] = 1.0;
        let r = covering_radius(&affine, [1, 1, 0]);
        assert!((r - 0.5 * (4.0f64 + 4.0).sqrt()).abs() < 1e-12);
        assert_eq!(covering_radius(&affine, [0, 0, 0]), 0.0);
    }

    #[test]
    fn certified_radius_halves_class_gaps_and_not_background_gaps() {
        // Background wins: the nearest class is 0.4 away, one channel moves.
        assert_eq!(certified_radius(&[0.4, 0.9], 0), 0.4);
        // Class 2 wins over class 1 by 0.2 (both move) and over the background by 0.5.
        assert!((certified_radius(&[-0.3, -0.5], 2) - 0.1).abs() < 1e-7);
        assert_eq!(certified_radius(&[0.0], 0), 0.0);
    }

    #[test]
    fn bad_safety_factors_are_refused() {
        for safety in [0.5, f32::NAN, f32::INFINITY] {
            let e = Evaluation::Pruned { safety }.validate().unwrap_err();
            assert!(e.to_string().contains("safety factor"), "{e}");
        }
        assert!(Evaluation::Dense.validate().is_ok());
    }
}
