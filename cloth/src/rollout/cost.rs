//! The paper's costs, recorded on a tape so that values and gradients come from one definition.
//!
//! Per state: target error `G = ‖x_target − x̄‖`, elastic energy `E(x) = Σ_c ½ k_c C_c(x)²`, per-particle
//! signed distance to the safety obstacles and the safety term `−Σᵢ relu(δ − SDF(xᵢ))`.
//! Over the controls: trajectory irregularity `T = Σ_{t≥1} ‖u_t − u_{t−1}‖`.
//!
//! Conventions: `G` and every norm in `T` have gradient 0 where the norm is 0; `relu` has
//! gradient 0 at its kink (a particle exactly at `δ` counts as safe and exerts no pull); the
//! minimum over spheres passes the gradient to the first sphere on a tie.

use crate::controls::Controls;
use crate::model::Model;
use crate::sdf::rows::{ParticleSdf, ParticleSdfComponents};
use autodiff::{DynRowFn, Tape, Tensor, Var};
use std::sync::Arc;

/// A soft-min entry whose weight is below `e^−NEGLIGIBLE_WEIGHT_EXPONENT` relative to the
/// smallest entry's does not matter: [`Model::record_sdf_components_for_soft_min`] need not
/// query it exactly.
pub const NEGLIGIBLE_WEIGHT_EXPONENT: f64 = 40.0;

impl Model {
    /// Records `E(x)`; `None` when no constraint carries elastic energy.
    pub fn record_energy(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let mut total: Option<Var> = None;
        for (f, index) in self.groups.iter().filter_map(|g| g.energy.as_ref()) {
            let rows = tape.gather(x, index);
            let per = tape.map_rows(f, rows);
            let e = tape.sum(per);
            total = Some(match total {
                Some(t) => tape.add(t, e),
                None => e,
            });
        }
        total
    }

    /// Records the signed distance of every particle to the safety obstacles (`N × 1`); `None`
    /// when the scene has none.
    pub fn record_sdf(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let f = self.safety.as_ref()?;
        Some(tape.map_rows(f, x))
    }

    /// Records the signed distance of every particle to every safety primitive
    /// (`N × primitives`); `None` when the scene has none.
    pub fn record_sdf_components(&self, tape: &mut Tape, x: Var) -> Option<Var> {
        let f = self.safety_components.as_ref()?;
        Some(tape.map_rows(f, x))
    }

    /// [`Model::record_sdf_components`] for a soft minimum of sharpness `kappa` over them (and over
    /// whatever else is concatenated with them): exact wherever an entry's soft-min weight can
    /// reach `e^−40` (within `40/κ` of this state's smallest distance, see
    /// `NEGLIGIBLE_WEIGHT_EXPONENT` in `cloth/src/rollout/cost.rs`), elsewhere a lower bound above
    /// that, so a mesh obstacle's search stops there. Without a mesh obstacle every entry is exact
    /// (bitwise [`Model::record_sdf_components`]). With one, only entries of weight below `e^−40`
    /// change: the soft minimum moves by at most `K·e^−40/κ` (`K` such entries), each weight
    /// relatively by `K·e^−40`.
    pub fn record_sdf_components_for_soft_min(
        &self,
        tape: &mut Tape,
        x: Var,
        kappa: f64,
    ) -> Option<Var> {
        if self.safety_obstacles.meshes.is_empty() {
            return self.record_sdf_components(tape, x);
        }
        self.safety_components.as_ref()?;
        let smallest = crate::sdf::batch::min_distance(&self.safety_obstacles, tape.value(x));
        let f: Arc<dyn DynRowFn> = Arc::new(ParticleSdfComponents {
            field: self.safety_obstacles.clone(),
            bound: smallest + NEGLIGIBLE_WEIGHT_EXPONENT / kappa,
        });
        Some(tape.map_rows(&f, x))
    }

    /// Records `−Σᵢ relu(δ − SDF(xᵢ))` (≥ 0 only when every particle is at least `δ` away).
    ///
    /// The distances are exact up to `δ` only (a lower bound above `δ` elsewhere: a mesh's
    /// search stops there): `relu(δ − ·)` and its derivative are 0 above `δ` either way, so the
    /// value and its gradient are bitwise those of exact distances.
    pub fn record_safety(&self, tape: &mut Tape, x: Var, delta: f64) -> Option<Var> {
        self.safety.as_ref()?;
        let f: Arc<dyn DynRowFn> = Arc::new(ParticleSdf {
            field: self.safety_obstacles.clone(),
            bound: delta,
        });
        let sdf = tape.map_rows(&f, x);
        Some(Self::record_safety_of_sdf(tape, sdf, delta))
    }

    /// [`Model::record_safety`] from already recorded signed distances `sdf` (`N × 1`).
    pub fn record_safety_of_sdf(tape: &mut Tape, sdf: Var, delta: f64) -> Var {
        let gap = tape.neg(sdf);
        let gap = tape.add_scalar(gap, delta);
        let violation = tape.relu(gap);
        let total = tape.sum(violation);
        tape.neg(total)
    }

    /// Records `G = ‖x_target − x̄‖` over the task's target particles.
    pub fn record_target_error(&self, tape: &mut Tape, x: Var) -> Var {
        let reached = tape.gather(x, &self.task.targets);
        let target = tape.leaf(self.task.target_positions.clone());
        let diff = tape.sub(reached, target);
        let sq = tape.square(diff);
        let total = tape.sum(sq);
        tape.sqrt(total)
    }
}

/// `T = Σ_{t=1}^{T−1} ‖u_t − u_{t−1}‖` and its gradient (each norm's gradient is 0 where the
/// norm is 0, e.g. everywhere on an all-zero guess).
pub fn trajectory_irregularity(controls: &Controls) -> (f64, Tensor) {
    let (steps, width) = controls.shape();
    let mut grad = Tensor::zeros(steps, width);
    let mut total = 0.0;
    for t in 1..steps {
        let diff: Vec<f64> = controls
            .row(t)
            .iter()
            .zip(controls.row(t - 1))
            .map(|(a, b)| a - b)
            .collect();
        let norm = diff.iter().map(|d| d * d).sum::<f64>().sqrt();
        total += norm;
        if norm > 0.0 {
            for (j, d) in diff.iter().enumerate() {
                grad.row_mut(t)[j] += d / norm;
                grad.row_mut(t - 1)[j] -= d / norm;
            }
        }
    }
    (total, grad)
}
