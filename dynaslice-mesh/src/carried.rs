//! Meshes in correspondence over a series: a motion model's surfaces at later times as the
//! first time's mesh carried by the motion, the same vertices and triangles at every time.
//!
//! A motion model is f(x, t) = g(x + u(x, t), t): the point x at time t is read from the shape
//! g at its canonical position y = x + u(x, t). A vertex x₀ of the first time's (marched) mesh
//! has the canonical position y = x₀ + u(x₀, t₀); at a later time t it is where the warp sends
//! the same canonical point, the x with x + u(x, t) = y. That x is found by the fixed point
//! x ← y − u(x, t), started from the vertex's position at the previous time (close to it, so a
//! few iterations converge: the error shrinks by the factor ‖J_u‖ each time). Where g does not
//! change with time, f(x, t) = g(y) = f(x₀, t₀) = 0 and the carried vertex is on the surface
//! already; g keeps a time input for shapes that really change, so a short Newton projection
//! along ∇ₓF puts it on the surface that marching would mesh at t (the same clipped field F of
//! the same [`Surfaces`](crate::Surfaces) mode, `field.rs`). The triangles are the first
//! time's, so every time has the same vertex count and faces, and each vertex's displacement
//! from the first time is a point-data array (`displacement`) a viewer can warp by.
//!
//! The carried mesh is refused, and the caller marches that time instead ([`Fallback`]), when
//! any vertex's fixed point does not converge, the warp folds there (det(I + J_u) ≤ 0: it is
//! not invertible, and the carried surface would turn inside out), the projection would move a
//! vertex farther than [`MAX_PROJECTION_CELLS`] of a lattice cell or does not reach the surface
//! (the shape itself changed more than the motion carries), a triangle turns over against the
//! field's normal where it agreed with it at the first time, or two vertices land on one f32
//! point (readers that weld by position would join them). These are local checks: a carried
//! surface that met itself far from any fold (two distant parts pushed together) is not
//! detected.

use crate::field::{LevelSets, Source};
use crate::geometry::Mesh;
use crate::vertices::normals_and_velocities;
use dynaslice_core::{Model, Scratch};
use rayon::prelude::*;
use std::fmt;

/// Fixed-point iterations at most per vertex and time. The error shrinks by about ‖J_u‖ per
/// iteration; a motion network's ‖J_u‖ is a strain, well below 1 where the warp is smooth.
pub const MAX_ITERATIONS: u32 = 50;

/// The fixed point has converged where an iteration moves the vertex by at most this fraction
/// of a lattice cell (or by 64 f32 ulps of its largest coordinate where that is more: the
/// network's own rounding).
pub const TOLERANCE_CELLS: f64 = 1e-4;

/// Newton steps of the projection onto F = 0 at most.
pub const PROJECTION_STEPS: u32 = 4;

/// The farthest the projection may move a carried vertex, in lattice cells: farther means the
/// shape changed (g's own time dependence) more than the motion carries it, and a projection
/// along ∇ₓF that long can pull neighbours across each other.
pub const MAX_PROJECTION_CELLS: f64 = 0.5;

/// The projection has reached the surface where |F| / ‖∇ₓF‖ is at most this fraction of a cell
/// (marching's own vertices, one Newton step along their lattice edges, are within 10⁻² of a
/// cell: `docs/meshing.md`).
pub const SURFACE_CELLS: f64 = 1e-3;

/// Central-difference step for J_u, in lattice cells (the core gives u, not its derivatives).
const JACOBIAN_STEP_CELLS: f64 = 1e-2;

/// Points per parallel task, as the field's.
const TASK_POINTS: usize = 2048;

/// Why a time of a carried series was marched instead, with how many vertices (or triangles)
/// failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fallback {
    /// The fixed point x ← y − u(x, t) did not converge in [`MAX_ITERATIONS`].
    NotConverged {
        /// Vertices that did not converge.
        vertices: usize,
    },
    /// det(I + J_u) ≤ 0 at the solution: the warp folds there.
    Folded {
        /// Vertices where it folds.
        vertices: usize,
    },
    /// The projection onto F = 0 would move a vertex farther than [`MAX_PROJECTION_CELLS`]
    /// along its Newton path, or did not reach the surface (a vanishing gradient included).
    Projection {
        /// Vertices that failed.
        vertices: usize,
        /// The longest Newton path asked for (steps taken plus the next), in cells.
        farthest_cells: f64,
    },
    /// Triangles that agreed with the field's normals at the first time point against them.
    Flipped {
        /// Triangles turned over.
        triangles: usize,
    },
    /// Vertices that landed on another vertex's f32 position.
    Merged {
        /// Vertices lost to a merge.
        vertices: usize,
    },
}

