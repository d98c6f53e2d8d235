//! Plane samples: off-contour points on annotated planes with their in-plane SDF targets, for
//! the paper's data term 𝒟 (Eq. 7), and "class absent here" lower bounds.

use super::index::SamplingIndex;
use super::rng::SampleRng;
use dynaslice_geometry::PolygonSdf;

/// What a plane sample's `target` means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum PlaneTarget {
    /// `target` is the exact in-plane signed distance **f**ᵢ(x) (Eq. 7). Its sign is the 3D
    /// sign and its magnitude bounds the 3D distance from above.
    Sdf = 0,
    /// The class is absent from the plane: `target` (0) is only a lower bound, f^k(x) ≥ target;
    /// penalise ReLU(target − f) rather than a squared difference.
    LowerBound = 1,
}

/// How plane samples are placed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneSampling {
    /// Fraction of samples on contoured planes placed near the contour (a contour point plus an
    /// isotropic in-plane Gaussian offset); the rest are uniform over the plane's region of
    /// interest. Near-contour samples resolve the sign where it matters.
    pub near_fraction: f64,
    /// Standard deviation of the near-contour offset, world units.
    pub near_sigma: f64,
    /// For a class narrower than the scene, the offset's standard deviation is at most this
    /// fraction of the class's width (2·area/perimeter, a disc's radius), so its samples fall
    /// on it rather than around it: with σ = 1 % of a breast case's 1 m diagonal (10 mm), a
    /// 12 mm node's plane samples landed mostly outside it, and it vanished.
    pub near_width_fraction: f64,
    /// Fraction of each class's samples drawn from planes where the class is absent (when it has
    /// both kinds). Absences dominate real multi-organ data; a fixed share keeps them from
    /// crowding out the exact targets.
    pub absent_fraction: f64,
}

impl PlaneSampling {
    /// Defaults scaled to a scene: half the samples near contours with σ = 1 % of `diagonal`
    /// (at most half a narrow class's width), a quarter of each class's samples on planes where
    /// it is absent.
    pub fn for_scene(diagonal: f64) -> Self {
        PlaneSampling {
            near_fraction: 0.5,
            near_sigma: 0.01 * diagonal,
            near_width_fraction: 0.5,
            absent_fraction: 0.25,
        }
    }
}

/// A batch of plane samples as flat arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlaneBatch {
    /// World position (on the sample's plane).
    pub xyz: Vec<[f32; 3]>,
    /// Time of the plane's timestep.
    pub t: Vec<f32>,
    /// Class index.
    pub class: Vec<u32>,
    /// The target value; see `kind`.
    pub target: Vec<f32>,
    /// What the target means.
    pub kind: Vec<PlaneTarget>,
}

impl PlaneBatch {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the batch is empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    pub(super) fn clear(&mut self) {
        self.xyz.clear();
        self.t.clear();
        self.class.clear();
        self.target.clear();
        self.kind.clear();
    }
}

impl SamplingIndex {
    /// Replaces `out` with `per_class[k]` plane samples of each class `k`: (per
    /// [`PlaneSampling::absent_fraction`]) one of its absent or contoured annotations uniformly,
    /// then a point per [`PlaneSampling::near_fraction`]. Exact targets cost one grid query each
    /// ([`dynaslice_geometry::PolygonSdf`]). No allocation once `out` has grown to the total.
    pub fn sample_planes(
        &self,
        rng: &mut SampleRng,
        per_class: &[usize],
        how: &PlaneSampling,
        out: &mut PlaneBatch,
    ) {
        out.clear();
        let draws = self
            .classes
            .iter()
            .zip(per_class)
            .filter(|(c, _)| !(c.absent.is_empty() && c.contoured.is_empty()))
            .flat_map(|(class, &n)| std::iter::repeat_n(class, n));
        for class in draws {
            let sigma = how.near_sigma.min(how.near_width_fraction * class.width);
            let use_absent = !class.absent.is_empty()
                && (class.contoured.is_empty() || rng.uniform() < how.absent_fraction);
            let list = if use_absent {
                &class.absent
            } else {
                &class.contoured
            };
            let a = &self.annotations[list[rng.below(list.len())]];
            let entry = &self.planes[a.plane];
            let roi = entry.plane.roi;
            let uniform = |rng: &mut SampleRng| {
                [
                    rng.range(roi.min[0], roi.max[0]),
                    rng.range(roi.min[1], roi.max[1]),
                ]
            };
            let (p, target, kind) = match &a.sdf {
                None => (uniform(rng), 0.0, PlaneTarget::LowerBound),
                Some(sdf) => {
                    let p = if rng.uniform() < how.near_fraction {
                        near_contour(rng, sdf, sigma)
                    } else {
                        uniform(rng)
                    };
                    (p, sdf.distance(p), PlaneTarget::Sdf)
                }
            };
            out.xyz.push(entry.plane.to_world(p).map(|x| x as f32));
            out.t.push(entry.time as f32);
            out.class.push(a.class);
            out.target.push(target as f32);
            out.kind.push(kind);
        }
    }
}

/// A point near `sdf`'s contour: a point of it uniform by arc length, moved by a normal draw of
/// spread `sigma` in each in-plane axis.
pub(super) fn near_contour(rng: &mut SampleRng, sdf: &PolygonSdf, sigma: f64) -> [f64; 2] {
    let (c, _) = sdf.point_at_arc_length(rng.range(0.0, sdf.perimeter()));
    let (g0, g1) = rng.normal_pair();
    [c[0] + sigma * g0, c[1] + sigma * g1]
}
