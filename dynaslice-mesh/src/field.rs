//! What is meshed: the K raw channels of a model (or of any other [`Source`]) turned into one
//! scalar field per extracted surface, F_c(x) at a fixed time, negative inside.
//!
//! - [`Surfaces::Overlapping`]: F = f^k, each class's own zero-level set; classes may overlap.
//! - [`Surfaces::Partition`]: F = g_k = f^k − min(min_{j≠k} f^j, 0), negative exactly where
//!   Eq. 11 labels a point k, so adjacent classes share their boundary (f^k = f^j there).
//!
//! Either is then clipped to a box, F = max(F, b) with b the signed distance to the box, so a
//! surface leaving the lattice is closed by a cap instead of left open.

use dynaslice_core::{Model, Scratch};
use rayon::prelude::*;

/// A field with K channels that the extractor can evaluate in batches: a trained [`Model`], or
/// an analytic field in tests. Implementations must be deterministic per point (the result for
/// a point must not depend on the batch it is in), which keeps sparse and dense extraction
/// identical.
pub trait Source: Sync {
    /// Per-thread working memory.
    type Scratch: Send;
    /// A fresh scratch.
    fn scratch(&self) -> Self::Scratch;
    /// K, the number of channels.
    fn num_classes(&self) -> usize;
    /// f at `xyz` and time `t` into `f` (`xyz.len() · K`, row-major).
    fn eval(&self, scratch: &mut Self::Scratch, xyz: &[[f32; 3]], t: f32, f: &mut [f32]);
    /// f, ∇ₓf and ∂f/∂t at `xyz` (each `xyz.len() · K`, row-major).
    fn eval_jacobian(
        &self,
        scratch: &mut Self::Scratch,
        xyz: &[[f32; 3]],
        t: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    );
}

/// A field known in closed form, one point and channel at a time: the synthetic benchmark's exact
/// shapes, the analytic fields of tests. Every such field is a [`Source`] with no scratch.
pub trait PointField: Sync {
    /// K, the number of channels.
    fn num_classes(&self) -> usize;
    /// f of channel `class` at `p`, time `t`.
    fn value(&self, class: usize, p: [f32; 3], t: f32) -> f32;
    /// f, ∇ₓf and ∂f/∂t of channel `class` at `p`, time `t`.
    fn jet(&self, class: usize, p: [f32; 3], t: f32) -> (f32, [f32; 3], f32);
}

impl<F: PointField> Source for F {
    type Scratch = ();

    fn scratch(&self) {}

    fn num_classes(&self) -> usize {
        PointField::num_classes(self)
    }

    fn eval(&self, _: &mut (), xyz: &[[f32; 3]], t: f32, f: &mut [f32]) {
        let k = PointField::num_classes(self);
        for (i, &p) in xyz.iter().enumerate() {
            for c in 0..k {
                f[i * k + c] = self.value(c, p, t);
            }
        }
    }

    fn eval_jacobian(
        &self,
        _: &mut (),
        xyz: &[[f32; 3]],
        t: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) {
        let k = PointField::num_classes(self);
        for (i, &p) in xyz.iter().enumerate() {
            for c in 0..k {
                (f[i * k + c], grad[i * k + c], dfdt[i * k + c]) = self.jet(c, p, t);
            }
        }
    }
}

/// A model's scratch and the per-point time column its batch functions read.
pub struct ModelScratch {
    scratch: Box<Scratch>,
    times: Vec<f32>,
}

impl Source for Model<'_> {
    type Scratch = ModelScratch;

    fn scratch(&self) -> ModelScratch {
        ModelScratch {
            scratch: Scratch::boxed(),
            times: Vec::new(),
        }
    }

    fn num_classes(&self) -> usize {
        Model::num_classes(self)
    }

    fn eval(&self, s: &mut ModelScratch, xyz: &[[f32; 3]], t: f32, f: &mut [f32]) {
        s.times.clear();
        s.times.resize(xyz.len(), t);
        // The extractor sizes every buffer from the batch, the only thing the core checks.
        self.eval_batch(&mut s.scratch, xyz, &s.times, f)
            .expect("mesh buffers are sized to the batch");
    }

    fn eval_jacobian(
        &self,
        s: &mut ModelScratch,
        xyz: &[[f32; 3]],
        t: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) {
        s.times.clear();
        s.times.resize(xyz.len(), t);
        self.eval_jacobian_batch(&mut s.scratch, xyz, &s.times, f, grad, dfdt)
            .expect("mesh buffers are sized to the batch");
    }
}