impl fmt::Display for Fallback {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fallback::NotConverged { vertices } => write!(
                f,
                "the inverse of the motion did not converge at {vertices} vertices"
            ),
            Fallback::Folded { vertices } => write!(
                f,
                "the motion folds (det(I + J_u) ≤ 0) at {vertices} vertices"
            ),
            Fallback::Projection {
                vertices,
                farthest_cells,
            } => write!(
                f,
                "the shape changed more than the motion carries at {vertices} vertices \
                 (projection of up to {farthest_cells:.2} cells, limit {MAX_PROJECTION_CELLS})"
            ),
            Fallback::Flipped { triangles } => {
                write!(f, "{triangles} triangles turned over")
            }
            Fallback::Merged { vertices } => {
                write!(f, "{vertices} vertices landed on others")
            }
        }
    }
}

/// How a carried mesh came out (for the log).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CarryReport {
    /// The most fixed-point iterations any vertex took.
    pub iterations: u32,
    /// The farthest projection onto the surface, in cells.
    pub farthest_cells: f64,
    /// The largest |F| / ‖∇ₓF‖ left at a vertex, in world units.
    pub distance: f64,
    /// Displacement evaluations (the fixed point and J_u).
    pub displacement_evaluations: u64,
    /// Jacobian evaluations of the field (projection, normals, normal velocity).
    pub jacobian_evaluations: u64,
}

/// One class's mesh at the first time of a series, and its vertices' canonical positions,
/// carried to later times by [`Carrier::carry`].
pub struct Carrier {
    reference: Mesh,
    /// y = x₀ + u(x₀, t₀) per vertex (f64: the sum is exact enough to invert to f32 rounding).
    canonical: Vec<[f64; 3]>,
    /// Each vertex's solution of x + u(x, t) = y at the last time carried (x₀ at first): where
    /// the next time's fixed point starts.
    start: Vec<[f32; 3]>,
    /// Whether each triangle agreed with the field's normals at the first time.
    agreed: Vec<bool>,
}

impl Carrier {
    /// The carrier of `marched`, a class's mesh of `model` (a motion model) at world time `t0`
    /// as marching made it, `field` the class's field F at `t0` (channel `channel`), `h` the
    /// lattice cell. Its vertices are first projected onto F = 0 as every later time's are
    /// (marching leaves them up to about 10⁻² of a cell off, farther where its one Newton step
    /// along the edge fell back to bisection), so that the displacements are the motion alone,
    /// not that settling; where the projection is refused the marched mesh is kept as it is.
    pub fn new<'m>(
        model: &Model<'m>,
        marched: Mesh,
        field: &LevelSets<Model<'m>>,
        channel: usize,
        h: f64,
        t0: f32,
    ) -> Carrier {
        let agreed: Vec<bool> =
            orientation(&marched.positions, &marched.triangles, &marched.normals)
                .into_iter()
                .map(|d| d > 0.0)
                .collect();
        let mut report = CarryReport::default();
        let reference = settle(
            field,
            channel,
            &marched.positions,
            &marched.triangles,
            &agreed,
            h,
            &mut report,
        )
        .unwrap_or(marched);
        let u = par_displacement(model, &reference.positions, t0);
        let canonical = reference
            .positions
            .iter()
            .zip(&u)
            .map(|(x, u)| std::array::from_fn(|a| f64::from(x[a]) + f64::from(u[a])))
            .collect();
        Carrier {
            start: reference.positions.clone(),
            reference,
            canonical,
            agreed,
        }
    }

    /// The first time's mesh, with a zero displacement on every vertex.
    pub fn reference(&self) -> Mesh {
        Mesh {
            displacement: vec![[0.0; 3]; self.reference.positions.len()],
            ..self.reference.clone()
        }
    }

    /// The mesh carried to the time of `field` (the class's clipped field F at that time,
    /// channel `channel`, as marching builds it), `h` the lattice cell: the first time's
    /// triangles, each vertex solved from x + u(x, t) = y and projected onto F = 0, with its
    /// normal, normal velocity and displacement from the first time; or a [`Fallback`] where
    /// any check fails (the module documentation), and the next call then starts from the last
    /// time that succeeded. With what it found and cost, either way.
    pub fn carry<'m>(
        &mut self,
        model: &Model<'m>,
        field: &LevelSets<Model<'m>>,
        channel: usize,
        h: f64,
        t: f32,
    ) -> (Result<Mesh, Fallback>, CarryReport) {
        let mut report = CarryReport::default();
        let mesh = self.try_carry(model, field, channel, h, t, &mut report);
        (mesh, report)
    }

    fn try_carry<'m>(
        &mut self,
        model: &Model<'m>,
        field: &LevelSets<Model<'m>>,
        channel: usize,
        h: f64,
        t: f32,
        report: &mut CarryReport,
    ) -> Result<Mesh, Fallback> {
        let inverse = self.invert(model, t, h, report)?;
        let folded = par_fold_count(model, &inverse, t, h);
        report.displacement_evaluations += 6 * inverse.len() as u64;
        if folded > 0 {
            return Err(Fallback::Folded { vertices: folded });
        }
        let mut mesh = settle(
            field,
            channel,
            &inverse,
            &self.reference.triangles,
            &self.agreed,
            h,
            report,
        )?;
        mesh.displacement = mesh
            .positions
            .iter()
            .zip(&self.reference.positions)
            .map(|(p, p0)| std::array::from_fn(|a| p[a] - p0[a]))
            .collect();
        self.start = inverse;
        Ok(mesh)
    }

    /// Solves x + u(x, t) = y for every vertex by the fixed point x ← y − u(x, t), from
    /// `self.start`; only vertices not yet converged are evaluated again.
    fn invert(
        &self,
        model: &Model,
        t: f32,
        h: f64,
        report: &mut CarryReport,
    ) -> Result<Vec<[f32; 3]>, Fallback> {
        let mut x = self.start.clone();
        let mut open: Vec<usize> = (0..x.len()).collect();
        let mut points = Vec::new();
        for iteration in 1..=MAX_ITERATIONS {
            if open.is_empty() {
                break;
            }
            report.iterations = iteration;
            points.clear();
            points.extend(open.iter().map(|&i| x[i]));
            let u = par_displacement(model, &points, t);
            report.displacement_evaluations += points.len() as u64;
            let mut still = Vec::new();
            for (&i, u) in open.iter().zip(&u) {
                let y = self.canonical[i];
                let next: [f32; 3] = std::array::from_fn(|a| (y[a] - f64::from(u[a])) as f32);
                let step = distance(next, x[i]);
                let reach = x[i].iter().chain(&next).fold(0.0f32, |m, v| m.max(v.abs()));
                let tolerance = (TOLERANCE_CELLS * h).max(64.0 * f64::from(reach * f32::EPSILON));
                x[i] = next;
                if !within(step, tolerance) {
                    still.push(i);
                }
            }
            open = still;
        }
        if open.is_empty() {
            Ok(x)
        } else {
            Err(Fallback::NotConverged {
                vertices: open.len(),
            })
        }
    }
}

