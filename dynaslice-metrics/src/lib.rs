//! Accuracy measures against ground truth (definitions and commands: docs/metrics.md).
//!
//! - [`iou`]: 3D intersection over union of the Eq. 11 label partition on a grid.
//! - [`chamfer`]: Chamfer distance between area-uniform surface samples, unit-normalised.
//! - [`benchmark`]: both against the synthetic benchmark's exact shapes at every frame.
//! - [`inside`]: 3D IoU against a reference triangle mesh (inside cells by ray parity).
//! - [`heldout`]: 2D IoU on withheld planes and frames (spatial, temporal, spatio-temporal).
//! - [`volume`]: each class's volume over time.
//! - [`itv`]: the internal target volume, a class's union over a cycle, as a mask and a mesh,
//!   and their files.
//! - [`motion`]: per class over a cycle: volumes, centroids, amplitudes, the volume change (or
//!   rigid).
//! - [`measurement`]: a model file measured at its times, with its units, patient frame and
//!   classes: what `dynaslice measure` prints and writes and the report shows.
//! - [`support`]: components of a class that the input's contours do not support.
//! - [`extent`]: classes whose extent or volume the data does not support (spurious structure).

#![warn(missing_docs)]

pub mod benchmark;
pub mod chamfer;
pub mod extent;
pub mod heldout;
pub mod inside;
pub mod iou;
pub mod itv;
pub mod measurement;
pub mod motion;
pub mod support;
pub mod volume;

/// Which frames an average is over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frames {
    /// Every frame.
    All,
    /// Frames the model was trained on.
    Annotated,
    /// Frames it was not.
    Unannotated,
}

impl Frames {
    fn keeps(self, annotated: bool) -> bool {
        match self {
            Frames::All => true,
            Frames::Annotated => annotated,
            Frames::Unannotated => !annotated,
        }
    }
}

/// One score per frame and class (`None` where it is undefined, e.g. a class in neither
/// partition), with which frames were annotated.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTable {
    /// Time of each frame.
    pub times: Vec<f64>,
    /// Whether each frame was annotated.
    pub annotated: Vec<bool>,
    /// `values[frame][class]`.
    pub values: Vec<Vec<Option<f64>>>,
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

impl FrameTable {
    /// Frame `f`'s mean over the classes where the score is defined.
    pub fn frame_mean(&self, f: usize) -> Option<f64> {
        mean(self.values[f].iter().flatten().copied())
    }

    /// The mean over `frames` of the frame means (frames without a defined score are left out).
    pub fn mean(&self, frames: Frames) -> Option<f64> {
        mean(
            (0..self.values.len())
                .filter(|&f| frames.keeps(self.annotated[f]))
                .filter_map(|f| self.frame_mean(f)),
        )
    }

    /// Class `c`'s mean over `frames`.
    pub fn class_mean(&self, c: usize, frames: Frames) -> Option<f64> {
        mean(
            self.values
                .iter()
                .zip(&self.annotated)
                .filter(|(_, &a)| frames.keeps(a))
                .filter_map(|(v, _)| v[c]),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_skip_undefined_scores_and_split_frames() {
        let t = FrameTable {
            times: vec![0.0, 0.5, 1.0],
            annotated: vec![true, false, true],
            values: vec![
                vec![Some(1.0), Some(0.5)],
                vec![Some(0.2), None],
                vec![None, None],
            ],
        };
        assert_eq!(t.frame_mean(0), Some(0.75));
        assert_eq!(t.frame_mean(2), None);
        assert_eq!(t.mean(Frames::Annotated), Some(0.75));
        assert_eq!(t.mean(Frames::Unannotated), Some(0.2));
        assert_eq!(t.mean(Frames::All), Some(0.475));
        assert_eq!(t.class_mean(1, Frames::All), Some(0.5));
        assert_eq!(t.class_mean(1, Frames::Unannotated), None);
    }
}