/// Which surfaces of a multi-class model are extracted (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surfaces {
    /// Each class's own zero-level set f^k = 0; overlapping classes give overlapping meshes.
    Overlapping,
    /// The boundaries of the Eq. 11 partition: non-overlapping, neighbours share boundaries.
    Partition,
}

/// The scalar fields F_c of some classes of a [`Source`] at one time, clipped to a box.
pub struct LevelSets<'a, S: Source> {
    source: &'a S,
    time: f32,
    classes: Vec<usize>,
    surfaces: Surfaces,
    clip: ([f32; 3], [f32; 3]),
}

/// Working memory of [`LevelSets`]: the source's scratch and its raw K-channel outputs.
pub struct LevelScratch<T> {
    source: T,
    f: Vec<f32>,
    grad: Vec<[f32; 3]>,
    dfdt: Vec<f32>,
}

/// Points per parallel task: large enough to amortise a scratch (≈ 330 KiB for a model), small
/// enough that both cores stay busy to the end.
const TASK_POINTS: usize = 2048;

impl<'a, S: Source> LevelSets<'a, S> {
    /// The surfaces of `classes` (0-based channel indices, each < K) of `source` at world time
    /// `time`, clipped to the box `clip`.
    pub fn new(
        source: &'a S,
        time: f32,
        classes: Vec<usize>,
        surfaces: Surfaces,
        clip: ([f32; 3], [f32; 3]),
    ) -> Self {
        assert!(
            classes.iter().all(|&k| k < source.num_classes()),
            "class index out of range"
        );
        LevelSets {
            source,
            time,
            classes,
            surfaces,
            clip,
        }
    }

    /// Number of fields (one per extracted class).
    pub fn channels(&self) -> usize {
        self.classes.len()
    }

    /// A bound on ‖∇F‖ when every f^k is an exact SDF: 1 for one class's distance, 2 for the
    /// partition field (a difference of two distances). The pruning bound is scaled by it.
    pub fn lipschitz(&self) -> f32 {
        match self.surfaces {
            Surfaces::Overlapping => 1.0,
            Surfaces::Partition => 2.0,
        }
    }

    /// A fresh scratch for [`LevelSets::values`] and [`LevelSets::jacobians`].
    pub fn scratch(&self) -> LevelScratch<S::Scratch> {
        LevelScratch {
            source: self.source.scratch(),
            f: Vec::new(),
            grad: Vec::new(),
            dfdt: Vec::new(),
        }
    }

    /// F at `points` into `out` (`points.len() · channels()`, row-major).
    pub fn values(&self, s: &mut LevelScratch<S::Scratch>, points: &[[f32; 3]], out: &mut [f32]) {
        let k = self.source.num_classes();
        s.f.resize(points.len() * k, 0.0);
        self.source.eval(&mut s.source, points, self.time, &mut s.f);
        let c = self.channels();
        for (i, p) in points.iter().enumerate() {
            let f = &s.f[i * k..(i + 1) * k];
            let box_distance = box_sdf(*p, self.clip).0;
            for (ch, &class) in self.classes.iter().enumerate() {
                let (other, _) = self.subtrahend(f, class);
                out[i * c + ch] = (f[class] - other).max(box_distance);
            }
        }
    }

