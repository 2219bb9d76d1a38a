//! How far a plan stretches the cloth: the largest edge strain per step, and the warning a plan
//! gets when it stretches an edge beyond 10% with no `task.limits.max_strain` bounding it.

use crate::plan::PlanResult;
use autodiff::Tensor;
use cloth::Model;
use serde::Serialize;

/// Edge strain `|x_i − x_j|/L₀ − 1` of a rollout (0.1 = stretched 10% beyond its rest length).
#[derive(Clone, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct StrainReport {
    /// The largest edge strain at each step `0..=T` (step 0 is the rest state: 0).
    pub max_per_step: Vec<f64>,
    /// The largest over every step.
    pub max: f64,
}

/// The strain of the rollout `states` (`T + 1` states) of `model`.
pub fn strain_report(model: &Model, states: &[Tensor]) -> StrainReport {
    let max_per_step = model.max_strain_per_step(states);
    let max = max_per_step.iter().copied().fold(0.0, f64::max);
    StrainReport { max_per_step, max }
}

/// Strain above which a plan without a `task.limits.max_strain` gets a warning: 10%.
pub const STRAIN_WARNING_THRESHOLD: f64 = 0.1;

/// A one-line warning when a feasible `result` stretches an edge beyond
/// [`STRAIN_WARNING_THRESHOLD`] and the scene sets no `max_strain` limit; `None` otherwise (an
/// infeasible plan gets its own one-line error and must not be executed anyway).
pub fn strain_warning(model: &Model, result: &PlanResult) -> Option<String> {
    let strain = &result.strain;
    if !result.is_feasible()
        || model.task.limits.max_strain.is_some()
        || strain.max <= STRAIN_WARNING_THRESHOLD
    {
        return None;
    }
    let step = strain
        .max_per_step
        .iter()
        .position(|&s| s == strain.max)
        .unwrap_or(0);
    Some(format!(
        "the plan stretches an edge to {:.2}× its rest length (strain {:.1}% at step {step}, \
         above {:.0}%); set task.limits.max_strain to bound it",
        1.0 + strain.max,
        100.0 * strain.max,
        100.0 * STRAIN_WARNING_THRESHOLD
    ))
}