/// The mesh of `triangles` on `start` projected onto F = 0 ([`project`]), with its normals and
/// normal velocities, refused where a triangle that agreed with the field's normals at the
/// first time (`agreed`) no longer does, or where two vertices land on one f32 point.
fn settle<S: Source>(
    field: &LevelSets<S>,
    channel: usize,
    start: &[[f32; 3]],
    triangles: &[[u32; 3]],
    agreed: &[bool],
    h: f64,
    report: &mut CarryReport,
) -> Result<Mesh, Fallback> {
    let (positions, normals, normal_velocity) = project(field, channel, start, h, report)?;
    let flipped = orientation(&positions, triangles, &normals)
        .iter()
        .zip(agreed)
        .filter(|&(&d, &agreed)| agreed && d <= 0.0)
        .count();
    if flipped > 0 {
        return Err(Fallback::Flipped { triangles: flipped });
    }
    let mesh = Mesh {
        positions,
        triangles: triangles.to_vec(),
        normals,
        normal_velocity,
        displacement: Vec::new(),
    };
    let merged = mesh.positions.len() - mesh.welded().positions.len();
    if merged > 0 {
        return Err(Fallback::Merged { vertices: merged });
    }
    Ok(mesh)
}

/// Safeguarded Newton steps x ← x − F ∇F / ‖∇F‖² on channel `channel` of `field` from each
/// of `start` (at most [`PROJECTION_STEPS`], until every |F| / ‖∇F‖ ≤ [`SURFACE_CELLS`] of a
/// cell), then the normals and normal velocities at the positions reached, from the same
/// evaluation.
#[allow(clippy::type_complexity)]
fn project<S: Source>(
    field: &LevelSets<S>,
    channel: usize,
    start: &[[f32; 3]],
    h: f64,
    report: &mut CarryReport,
) -> Result<(Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>), Fallback> {
    let mut positions = start.to_vec();
    let surface = SURFACE_CELLS * h;
    let mut step = 0;
    let (grad, dfdt) = loop {
        let (value, grad, dfdt) = field.par_jacobians(&positions, channel);
        report.jacobian_evaluations += positions.len() as u64;
        // Per vertex, |F| / ‖∇F‖ (the next Newton step's length) and the path so far plus that
        // step, in cells. A vertex whose path would pass the limit fails now: the evaluations
        // left would not bring it back (a shape that changed by several cells sends Newton
        // far off, which used to cost every remaining step first).
        let (mut failed, mut farthest, mut worst, mut done) = (0, 0.0f64, 0.0f64, true);
        for i in 0..positions.len() {
            let off = f64::from(value[i]).abs() / norm(grad[i]);
            let reach = distance(positions[i], start[i]) / h + off / h;
            farthest = farthest.max(reach);
            let last = step == PROJECTION_STEPS;
            // A NaN (no gradient, a non-finite value) fails too.
            if !within(reach, MAX_PROJECTION_CELLS) || (last && !within(off, 10.0 * surface)) {
                failed += 1;
            } else {
                worst = worst.max(off);
                done &= off <= surface;
            }
        }
        report.farthest_cells = farthest;
        report.distance = worst;
        if failed > 0 {
            return Err(Fallback::Projection {
                vertices: failed,
                farthest_cells: farthest,
            });
        }
        if done || step == PROJECTION_STEPS {
            break (grad, dfdt);
        }
        step += 1;
        for (i, p) in positions.iter_mut().enumerate() {
            let g = grad[i].map(f64::from);
            let g2 = g.iter().map(|v| v * v).sum::<f64>();
            if f64::from(value[i]).abs() > surface * g2.sqrt() {
                let s = f64::from(value[i]) / g2;
                *p = std::array::from_fn(|a| (f64::from(p[a]) - s * g[a]) as f32);
            }
        }
    };
    // As a marched mesh's (`vertices::refine`).
    let (normals, normal_velocity) = normals_and_velocities(&grad, &dfdt);
    Ok((positions, normals, normal_velocity))
}

