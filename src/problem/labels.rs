//! What each inequality row of a [`TrajectoryProblem`] constrains ([`RowLabel`]), in row order.

use super::{SafetyForm, StepRow, TrajectoryProblem};
use crate::control_rows::ControlRow;

/// What one inequality row of a [`TrajectoryProblem`] constrains.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowLabel {
    /// A safety row: of one step (per-step form), or of the whole rollout (`None`).
    Safety {
        /// The step `1..=T` the row constrains, `None` for the scalar and aggregate forms.
        step: Option<usize>,
    },
    /// A held-clearance row: every held particle's gap to the rest of the cloth at one step
    /// (`step_rows.rs`).
    HeldClearance {
        /// The step `1..=T`.
        step: usize,
    },
    /// The goal row: every target within
    /// [`TaskOptions::goal_radius`](super::TaskOptions::goal_radius) at step `T`.
    Goal,
    /// A control point kept on the free side of a collider plane at one step.
    ColliderPlane {
        /// Index of the plane among the colliders.
        plane: usize,
        /// Index of the control point.
        control: usize,
        /// The step `1..=T`.
        step: usize,
    },
    /// A control point (gripper) kept out of the colliders other than planes at one step and,
    /// with the continuous check, on its straight motion from the step before.
    Collider {
        /// Index of the control point.
        control: usize,
        /// The step `1..=T`.
        step: usize,
    },
    /// A robot limit (`task.limits`) at one step.
    Limit {
        /// The limit: `max_strain`, `max_step`, `gripper_separation` or `workspace`.
        limit: &'static str,
        /// The step `1..=T` (for `max_step`, the step the move ends at).
        step: usize,
    },
}

impl std::fmt::Display for RowLabel {
    /// The row as a reader would name it: `safety at step 3`, `limit max_strain at step 4`, …
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            RowLabel::Safety { step: Some(t) } => write!(f, "safety at step {t}"),
            RowLabel::Safety { step: None } => write!(f, "safety (whole rollout)"),
            RowLabel::HeldClearance { step } => {
                write!(f, "held particles' clearance from the cloth at step {step}")
            }
            RowLabel::Goal => write!(f, "goal (every target within the goal radius)"),
            RowLabel::ColliderPlane {
                plane,
                control,
                step,
            } => write!(
                f,
                "collider plane {plane} under control point {control} at step {step}"
            ),
            RowLabel::Collider { control, step } => {
                write!(f, "colliders around control point {control} at step {step}")
            }
            RowLabel::Limit { limit, step } => write!(f, "limit {limit} at step {step}"),
        }
    }
}

impl TrajectoryProblem<'_> {
    /// What each inequality row constrains, in row order (safety rows, step rows, the goal row,
    /// step and separation rows, collider rows, workspace rows).
    pub fn row_labels(&self) -> Vec<RowLabel> {
        let mut labels: Vec<RowLabel> = match self.options.safety {
            Some(SafetyForm::PerStep) => (1..=self.safety_rows())
                .map(|t| RowLabel::Safety { step: Some(t) })
                .collect(),
            _ => vec![RowLabel::Safety { step: None }; self.safety_rows()],
        };
        for kind in self.step_row_kinds() {
            labels.extend((1..=self.model.task.horizon).map(|step| match kind {
                StepRow::Strain => RowLabel::Limit {
                    limit: "max_strain",
                    step,
                },
                StepRow::HeldClearance => RowLabel::HeldClearance { step },
            }));
        }
        labels.extend((0..self.goal_rows()).map(|_| RowLabel::Goal));
        labels.extend(self.control.iter().map(control_label));
        let (planes, k, horizon) = (
            self.model.colliders.planes.len(),
            self.model.n_controls(),
            self.model.task.horizon,
        );
        for plane in 0..planes {
            for control in 0..k {
                labels.extend((1..=horizon).map(|step| RowLabel::ColliderPlane {
                    plane,
                    control,
                    step,
                }));
            }
        }
        // Workspace rows: per control point, step, axis, the lower then the upper bound.
        let workspace = self.linear.len() - planes * k * horizon;
        labels.extend((0..workspace).map(|r| RowLabel::Limit {
            limit: "workspace",
            step: 1 + (r / 6) % horizon,
        }));
        labels
    }
}

/// What a row on the controls constrains: a limit (its `task.limits` field) or the colliders, and
/// the step `1..=T`.
fn control_label(row: &ControlRow) -> RowLabel {
    match *row {
        ControlRow::Step { t, .. } => RowLabel::Limit {
            limit: "max_step",
            step: t + 1,
        },
        ControlRow::MinSeparation { t, .. } | ControlRow::MaxSeparation { t, .. } => {
            RowLabel::Limit {
                limit: "gripper_separation",
                step: t,
            }
        }
        ControlRow::Collider { t, k, .. } => RowLabel::Collider {
            control: k,
            step: t,
        },
    }
}
