//! The `strain` section of a result: how far a plan stretches the cloth, the largest edge strain
//! per step ([`crate::strain`] warns about a plan stretching it too far).

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
