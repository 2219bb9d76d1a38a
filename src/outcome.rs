//! Whether a plan achieved its task and, when it did not, why.
//!
//! A target is reached when its particle ends (at step `T` of the re-simulated rollout) within the
//! task tolerance of its position. A task is *achieved* when every target is reached **and** the
//! plan is safe. A plan that misses says which of the [`Reason`]s holds, checked in this order:
//! no safe plan; a missed target inside a collider deeper than the tolerance (unreachable); targets
//! for every particle that the cloth, put there, does not rest in (a finished run's verdict only:
//! it simulates); the solver stopped early (iteration limit, stall); constraints active at the returned plan hold the
//! cloth back (safety rows, or other rows such as collider planes); none is active, so the plan
//! sits in a local minimum of `L`.

use crate::problem::{RowLabel, TrajectoryProblem};
use crate::target_check::{targets_rest, unreachable_targets, REST_STEPS};
// The `task` section of a result, from `crate::result`: re-exported for this module's callers.
pub use crate::result::{target_errors, Reason, TaskOutcome};
use autodiff::Tensor;
use cloth::Model;
use optim::Problem;

/// What the verdict needs besides the rollout.
#[derive(Clone, Debug)]
pub struct PlanFacts<'a> {
    /// The plan is safe (feasible for the optimizer's rows and within the safety margin).
    pub safe: bool,
    /// The solver's status name (`converged`, `iteration_limit`, …).
    pub status: &'a str,
    /// Labels of the active safety groups.
    pub active_safety: Vec<String>,
    /// Labels of the other active groups.
    pub active_other: Vec<String>,
    /// Why the plan is not safe beyond its rows and margin at the steps (the motion between the
    /// steps, the grippers, the colliders: [`crate::result::SafetyReport::failures`]).
    pub failures: Vec<String>,
}

/// The task outcome of a plan whose re-simulated rollout ends in `final_state`.
pub fn task_outcome(model: &Model, final_state: &Tensor, facts: &PlanFacts<'_>) -> TaskOutcome {
    let tolerance = model.task.tolerance;
    let errors = target_errors(model, final_state);
    let max = errors.iter().copied().fold(0.0, f64::max);
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    let reached = errors.iter().filter(|&&e| e <= tolerance).count();
    let all_reached = reached == errors.len();
    let missed = format!(
        "{} of {} targets within {tolerance:.4} (largest error {max:.4})",
        reached,
        errors.len()
    );
    let unreachable: Vec<(usize, f64)> = unreachable_targets(model)
        .into_iter()
        .filter(|&(i, _)| errors[i] > tolerance)
        .collect();
    // A finished run's safe miss with no buried target: do the targets themselves rest?
    let restless =
        if facts.safe && !all_reached && unreachable.is_empty() && facts.status != "running" {
            targets_rest(model).filter(|rest| rest.largest_error > tolerance)
        } else {
            None
        };
    let (reason, explanation) = if !facts.safe {
        let why = if facts.failures.is_empty() {
            "the returned plan violates the safety margin or the optimizer's rows".to_string()
        } else {
            facts.failures.join("; ")
        };
        (Reason::NoSafePlan, format!("no safe plan: {why}; {missed}"))
    } else if all_reached {
        (
            Reason::Achieved,
            format!("every target within {tolerance:.4} (largest error {max:.4}), plan safe"),
        )
    } else if let Some(&(target, depth)) = unreachable.first() {
        (
            Reason::UnreachableTarget,
            format!(
                "{} missed target{} inside the colliders deeper than the tolerance (target \
                 {target}: {depth:.4} deep), where no particle goes; {missed}",
                unreachable.len(),
                if unreachable.len() == 1 {
                    " lies"
                } else {
                    "s lie"
                }
            ),
        )
    } else if let Some(rest) = restless {
        let spread = if rest.spread > 1.0 {
            format!(
                " (their heights above the lowest spread {}× to start its layers apart)",
                rest.spread
            )
        } else {
            String::new()
        };
        let rise = if rest.largest_rise > tolerance {
            format!(
                "; parts of it rise up to {:.4} above their targets",
                rest.largest_rise
            )
        } else {
            String::new()
        };
        (
            Reason::TargetsCannotRest,
            format!(
                "the targets are no state the cloth rests in with its grippers held there: put \
                 at them{spread}, it settles {:.4} from them in {REST_STEPS} steps ({} of {} \
                 within {tolerance:.4}{rise}), so a plan can only end at another equilibrium; \
                 {missed}",
                rest.largest_error, rest.reached, rest.targets
            ),
        )
    } else if facts.status == "iteration_limit" {
        (
            Reason::IterationLimit,
            format!("the solver hit its iteration limit before converging; {missed}"),
        )
    } else if matches!(facts.status, "time_limit" | "interrupted" | "running") {
        (
            Reason::Stopped,
            format!("no converged plan yet (run {}); {missed}", facts.status),
        )
    } else if facts.status != "converged" {
        (
            Reason::Stalled,
            format!(
                "the solver stopped without converging ({}); {missed}",
                facts.status
            ),
        )
    } else if !facts.active_safety.is_empty() {
        (
            Reason::SafetyActive,
            format!(
                "the safety margin holds the cloth back ({} active); {missed}",
                facts.active_safety.join(", ")
            ),
        )
    } else if !facts.active_other.is_empty() {
        (
            Reason::LimitsActive,
            format!(
                "constraints hold the cloth back ({} active); {missed}",
                facts.active_other.join(", ")
            ),
        )
    } else {
        (
            Reason::LocalMinimum,
            format!("converged with no constraint active: a local minimum of L; {missed}"),
        )
    };
    let mut active_constraints = facts.active_safety.clone();
    active_constraints.extend(facts.active_other.iter().cloned());
    TaskOutcome {
        achieved: reason == Reason::Achieved,
        tolerance,
        max_target_error: max,
        rms_target_error: rms,
        target_errors: errors,
        targets_reached: reached,
        reason,
        explanation,
        active_constraints,
    }
}

