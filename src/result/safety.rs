//! The `safety` section of a result: what the verdict checked besides the optimizer's rows and
//! the margin at the steps — the straight motion between the steps (the continuous check), the
//! grippers against the colliders, the cloth inside the colliders — and what failed
//! ([`crate::safety_check`] fills it in).

use serde::{Deserialize, Serialize};

/// How the motion between the steps was judged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionCheck {
    /// The straight motion of every particle between consecutive steps keeps `δ` from the safety
    /// obstacles, and every gripper's motion stays out of the colliders (the default).
    Continuous,
    /// Only the states at the `T` steps are judged (`--step-only`); a result written before the
    /// continuous check existed reads as this.
    #[default]
    StepOnly,
}

impl MotionCheck {
    /// The check's JSON name: `continuous` or `step_only`.
    pub fn name(self) -> &'static str {
        match self {
            MotionCheck::Continuous => "continuous",
            MotionCheck::StepOnly => "step_only",
        }
    }
}

/// The smallest signed distance to the safety obstacles along the particles' straight motion
/// between two steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PathMinimum {
    /// The distance (length units; negative inside an obstacle).
    pub distance: f64,
    /// The step `1..=T` the motion ends at (it starts at the step before).
    pub step: usize,
    /// The particle (flat index).
    pub particle: usize,
}

/// The gripper (control point) nearest to, or deepest inside, the colliders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GripperClearance {
    /// Its signed distance to the colliders (length units; negative inside one).
    pub distance: f64,
    /// The step `1..=T`: at that step, or on the motion from the step before under the
    /// continuous check.
    pub step: usize,
    /// The control point's index (in the scene's `controls` order).
    pub gripper: usize,
}

/// The verdict's safety checks beyond the optimizer's rows.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SafetyReport {
    /// How the motion between the steps was judged.
    pub check: MotionCheck,
    /// Under the continuous check, the smallest signed distance along any particle's straight
    /// motion between two steps (a particle whose rest state already lies within `δ` counts
    /// from its step-1 state); `null` under the step-only check or without safety obstacles.
    #[serde(default)]
    pub between_steps: Option<PathMinimum>,
    /// The gripper nearest to the colliders, at the steps and (continuous check) between them;
    /// `null` without colliders.
    #[serde(default)]
    pub grippers: Option<GripperClearance>,
    /// Why the plan is not safe by these checks, one sentence each; empty when it is.
    #[serde(default)]
    pub failures: Vec<String>,
}
