//! The `task` section of a result: how far each target ended from its position ([`target_errors`])
//! and the verdict — whether the plan achieved its task and, when it did not, why
//! ([`crate::outcome`] reaches it).

use autodiff::Tensor;
use cloth::Model;
use serde::{Deserialize, Serialize};

/// The final distance of each target particle from its position.
pub fn target_errors(model: &Model, final_state: &Tensor) -> Vec<f64> {
    let positions = &model.task.target_positions;
    model
        .task
        .targets
        .as_slice()
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            (0..3)
                .map(|j| (final_state.get(p, j) - positions.get(i, j)).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

/// Why a task was or was not achieved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// Every target within tolerance, and the plan is safe.
    Achieved,
    /// The safety rows are active at the returned plan: the margin `δ` (or a route too narrow for
    /// the cloth) holds the cloth back.
    SafetyActive,
    /// Rows other than safety (control points against collider planes, robot limits) are active
    /// at the returned plan and hold the cloth back.
    LimitsActive,
    /// The solver converged with no constraint active: a local minimum of `L = G + αT + βE`
    /// (another route, or smaller `α`/`β`, may reach the targets).
    LocalMinimum,
    /// A target the plan misses lies inside a collider deeper than the task tolerance: no plan
    /// brings its particle within the tolerance.
    UnreachableTarget,
    /// Every particle has a target, and the targets are no state the cloth rests in with its
    /// grippers held there: put at them, it settles beyond the tolerance
    /// ([`crate::target_check::targets_rest`]), so a plan can only end at another equilibrium.
    TargetsCannotRest,
    /// The solver stopped at its iteration limit before converging.
    IterationLimit,
    /// The solver stopped without converging (negligible step, line-search failure, QP failure,
    /// no progress).
    Stalled,
    /// The run was stopped (time limit, interrupt) before the solver converged, or is still
    /// under way (a best-so-far file).
    Stopped,
    /// The returned plan is not safe (it violates the safety margin or the optimizer's rows).
    #[default]
    NoSafePlan,
}

impl Reason {
    /// Every reason, in the order the verdict checks them (achieved first).
    pub const ALL: [Reason; 10] = [
        Reason::Achieved,
        Reason::NoSafePlan,
        Reason::UnreachableTarget,
        Reason::TargetsCannotRest,
        Reason::IterationLimit,
        Reason::Stopped,
        Reason::Stalled,
        Reason::SafetyActive,
        Reason::LimitsActive,
        Reason::LocalMinimum,
    ];

    /// The name the result JSON and the summary give it: `achieved`, `no_safe_plan`,
    /// `unreachable_target`, `targets_cannot_rest`, `iteration_limit`, `stopped`, `stalled`, `safety_active`, `limits_active`,
    /// `local_minimum`.
    pub fn name(self) -> &'static str {
        match self {
            Reason::Achieved => "achieved",
            Reason::SafetyActive => "safety_active",
            Reason::LimitsActive => "limits_active",
            Reason::LocalMinimum => "local_minimum",
            Reason::UnreachableTarget => "unreachable_target",
            Reason::TargetsCannotRest => "targets_cannot_rest",
            Reason::IterationLimit => "iteration_limit",
            Reason::Stalled => "stalled",
            Reason::Stopped => "stopped",
            Reason::NoSafePlan => "no_safe_plan",
        }
    }
}

/// The task section of a result: how close the cloth came to its targets, and the verdict.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TaskOutcome {
    /// Every target reached and the plan safe.
    pub achieved: bool,
    /// Distance within which a target counts as reached (`task.tolerance`).
    pub tolerance: f64,
    /// Largest final distance of a target particle from its position.
    pub max_target_error: f64,
    /// Root mean square of the final target distances.
    pub rms_target_error: f64,
    /// Final distance of each target particle from its position, in target order.
    pub target_errors: Vec<f64>,
    /// How many targets are within tolerance.
    pub targets_reached: usize,
    /// The verdict's reason.
    pub reason: Reason,
    /// The verdict in words.
    pub explanation: String,
    /// Constraint groups active at the returned plan (e.g. `safety at steps 4–6`); empty when
    /// none is.
    pub active_constraints: Vec<String>,
}
