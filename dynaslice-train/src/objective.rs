//! The loss and its exact parameter gradient over one batch of samples, split across threads.
//!
//! Each set is cut into as many contiguous chunks as there are workers; worker i runs chunk i
//! of every set with its own buffers and gradient, and the partial gradients are summed in
//! worker order. The result is therefore deterministic for a given thread count.

use super::loss::{self, ContourSample, LossTerms, LossWeights, PlaneSample};
use super::network::Network;
use super::passes::{Tangents, Workspace, INPUT_DIM};
use super::reverse_over_reverse::ReverseWorkspace;
use super::warp::{self, WarpWorkspace};
use rayon::prelude::*;

/// How space-time samples, which need f and the whole ∇ₓf of every channel (Eq. 8), get their
/// exact parameter gradient. Both schemes give the same gradient up to rounding; they differ in
/// cost, counted in M (one layer's matrix product over the set's points).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpaceTimeScheme {
    /// Three forward tangents, then one backward through primal and tangents
    /// ([`super::passes`]): 12M whatever K is.
    ForwardTangents,
    /// A forward, a backward per channel for ∇ₓf^k, then the reverse of both
    /// ([`super::reverse_over_reverse`]): (3 + 3K)M.
    ReverseOverReverse,
}

impl SpaceTimeScheme {
    /// Matrix-product cost per point in units of one layer's product (see the variants).
    pub fn cost(self, num_classes: usize) -> usize {
        match self {
            SpaceTimeScheme::ForwardTangents => 12,
            SpaceTimeScheme::ReverseOverReverse => 3 + 3 * num_classes,
        }
    }

    /// The cheaper scheme for K classes: reverse over reverse for K ≤ 2 (6M and 9M against
    /// 12M), forward tangents from K = 3 on (a tie at 3, where one stacked pass needs less
    /// memory; 4x cheaper at the multi-organ K = 8–40).
    pub fn cheapest(num_classes: usize) -> SpaceTimeScheme {
        let reverse = SpaceTimeScheme::ReverseOverReverse;
        let tangents = SpaceTimeScheme::ForwardTangents;
        if reverse.cost(num_classes) < tangents.cost(num_classes) {
            reverse
        } else {
            tangents
        }
    }
}

/// The space-time buffers of one worker, for the scheme in use.
enum SpaceTimeWorkspace {
    Tangents(Workspace),
    Reverse(ReverseWorkspace),
}

impl SpaceTimeWorkspace {
    /// f and ∇ₓf of every channel at `x`, stacked as [F; ∂F/∂x; ∂F/∂y; ∂F/∂z].
    fn forward(&mut self, net: &Network, x: &[[f32; INPUT_DIM]]) -> &[f32] {
        match self {
            SpaceTimeWorkspace::Tangents(ws) => {
                ws.forward(net, x, Tangents::Axes);
                ws.outputs(x.len())
            }
            SpaceTimeWorkspace::Reverse(ws) => {
                ws.forward(net, x);
                ws.outputs(x.len())
            }
        }
    }

    /// Adds the parameter gradient of the last forward, given ∂loss/∂outputs, to `grad`.
    fn backward(&mut self, net: &Network, x: &[[f32; INPUT_DIM]], g_out: &[f32], grad: &mut [f32]) {
        match self {
            SpaceTimeWorkspace::Tangents(ws) => ws.backward(net, x, Tangents::Axes, g_out, grad),
            SpaceTimeWorkspace::Reverse(ws) => ws.backward(net, x, g_out, grad),
        }
    }
}

/// The samples of one optimisation step, in the network's normalised frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Batch {
    /// Contour points (x, y, z, t).
    pub contour_x: Vec<[f32; INPUT_DIM]>,
    /// Their outward in-plane unit normals (the direction of Eq. 6's derivative).
    pub contour_normal: Vec<[f32; 3]>,
    /// Their class and weight.
    pub contour: Vec<ContourSample>,
    /// Plane samples (x, y, z, t).
    pub plane_x: Vec<[f32; INPUT_DIM]>,
    /// Their class, target and weight.
    pub plane: Vec<PlaneSample>,
    /// Space-time samples (x, y, z, t); each weighs 1/len.
    pub space_x: Vec<[f32; INPUT_DIM]>,
    /// Each space-time sample's lower bound of every channel, point-major (`[i·K + k]`; −∞: no
    /// bound): the signed distance of the class's extent ([`crate::extent_bound`]); empty where
    /// no extent applies.
    pub space_floor: Vec<f32>,
}

