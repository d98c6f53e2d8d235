//! Space-time samples for the regulariser ℛ (Eq. 8): uniform over a world box × time range.

use super::rng::SampleRng;
use dynaslice_sequence::Aabb;

/// A batch of space-time samples as flat arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpaceTimeBatch {
    /// World position.
    pub xyz: Vec<[f32; 3]>,
    /// Time.
    pub t: Vec<f32>,
}

/// Replaces `out` with `n` points uniform over `bbox` × [`times`.0, `times`.1]. The caller picks
/// the box, typically [`dynaslice_sequence::Sequence::bounding_box`] with a margin, and the time range,
/// typically [`dynaslice_sequence::Sequence::time_range`]. No allocation once `out` has grown to `n`.
pub fn sample_space_time(
    rng: &mut SampleRng,
    n: usize,
    bbox: &Aabb,
    times: (f64, f64),
    out: &mut SpaceTimeBatch,
) {
    out.xyz.clear();
    out.t.clear();
    for _ in 0..n {
        let x = std::array::from_fn(|k| rng.range(bbox.min[k], bbox.max[k]) as f32);
        out.xyz.push(x);
        out.t.push(rng.range(times.0, times.1) as f32);
    }
}