    /// F, ∇ₓF and ∂F/∂t at `points` (each `points.len() · channels()`, row-major). Where the
    /// partition or the clip switches branch, the derivatives are those of the active branch.
    pub fn jacobians(
        &self,
        s: &mut LevelScratch<S::Scratch>,
        points: &[[f32; 3]],
        value: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) {
        let k = self.source.num_classes();
        let n = points.len() * k;
        s.f.resize(n, 0.0);
        s.grad.resize(n, [0.0; 3]);
        s.dfdt.resize(n, 0.0);
        self.source.eval_jacobian(
            &mut s.source,
            points,
            self.time,
            &mut s.f,
            &mut s.grad,
            &mut s.dfdt,
        );
        let c = self.channels();
        for (i, p) in points.iter().enumerate() {
            let row = i * k;
            let f = &s.f[row..row + k];
            let (box_distance, box_grad) = box_sdf(*p, self.clip);
            for (ch, &class) in self.classes.iter().enumerate() {
                let (other, j) = self.subtrahend(f, class);
                let mut g = s.grad[row + class];
                let mut gt = s.dfdt[row + class];
                if let Some(j) = j {
                    let gj = s.grad[row + j];
                    g = std::array::from_fn(|a| g[a] - gj[a]);
                    gt -= s.dfdt[row + j];
                }
                let v = f[class] - other;
                let o = i * c + ch;
                if box_distance > v {
                    (value[o], grad[o], dfdt[o]) = (box_distance, box_grad, 0.0);
                } else {
                    (value[o], grad[o], dfdt[o]) = (v, g, gt);
                }
            }
        }
    }

    /// What the partition field subtracts from f^class: min(min_{j≠class} f^j, 0) and the j
    /// attaining it (None when it is the background's 0, or in overlapping mode).
    fn subtrahend(&self, f: &[f32], class: usize) -> (f32, Option<usize>) {
        if self.surfaces == Surfaces::Overlapping {
            return (0.0, None);
        }
        let mut best = (0.0, None);
        for (j, &v) in f.iter().enumerate() {
            if j != class && v < best.0 {
                best = (v, Some(j));
            }
        }
        best
    }

    /// F at many points, in parallel: `points.len() · channels()` values.
    pub fn par_values(&self, points: &[[f32; 3]]) -> Vec<f32> {
        let c = self.channels();
        let mut out = vec![0.0; points.len() * c];
        points
            .par_chunks(TASK_POINTS)
            .zip(out.par_chunks_mut(TASK_POINTS * c))
            .for_each_init(|| self.scratch(), |s, (p, o)| self.values(s, p, o));
        out
    }

    /// F, ∇ₓF and ∂F/∂t of channel `channel` at many points, in parallel.
    pub fn par_jacobians(
        &self,
        points: &[[f32; 3]],
        channel: usize,
    ) -> (Vec<f32>, Vec<[f32; 3]>, Vec<f32>) {
        let c = self.channels();
        let n = points.len();
        let (mut value, mut grad, mut dfdt) = (vec![0.0; n], vec![[0.0; 3]; n], vec![0.0; n]);
        points
            .par_chunks(TASK_POINTS)
            .zip(value.par_chunks_mut(TASK_POINTS))
            .zip(grad.par_chunks_mut(TASK_POINTS))
            .zip(dfdt.par_chunks_mut(TASK_POINTS))
            .for_each_init(
                || (self.scratch(), Vec::new(), Vec::new(), Vec::new()),
                |(s, v_all, g_all, t_all), (((p, v), g), t)| {
                    v_all.resize(p.len() * c, 0.0);
                    g_all.resize(p.len() * c, [0.0; 3]);
                    t_all.resize(p.len() * c, 0.0);
                    self.jacobians(s, p, v_all, g_all, t_all);
                    for i in 0..p.len() {
                        (v[i], g[i], t[i]) = (
                            v_all[i * c + channel],
                            g_all[i * c + channel],
                            t_all[i * c + channel],
                        );
                    }
                },
            );
        (value, grad, dfdt)
    }
}