struct Worker {
    directional: Workspace,
    space_time: SpaceTimeWorkspace,
    plain: Workspace,
    motion: Option<MotionWorkspaces>,
    g_out: Vec<f32>,
    grad: Vec<f32>,
    terms: LossTerms,
}

/// One of u's regulariser terms: its loss and output adjoint from u's stacked outputs, each
/// point weighing the given weight (`warp::regulariser`, `warp::velocity`).
type MotionTerm = fn(&[f32], f32, &mut [f32]) -> LossTerms;

/// A motion model's extra buffers per worker: u's passes under the contour and plane sets, and
/// its regulariser's pass (three tangents, for J_u) on the space-time samples.
struct MotionWorkspaces {
    contour: WarpWorkspace,
    plane: WarpWorkspace,
    strain: Workspace,
    g_strain: Vec<f32>,
    velocity: Workspace,
    g_velocity: Vec<f32>,
}

/// Per-thread buffers for evaluating the loss; allocated once for the largest batch.
pub struct Objective {
    workers: Vec<Worker>,
}

fn chunk(len: usize, parts: usize, i: usize) -> std::ops::Range<usize> {
    (len * i / parts)..(len * (i + 1) / parts)
}

impl Objective {
    /// Buffers for `workers` threads and batches of at most `max_set` samples per set, with the
    /// cheapest space-time scheme for the network's K ([`SpaceTimeScheme::cheapest`]).
    pub fn new(net: &Network, workers: usize, max_set: usize) -> Objective {
        let scheme = SpaceTimeScheme::cheapest(net.layout.num_classes());
        Objective::with_scheme(net, workers, max_set, scheme)
    }

    /// As [`Objective::new`], with the given space-time scheme (for benchmarks and tests).
    pub fn with_scheme(
        net: &Network,
        workers: usize,
        max_set: usize,
        scheme: SpaceTimeScheme,
    ) -> Objective {
        let workers = workers.max(1);
        let cap = max_set.div_ceil(workers).max(1);
        let k = net.layout.num_classes();
        let workers = (0..workers)
            .map(|_| Worker {
                directional: Workspace::new(net, cap, 1),
                space_time: match scheme {
                    SpaceTimeScheme::ForwardTangents => {
                        SpaceTimeWorkspace::Tangents(Workspace::new(net, cap, 3))
                    }
                    SpaceTimeScheme::ReverseOverReverse => {
                        SpaceTimeWorkspace::Reverse(ReverseWorkspace::new(net, cap))
                    }
                },
                plain: Workspace::new(net, cap, 0),
                motion: net.motion.as_deref().map(|m| MotionWorkspaces {
                    contour: WarpWorkspace::new(m, cap, true),
                    plane: WarpWorkspace::new(m, cap, false),
                    strain: Workspace::new(m, cap, 3),
                    g_strain: vec![0.0; 12 * cap],
                    velocity: Workspace::new(m, cap, 1),
                    g_velocity: vec![0.0; 6 * cap],
                }),
                g_out: vec![0.0; 4 * cap * k],
                grad: vec![0.0; net.all_params_len()],
                terms: LossTerms::default(),
            })
            .collect();
        Objective { workers }
    }

    /// Contour points of the last [`Objective::evaluate`] whose orientation hinge was active,
    /// i.e. whose tangent rows its backward pass carried (see [`Workspace::backward`]).
    pub fn active_contour_points(&self) -> usize {
        self.workers
            .iter()
            .map(|w| w.directional.kept_points())
            .sum()
    }

