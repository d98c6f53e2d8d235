//! The plan of a run's learning-rate schedule: where the cosine stands at each step, so a timed
//! run (`--minutes`) can stretch or shorten it as the machine's speed changes without a jump
//! in the learning rate. Checkpoints store it; the trainer makes and re-makes it.

/// Steps held at the initial learning rate (after any warm-up ramp) before the cosine starts.
/// A timed run measures its step time over them (all but the first step of the process, which
/// pays for starting threads and warming caches) and plans the schedule from that, so the
/// learning rates of these steps cannot depend on the plan.
pub const CALIBRATION_STEPS: u64 = 10;

/// A timed run's learning-rate schedule: from `anchor_step` on, the cosine's phase runs
/// linearly from `anchor_phase` to 1 at `length`. The first plan anchors at the end of the
/// calibration steps with phase 0; a re-plan anchors at the step it is made with the phase
/// reached there, so the learning rate never jumps, only the pace of its decay changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SchedulePlan {
    /// The step the plan was made at (0-based: the next step to run).
    pub anchor_step: u64,
    /// The cosine's phase in [0, 1] at `anchor_step`.
    pub anchor_phase: f64,
    /// The schedule's length: the phase reaches 1 at this step.
    pub length: u64,
}

impl SchedulePlan {
    /// The plain schedule of `length` steps: phase 0 through the calibration steps, then linear
    /// to 1 at `length`.
    pub fn plain(length: u64) -> SchedulePlan {
        SchedulePlan {
            anchor_step: CALIBRATION_STEPS.min(length),
            anchor_phase: 0.0,
            length,
        }
    }

    /// The cosine's phase at `step` (0-based), in [0, 1].
    pub fn phase(&self, step: u64) -> f64 {
        let done = step.saturating_sub(self.anchor_step) as f64;
        let span = self.length.saturating_sub(self.anchor_step).max(1) as f64;
        self.anchor_phase + (1.0 - self.anchor_phase) * (done / span).min(1.0)
    }

    /// The plan from `step` on with a new `length`, continuing this plan's phase.
    pub fn replanned(&self, step: u64, length: u64) -> SchedulePlan {
        SchedulePlan {
            anchor_step: step,
            anchor_phase: self.phase(step),
            length,
        }
    }
}