/// Signed distance to the box (negative inside) and its gradient.
fn box_sdf(p: [f32; 3], (lo, hi): ([f32; 3], [f32; 3])) -> (f32, [f32; 3]) {
    // Per axis: the signed distance past the nearer face and the outward direction.
    let q: [(f32, f32); 3] = std::array::from_fn(|a| {
        let below = lo[a] - p[a];
        let above = p[a] - hi[a];
        if below > above {
            (below, -1.0)
        } else {
            (above, 1.0)
        }
    });
    let outside: [f32; 3] = std::array::from_fn(|a| q[a].0.max(0.0) * q[a].1);
    let norm = outside.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 0.0 {
        return (norm, outside.map(|v| v / norm));
    }
    let a = (0..3)
        .max_by(|&i, &j| q[i].0.total_cmp(&q[j].0))
        .unwrap_or(0);
    let mut g = [0.0; 3];
    g[a] = q[a].1;
    (q[a].0, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::{Analytic, Shape};

    const BIG: ([f32; 3], [f32; 3]) = ([-10.0; 3], [10.0; 3]);

    #[test]
    fn partition_field_is_negative_exactly_on_the_argmin_label() {
        // Two unit balls overlapping around x = 0: the partition splits the lens at x = 0.
        let a = Analytic::new(vec![
            Shape::sphere([-0.5, 0.0, 0.0], 1.0, 0.0),
            Shape::sphere([0.5, 0.0, 0.0], 1.0, 0.0),
        ]);
        let part = LevelSets::new(&a, 0.0, vec![0, 1], Surfaces::Partition, BIG);
        let over = LevelSets::new(&a, 0.0, vec![0, 1], Surfaces::Overlapping, BIG);
        let pts: Vec<[f32; 3]> = (0..41)
            .flat_map(|i| (0..9).map(move |j| [i as f32 * 0.1 - 1.987, j as f32 * 0.2 - 0.8, 0.1]))
            .collect();
        let (p, o) = (part.par_values(&pts), over.par_values(&pts));
        let mut raw = vec![0.0; pts.len() * 2];
        a.eval(&mut (), &pts, 0.0, &mut raw);
        for (i, _) in pts.iter().enumerate() {
            let label = dynaslice_core::argmin_label(&raw[2 * i..2 * i + 2]);
            for c in 0..2 {
                assert_eq!(p[2 * i + c] < 0.0, label == c as u32 + 1, "point {i}");
                assert_eq!(o[2 * i + c], raw[2 * i + c]);
            }
        }
    }

    #[test]
    fn jacobians_match_finite_differences_through_partition_and_clip() {
        let a = Analytic::new(vec![
            Shape::sphere([-0.5, 0.0, 0.0], 1.0, 0.3),
            Shape::sphere([0.5, 0.1, 0.0], 0.8, -0.2),
        ]);
        let clip = ([-1.2, -0.6, -2.0], [2.0, 2.0, 2.0]);
        let field = LevelSets::new(&a, 0.4, vec![0, 1], Surfaces::Partition, clip);
        let pts = [
            [0.05, 0.3, 0.2],
            [-1.0, -0.55, 0.1],
            [0.9, 0.2, -0.3],
            [-1.5, 0.0, 0.0],
        ];
        let e = 1e-3;
        for c in 0..2 {
            let (v, g, _) = field.par_jacobians(&pts, c);
            for (i, p) in pts.iter().enumerate() {
                assert_eq!(v[i], field.par_values(&[*p])[c]);
                for ax in 0..3 {
                    let (mut lo, mut hi) = (*p, *p);
                    lo[ax] -= e;
                    hi[ax] += e;
                    let d = (field.par_values(&[hi])[c] - field.par_values(&[lo])[c]) / (2.0 * e);
                    assert!((d - g[i][ax]).abs() < 1e-2, "c {c} point {i} axis {ax}");
                }
            }
        }
        // The time derivative: the partition subtracts the other class's rate.
        let (_, _, dt) = field.par_jacobians(&[[0.0, 0.0, 0.0]], 0);
        let later = LevelSets::new(&a, 0.4 + e, vec![0, 1], Surfaces::Partition, clip);
        let earlier = LevelSets::new(&a, 0.4 - e, vec![0, 1], Surfaces::Partition, clip);
        let d = (later.par_values(&[[0.0; 3]])[0] - earlier.par_values(&[[0.0; 3]])[0]) / (2.0 * e);
        assert!((d - dt[0]).abs() < 1e-2, "{d} vs {}", dt[0]);
    }
}
