//! 3D IoU of a model's Eq. 11 labels against ground-truth signed distances, on a grid.
//!
//! Both partitions are labelled the same way: a grid point belongs to class k when channel k
//! is negative and the smallest (Eq. 11, background 0, ties to the lower index), for the model
//! from its K channels and for the truth from the K exact distances. The IoU of class k is
//! |P_k ∩ T_k| / |P_k ∪ T_k| over the cell centres of a `resolution`³ grid spanning `bounds`.

use dynaslice_core::{argmin_label, Model, Scratch};
use rayon::prelude::*;

/// Points per batch call (one z-row of the grid at a time keeps memory bounded).
const ROW_CHUNK: usize = 4096;

/// Per-class intersection and union counts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlap {
    /// |P_k ∩ T_k| per class.
    pub intersection: Vec<u64>,
    /// |P_k ∪ T_k| per class.
    pub union: Vec<u64>,
}

impl Overlap {
    /// IoU per class; `None` where neither partition has the class (nothing to compare).
    pub fn iou(&self) -> Vec<Option<f64>> {
        self.intersection
            .iter()
            .zip(&self.union)
            .map(|(&i, &u)| (u > 0).then(|| i as f64 / u as f64))
            .collect()
    }

    /// No points yet, for `classes` classes.
    pub fn zeros(classes: usize) -> Overlap {
        Overlap {
            intersection: vec![0; classes],
            union: vec![0; classes],
        }
    }

    /// Counts `predicted` and `actual` labels (0 = background, k = class k) of one point.
    #[inline]
    pub fn count(&mut self, predicted: u32, actual: u32) {
        for (i, (n, u)) in self
            .intersection
            .iter_mut()
            .zip(&mut self.union)
            .enumerate()
        {
            let c = i as u32 + 1;
            let (a, b) = (predicted == c, actual == c);
            *n += (a && b) as u64;
            *u += (a || b) as u64;
        }
    }
}

/// The counts of both, e.g. over several planes or slabs.
impl std::ops::Add for Overlap {
    type Output = Overlap;

    fn add(mut self, o: Overlap) -> Overlap {
        self += o;
        self
    }
}

impl std::ops::AddAssign for Overlap {
    fn add_assign(&mut self, o: Overlap) {
        self.intersection
            .iter_mut()
            .zip(&o.intersection)
            .for_each(|(a, b)| *a += b);
        self.union
            .iter_mut()
            .zip(&o.union)
            .for_each(|(a, b)| *a += b);
    }
}

/// Cell centres of a `resolution`³ grid over `bounds`, as z-slabs of points.
fn slab(bounds: ([f64; 3], [f64; 3]), resolution: usize, z: usize) -> Vec<[f32; 3]> {
    let (lo, hi) = bounds;
    let c = |i: usize, a: usize| lo[a] + (hi[a] - lo[a]) * (i as f64 + 0.5) / resolution as f64;
    let mut pts = Vec::with_capacity(resolution * resolution);
    for y in 0..resolution {
        for x in 0..resolution {
            pts.push([c(x, 0) as f32, c(y, 1) as f32, c(z, 2) as f32]);
        }
    }
    pts
}

/// IoU counts of `model` at world time `t` against `truth(class, x, t)` (exact signed
/// distances, class 0-based), on a `resolution`³ grid over `bounds` (world units).
pub fn label_overlap(
    model: &Model,
    truth: &(dyn Fn(usize, [f64; 3], f64) -> f64 + Sync),
    bounds: ([f64; 3], [f64; 3]),
    resolution: usize,
    t: f64,
) -> Overlap {
    let k = model.num_classes();
    let empty = Overlap::zeros(k);
    (0..resolution)
        .into_par_iter()
        .map_init(Scratch::boxed, |scratch, z| {
            let pts = slab(bounds, resolution, z);
            let times = vec![t as f32; ROW_CHUNK];
            let mut labels = vec![0u32; ROW_CHUNK];
            let mut o = empty.clone();
            let mut dist = vec![0.0f32; k];
            for chunk in pts.chunks(ROW_CHUNK) {
                let n = chunk.len();
                model
                    .label_batch(scratch, chunk, &times[..n], &mut labels[..n])
                    .expect("buffers sized to the chunk");
                for (p, &predicted) in chunk.iter().zip(&labels[..n]) {
                    let x = p.map(f64::from);
                    dist.iter_mut()
                        .enumerate()
                        .for_each(|(c, d)| *d = truth(c, x, t) as f32);
                    o.count(predicted, argmin_label(&dist));
                }
            }
            o
        })
        .reduce(|| empty.clone(), |a, b| a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_core::format::ModelWriter;

    /// A model with constant outputs (only output biases) labels everything the same; against a
    /// truth sphere that covers a known fraction of the grid the IoU is that fraction.
    #[test]
    fn constant_model_against_a_sphere() {
        let mut w = ModelWriter::random_siren(&[8], 2, 1);
        w.params.iter_mut().for_each(|p| *p = 0.0);
        let n = w.params.len();
        w.params[n - 2] = -1.0; // class 1 everywhere (f¹ = −1 < f² = 0.5)
        w.params[n - 1] = 0.5;
        let bytes = w.to_bytes();
        let model = Model::from_bytes(&bytes).unwrap();
        let r = 0.6;
        let truth = move |c: usize, x: [f64; 3], _t: f64| {
            let d = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt() - r;
            if c == 0 {
                d
            } else {
                1.0
            }
        };
        let o = label_overlap(&model, &truth, ([-1.0; 3], [1.0; 3]), 64, 0.0);
        let iou = o.iou();
        let sphere_fraction = 4.0 / 3.0 * std::f64::consts::PI * r * r * r / 8.0;
        let got = iou[0].unwrap();
        assert!(
            (got - sphere_fraction).abs() < 0.01,
            "{got} vs {sphere_fraction}"
        );
        assert_eq!(iou[1], None, "class 2 is in neither partition");
        assert_eq!(o.union[0], 64 * 64 * 64);
    }
}
