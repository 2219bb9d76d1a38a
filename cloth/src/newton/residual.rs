//! How far a rollout's states are from equilibrium, whichever solver made them: each step's
//! relative KKT residual `‖∇Φ‖`, measured as Newton's convergence test measures it.
//!
//! XPBD stops after a fixed number of sweeps, and its Gauss–Seidel limit is not `Φ`'s minimizer
//! (docs/physics.md, "The two solvers"); Newton stops at `physics.tolerance`. This puts both on
//! one scale, so that a result can say whether its verdict rests on converged physics.

use super::solve::NewtonSystem;
use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::xpbd::set::Carry;
use autodiff::Tensor;

/// Each step's distance from equilibrium ([`Model::equilibrium_residuals`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Equilibrium {
    /// Per step `1..=T`: `‖∇Φ(x_t)‖` (normal components of active rigid contacts removed) over
    /// the step's scale, the larger of `‖∇Φ‖` at the predicted state `x̃` (projected onto the rigid
    /// contacts) and at the previous state with its grippers moved (with barriers): the relative
    /// residual Newton's `physics.tolerance` bounds.
    pub per_step: Vec<f64>,
    /// Forces the residual leaves out, in words, when the model has any: XPBD's rigid friction
    /// and its self-contact rows are not terms of `Φ`, so where they act the residual overstates
    /// the imbalance.
    pub uncounted: Option<&'static str>,
}

impl Equilibrium {
    /// The largest residual and its step (1-based); `None` for a rollout without steps.
    pub fn max(&self) -> Option<(f64, usize)> {
        self.per_step
            .iter()
            .enumerate()
            .map(|(t, &r)| (r, t + 1))
            .fold(None, |best, (r, t)| match best {
                Some((b, _)) if b >= r || r.is_nan() => best,
                _ => Some((r, t)),
            })
    }
}

impl Model {
    /// How far each of `states` (`T + 1` of them, from [`Model::simulate`] of `controls` under
    /// any solver) is from the minimizer of its step's `Φ`.
    ///
    /// # Errors
    /// [`ClothError::NewtonUnsupported`] for a model without a finite energy (a rigid material or
    /// constraint), whose equilibrium is not a minimizer of `Φ`; the controls' shape errors of
    /// [`Model::check_controls`].
    pub fn equilibrium_residuals(
        &self,
        states: &[Tensor],
        controls: &Controls,
    ) -> Result<Equilibrium, ClothError> {
        self.check_controls(controls)?;
        let mut system = NewtonSystem::new(self)?;
        let per_step = (1..states.len().min(self.task.horizon + 1))
            .map(|t| {
                let (x_prev, x) = (&states[t - 1], &states[t]);
                let xt = self.begin_step(x_prev, &self.step_controls(controls, t - 1));
                system.begin_step(x_prev);
                let (_, scale) = system.start_at(x_prev, &xt);
                system.fit_self_contact(x.data());
                system.assemble_gradient_at(x.data(), xt.data());
                let residual = system.residual();
                if scale > 0.0 {
                    residual / scale
                } else {
                    residual
                }
            })
            .collect();
        Ok(Equilibrium {
            per_step,
            uncounted: self.uncounted_forces(),
        })
    }

    /// XPBD's forces that are not terms of `Φ` ([`Equilibrium::uncounted`]).
    fn uncounted_forces(&self) -> Option<&'static str> {
        let friction = self
            .sets()
            .any(|s| matches!(s.carry, Carry::StartPosition { .. }));
        let self_contact = self.self_collision.is_some() && self.self_barrier.is_none();
        match (friction, self_contact) {
            (true, true) => Some("XPBD's friction and self-contact forces are not counted"),
            (true, false) => Some("XPBD's friction forces are not counted"),
            (false, true) => Some("XPBD's self-contact forces are not counted"),
            (false, false) => None,
        }
    }
}