/// Largest value (length units, relative to the task tolerance) of an inequality row that counts
/// as active at a returned plan: 1% of the tolerance.
const ACTIVE_FRACTION: f64 = 1e-2;

/// Smallest multiplier of an active row: below it the row does not hold the objective back.
const ACTIVE_MULTIPLIER: f64 = 1e-8;

/// What the inequality rows say at a returned plan ([`row_facts`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RowFacts {
    /// Active safety groups (`safety at steps 3–5`).
    pub active_safety: Vec<String>,
    /// Other active groups (collider planes, robot limits).
    pub active_other: Vec<String>,
    /// The most violated row but the goal row and by how much (length units), when one is
    /// violated.
    pub worst_violation: Option<(String, f64)>,
    /// The largest violation of the rows but the goal row (0 when they hold): the task's rows,
    /// on which a plan is judged.
    pub task_violation: f64,
    /// By how much the goal row ([`RowLabel::Goal`]) is violated (0 when it holds), when the
    /// problem has one.
    pub goal_shortfall: Option<f64>,
}

/// The constraint groups active at the solution: rows within `ACTIVE_FRACTION` (`src/outcome.rs`)
/// of the task tolerance of their bound with a positive multiplier (rows alone where the solver
/// returned no multipliers), as labels — safety groups first, then the others; the most
/// violated row, so a plan that misses its rows says which; and the violations of the task's rows
/// and of the goal row apart (the goal row is the route search's way to ask for the targets, not
/// a limit of the task: a plan that misses it is a plan that misses its targets).
pub fn row_facts(
    problem: &mut TrajectoryProblem<'_>,
    solution: &optim::Solution,
) -> crate::Result<RowFacts> {
    let rows = problem.num_inequalities();
    if rows == 0 || solution.x.is_empty() {
        return Ok(RowFacts::default());
    }
    let mut values = vec![0.0; rows];
    problem
        .inequalities(&solution.x, &mut values)
        .map_err(|source| crate::Error::Evaluation {
            what: "re-evaluating the constraints at the plan",
            source,
        })?;
    let threshold = ACTIVE_FRACTION * problem.model().task.tolerance;
    let multipliers = &solution.multipliers.inequality;
    let active = |r: usize| {
        values[r] <= threshold && (multipliers.len() != rows || multipliers[r] > ACTIVE_MULTIPLIER)
    };
    let labels = problem.row_labels();
    let is_goal = |label: &RowLabel| matches!(label, RowLabel::Goal);
    let shortfall = |goal: bool| {
        values
            .iter()
            .zip(&labels)
            .filter(|(_, label)| is_goal(label) == goal)
            .fold(0.0, |worst: f64, (&v, _)| worst.max(-v))
    };
    let task_violation = shortfall(false);
    let goal_shortfall = labels.iter().any(is_goal).then(|| shortfall(true));
    let worst_violation = values
        .iter()
        .zip(&labels)
        .filter(|(v, label)| **v < 0.0 && !is_goal(label))
        .fold(
            None,
            |worst: Option<(f64, &RowLabel)>, (&v, label)| match worst {
                Some((w, _)) if w <= v => worst,
                _ => Some((v, label)),
            },
        )
        .map(|(v, label)| (label.to_string(), -v));
    let mut safety_steps = Vec::new();
    let mut safety_whole = false;
    // Per collider plane: active steps, control points.
    let mut planes: std::collections::BTreeMap<usize, (Vec<usize>, Vec<usize>)> =
        Default::default();
    // Gripper rows against the other colliders: active steps, control points.
    let mut grippers: (Vec<usize>, Vec<usize>) = Default::default();
    // Held-clearance rows: active steps.
    let mut held = Vec::new();
    // Per robot limit: active steps.
    let mut limits: std::collections::BTreeMap<&str, Vec<usize>> = Default::default();
    for (_, label) in labels.iter().enumerate().filter(|&(r, _)| active(r)) {
        match *label {
            RowLabel::Safety { step: Some(t) } => safety_steps.push(t),
            RowLabel::Safety { step: None } => safety_whole = true,
            RowLabel::ColliderPlane {
                plane,
                control,
                step,
            } => {
                let entry = planes.entry(plane).or_default();
                entry.0.push(step);
                entry.1.push(control);
            }
            RowLabel::Collider { control, step } => {
                grippers.0.push(step);
                grippers.1.push(control);
            }
            RowLabel::Limit { limit, step } => limits.entry(limit).or_default().push(step),
            RowLabel::HeldClearance { step } => held.push(step),
            // The goal row asks the cloth to reach its targets: it never holds it back.
            RowLabel::Goal => {}
        }
    }
    let mut safety = Vec::new();
    if safety_whole {
        safety.push("safety (whole rollout)".to_string());
    }
    if !safety_steps.is_empty() {
        safety.push(format!("safety at steps {}", step_ranges(&safety_steps)));
    }
    let mut other: Vec<String> = planes
        .into_iter()
        .map(|(plane, (mut steps, mut controls))| {
            steps.sort_unstable();
            steps.dedup();
            controls.sort_unstable();
            controls.dedup();
            format!(
                "collider plane {plane} under control points {:?} at steps {}",
                controls,
                step_ranges(&steps)
            )
        })
        .collect();
    if !grippers.0.is_empty() {
        let (mut steps, mut controls) = grippers;
        steps.sort_unstable();
        steps.dedup();
        controls.sort_unstable();
        controls.dedup();
        other.push(format!(
            "colliders around control points {:?} at steps {}",
            controls,
            step_ranges(&steps)
        ));
    }
    if !held.is_empty() {
        other.push(format!(
            "held particles' clearance from the cloth at steps {}",
            step_ranges(&held)
        ));
    }
    other.extend(limits.into_iter().map(|(limit, mut steps)| {
        steps.sort_unstable();
        steps.dedup();
        format!("limit {limit} at steps {}", step_ranges(&steps))
    }));
    Ok(RowFacts {
        active_safety: safety,
        active_other: other,
        worst_violation,
        task_violation,
        goal_shortfall,
    })
}

/// Compresses sorted step numbers into ranges: `[1, 2, 3, 7]` → `"1–3, 7"`.
pub fn step_ranges(steps: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < steps.len() {
        let mut j = i;
        while j + 1 < steps.len() && steps[j + 1] == steps[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            steps[i].to_string()
        } else {
            format!("{}–{}", steps[i], steps[j])
        });
        i = j + 1;
    }
    parts.join(", ")
}

/// Process exit code for a planning verdict: 0 achieved, 3 a safe plan that does not achieve
/// the task, 4 no safe plan (1 is left for errors and bad input).
pub fn exit_code(outcome: &TaskOutcome) -> i32 {
    match outcome.reason {
        Reason::Achieved => 0,
        Reason::NoSafePlan => 4,
        _ => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_ranges_compress_runs() {
        assert_eq!(step_ranges(&[1, 2, 3, 7, 9, 10]), "1–3, 7, 9–10");
        assert_eq!(step_ranges(&[]), "");
        assert_eq!(step_ranges(&[4]), "4");
    }
}