/// u(x, t) at every point, in parallel.
fn par_displacement(model: &Model, points: &[[f32; 3]], t: f32) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; points.len()];
    points
        .par_chunks(TASK_POINTS)
        .zip(out.par_chunks_mut(TASK_POINTS))
        .for_each_init(
            || (Scratch::boxed(), Vec::new()),
            |(scratch, times), (p, o)| {
                times.clear();
                times.resize(p.len(), t);
                model
                    .displacement_batch(scratch, p, times, o)
                    .expect("buffers are sized to the batch");
            },
        );
    out
}

/// How many of `points` have det(I + J_u) ≤ 0 (or not finite) at time `t`, J_u by central
/// differences of step [`JACOBIAN_STEP_CELLS`] of a cell (`h`).
fn par_fold_count(model: &Model, points: &[[f32; 3]], t: f32, h: f64) -> usize {
    let delta = JACOBIAN_STEP_CELLS * h;
    // Six neighbours per point, ±δ along each axis; the steps actually taken (after f32
    // rounding) divide the differences.
    let mut probes = Vec::with_capacity(6 * points.len());
    for p in points {
        for a in 0..3 {
            for sign in [1.0, -1.0] {
                let mut q = *p;
                q[a] = (f64::from(q[a]) + sign * delta) as f32;
                probes.push(q);
            }
        }
    }
    let u = par_displacement(model, &probes, t);
    (0..points.len())
        .filter(|&i| {
            let mut m = [[0.0f64; 3]; 3];
            for b in 0..3 {
                let (plus, minus) = (6 * i + 2 * b, 6 * i + 2 * b + 1);
                let step = f64::from(probes[plus][b]) - f64::from(probes[minus][b]);
                for a in 0..3 {
                    let du = f64::from(u[plus][a]) - f64::from(u[minus][a]);
                    m[a][b] = f64::from(u8::from(a == b)) + du / step;
                }
            }
            let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
            det.is_nan() || det <= 0.0
        })
        .count()
}

/// Per triangle, its normal (b − a) × (c − a) dotted with the sum of its vertices' normals:
/// positive where the winding agrees with the field's outward normal.
fn orientation(positions: &[[f32; 3]], triangles: &[[u32; 3]], normals: &[[f32; 3]]) -> Vec<f64> {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize].map(f64::from));
            let e1: [f64; 3] = std::array::from_fn(|k| b[k] - a[k]);
            let e2: [f64; 3] = std::array::from_fn(|k| c[k] - a[k]);
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            let m: [f64; 3] = std::array::from_fn(|k| {
                t.iter()
                    .map(|&i| normals.get(i as usize).map_or(0.0, |v| f64::from(v[k])))
                    .sum()
            });
            n[0] * m[0] + n[1] * m[1] + n[2] * m[2]
        })
        .collect()
}

/// `value ≤ limit`, false where either is NaN (a failed evaluation fails the check).
fn within(value: f64, limit: f64) -> bool {
    value <= limit
}

fn distance(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3)
        .map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn norm(g: [f32; 3]) -> f64 {
    g.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>().sqrt()
}
