//! The `safety` section of a result: what the verdict checked besides the optimizer's rows and
//! the margin at the steps — the straight motion between the steps (the continuous check), the
//! cloth's surface between its particles, the cloth's layers, the grippers against the colliders,
//! the cloth inside the colliders — and what failed
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

/// The smallest signed distance from the safety obstacles to the cloth's surface (its
/// triangles, not only its particles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SurfaceClearance {
    /// The distance (length units; negative where an obstacle passes through the cloth), to
    /// [`SURFACE_TOLERANCE`] where it is below `δ`; where the whole surface keeps `δ`, a lower
    /// bound at least `δ` less that tolerance.
    pub distance: f64,
    /// The step `1..=T`: its state, or (continuous check) the motion from the step before.
    pub step: usize,
    /// The triangle (index into the cloth's triangles).
    pub triangle: usize,
}

/// How near a self-colliding cloth's layers come, and whether they pass through each other.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LayerClearance {
    /// The nearest vertex–triangle pair (outside each other's 1-ring) at any step `1..=T`,
    /// among the pairs within the thickness; `null` when none comes that near.
    pub nearest: Option<LayerPair>,
    /// How many vertex–triangle and edge–edge pairs pass through each other between the steps
    /// (from the rest state on), in all.
    pub crossings: usize,
    /// The first step whose motion from the step before has a crossing; `null` without any.
    pub first_crossing_step: Option<usize>,
}

/// A vertex–triangle pair of the cloth at a step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LayerPair {
    /// Their unsigned distance (length units).
    pub distance: f64,
    /// The step `1..=T`.
    pub step: usize,
    /// The vertex (particle index).
    pub vertex: usize,
    /// The triangle (index into the cloth's triangles).
    pub triangle: usize,
}

/// How precisely [`SurfaceClearance::distance`] is certified, and how far an obstacle may cut
/// into the cloth's surface before the plan is not safe: 1 mm (length units).
pub const SURFACE_TOLERANCE: f64 = 1e-3;

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
    /// The cloth's surface nearest to the safety obstacles, at the steps and (continuous check)
    /// swept between them: a thin obstacle can pass between particles that all keep `δ`. `null`
    /// without safety obstacles (and in results written before the check existed).
    #[serde(default)]
    pub surface: Option<SurfaceClearance>,
    /// With self-collision (`physics.self_collision`), how near the cloth's layers come and
    /// whether it passes through itself; `null` without self-collision.
    #[serde(default)]
    pub layers: Option<LayerClearance>,
    /// The gripper nearest to the colliders, at the steps and (continuous check) between them;
    /// `null` without colliders.
    #[serde(default)]
    pub grippers: Option<GripperClearance>,
    /// Why the plan is not safe by these checks, one sentence each; empty when it is.
    #[serde(default)]
    pub failures: Vec<String>,
}
