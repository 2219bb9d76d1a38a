//! The `measures` section of a result: the cloth benchmarks' measures of the final state, so that
//! a plan can be compared with SoftGym's and DaXBench's numbers.

use super::task::target_errors;
use autodiff::Tensor;
use cloth::Model;
use serde::{Deserialize, Serialize};

/// Measures of a plan's final state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Measures {
    /// Normalized coverage: the area the cloth covers seen along gravity over its flat area
    /// ([`cloth::Model::coverage`]; 1 for a cloth lying flat, 0.5 folded in half); `null`
    /// without gravity.
    pub coverage: Option<f64>,
    /// The mean distance of the particles from their targets, where the scene gives every
    /// particle one (`task.target_mesh`, or `task.targets` naming every particle); `null`
    /// otherwise.
    pub mean_particle_distance: Option<f64>,
}

impl Measures {
    /// The measures of `final_state` on `model`.
    pub fn of(model: &Model, final_state: &Tensor) -> Self {
        let targets = model.task.targets.as_slice();
        let n = model.n_particles();
        let mut named = vec![false; n];
        let every = targets.len() == n
            && targets
                .iter()
                .all(|&p| !std::mem::replace(&mut named[p], true));
        let mean_particle_distance = (every && n > 0)
            .then(|| target_errors(model, final_state).iter().sum::<f64>() / n as f64);
        Measures {
            coverage: model.coverage(final_state),
            mean_particle_distance,
        }
    }
}
