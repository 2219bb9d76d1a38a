//! The warning a plan gets when it stretches an edge beyond 10% with no `task.limits.max_strain`
//! bounding it. The largest edge strain per step is the result's `strain` section
//! ([`StrainReport`], in [`crate::result`]).

use crate::result::PlanResult;
// The `strain` section of a result, from `crate::result`: re-exported for this module's callers.
pub use crate::result::{strain_report, StrainReport};
use cloth::Model;

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
