//! Contour samples: points on the annotated contours with their outward in-plane normals, for the
//! paper's zero-level term |f(x, tᵢ)| and orientation term 𝒩 (Eq. 5, 6).

use super::index::SamplingIndex;
use super::rng::SampleRng;

/// A batch of contour samples as flat arrays (index i across all fields is one sample).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContourBatch {
    /// World position.
    pub xyz: Vec<[f32; 3]>,
    /// World outward unit normal, in the sample's plane.
    pub normal: Vec<[f32; 3]>,
    /// Time of the sample's timestep.
    pub t: Vec<f32>,
    /// Class index.
    pub class: Vec<u32>,
}

impl ContourBatch {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    fn clear(&mut self) {
        self.xyz.clear();
        self.normal.clear();
        self.t.clear();
        self.class.clear();
    }
}

impl SamplingIndex {
    /// Replaces `out` with `per_class[k]` contour samples of each class `k`, drawn uniformly by
    /// arc length over all of that class's contours in all timesteps. A class without contours
    /// gets none, whatever its count. No allocation once `out` has grown to the total.
    pub fn sample_contours(
        &self,
        rng: &mut SampleRng,
        per_class: &[usize],
        out: &mut ContourBatch,
    ) {
        out.clear();
        for (k, (class, &n)) in self.classes.iter().zip(per_class).enumerate() {
            let Some(&total) = class.cum_perimeter.last() else {
                continue;
            };
            for _ in 0..n {
                let s = rng.range(0.0, total);
                let j = class
                    .cum_perimeter
                    .partition_point(|&c| c <= s)
                    .min(class.contoured.len() - 1);
                let before = if j == 0 {
                    0.0
                } else {
                    class.cum_perimeter[j - 1]
                };
                let a = &self.annotations[class.contoured[j]];
                let entry = &self.planes[a.plane];
                let sdf = a.sdf.as_ref().expect("contoured annotations have an SDF");
                let (p, nrm) = sdf.point_at_arc_length(s - before);
                out.xyz.push(entry.plane.to_world(p).map(|x| x as f32));
                out.normal
                    .push(entry.plane.vector_to_world(nrm).map(|x| x as f32));
                out.t.push(entry.time as f32);
                out.class.push(k as u32);
            }
        }
    }
}