    /// Loss terms of `batch`, and the gradient of the weighted total written to `grad` (every
    /// trained parameter, laid out as [`Network::all_params`]). Runs on the current rayon pool.
    pub fn evaluate(
        &mut self,
        net: &Network,
        batch: &Batch,
        weights: &LossWeights,
        grad: &mut [f32],
    ) -> LossTerms {
        let parts = self.workers.len();
        let k = net.layout.num_classes();
        let space_weight = 1.0 / batch.space_x.len().max(1) as f32;
        let shape_len = net.params.len();
        self.workers.par_iter_mut().enumerate().for_each(|(i, w)| {
            w.grad.fill(0.0);
            w.terms = LossTerms::default();
            let (shape_grad, motion_grad) = w.grad.split_at_mut(shape_len);
            let c = chunk(batch.contour_x.len(), parts, i);
            if !c.is_empty() {
                let x = &batch.contour_x[c.clone()];
                let normals = &batch.contour_normal[c.clone()];
                // With motion, g is evaluated at y = x + u along m = n + J_u n (see `warp`).
                let (y, m) = match (&mut w.motion, net.motion.as_deref()) {
                    (Some(ws), Some(motion)) => ws.contour.forward(motion, x, Some(normals)),
                    _ => (x, normals),
                };
                let along = Tangents::Along(m);
                w.directional.forward(net, y, along);
                let out = w.directional.outputs(x.len());
                let t = loss::contour(out, k, &batch.contour[c], weights, &mut w.g_out);
                w.terms.add(&t);
                w.directional.backward(net, y, along, &w.g_out, shape_grad);
                if let (Some(ws), Some(motion)) = (&mut w.motion, net.motion.as_deref()) {
                    let pass = &w.directional;
                    ws.contour
                        .backward(motion, net, pass, x, Some(normals), motion_grad);
                }
            }
            let c = chunk(batch.plane_x.len(), parts, i);
            if !c.is_empty() {
                let x = &batch.plane_x[c.clone()];
                let y = match (&mut w.motion, net.motion.as_deref()) {
                    (Some(ws), Some(motion)) => ws.plane.forward(motion, x, None).0,
                    _ => x,
                };
                w.plain.forward(net, y, Tangents::None);
                let out = w.plain.outputs(x.len());
                let t = loss::plane(out, k, &batch.plane[c], weights, &mut w.g_out);
                w.terms.add(&t);
                w.plain
                    .backward(net, y, Tangents::None, &w.g_out, shape_grad);
                if let (Some(ws), Some(motion)) = (&mut w.motion, net.motion.as_deref()) {
                    ws.plane
                        .backward(motion, net, &w.plain, x, None, motion_grad);
                }
            }
            let c = chunk(batch.space_x.len(), parts, i);
            if !c.is_empty() {
                let floor = batch
                    .space_floor
                    .get(c.start * k..c.end * k)
                    .unwrap_or_default();
                let x = &batch.space_x[c];
                // Space-time samples are canonical points of the shape g (see `warp`).
                let out = w.space_time.forward(net, x);
                let t = loss::space_time(out, k, floor, space_weight, weights, &mut w.g_out);
                w.terms.add(&t);
                w.space_time.backward(net, x, &w.g_out, shape_grad);
                if let (Some(ws), Some(motion)) = (&mut w.motion, net.motion.as_deref()) {
                    // u's regulariser: its Jacobian (strain, folds), then its velocity.
                    let passes: [(_, _, MotionTerm, _); 2] = [
                        (
                            &mut ws.strain,
                            Tangents::Axes,
                            warp::regulariser,
                            &mut ws.g_strain,
                        ),
                        (
                            &mut ws.velocity,
                            Tangents::Time,
                            warp::velocity,
                            &mut ws.g_velocity,
                        ),
                    ];
                    for (pass, tangents, term, g) in passes {
                        pass.forward(motion, x, tangents);
                        let t = term(pass.outputs(x.len()), space_weight, g);
                        w.terms.add(&t);
                        pass.backward(motion, x, tangents, g, motion_grad);
                    }
                }
            }
        });
        grad.fill(0.0);
        let mut terms = LossTerms::default();
        for w in &self.workers {
            grad.iter_mut().zip(&w.grad).for_each(|(a, b)| *a += b);
            terms.add(&w.terms);
        }
        terms
    }
}
