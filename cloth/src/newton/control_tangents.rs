//! How a Newton-converged rollout moves with its controls: forward sensitivities `∂x_t/∂U`.
//!
//! At a step's minimizer `∇_f Φ(x_t; x_{t−1}, u_t) = 0`. Differentiating along a direction `U̇`
//! of the controls,
//!
//! ```text
//! H_ff ẋ_{t,f} = M ẋ_{t−1,f} − D_xy ẋ_{t−1} − H_fc ẋ_{t,c},   ẋ_{t,c} = ẋ_{t−1,c} + u̇_t,
//! ```
//!
//! the terms of [`super::sensitivity`] with the control particles' move added (their coupling
//! `H_fc` is the Newton predictor's, [`super::predictor`]). One factorization per step serves
//! every control coordinate; a direction whose steps all come after `t` leaves `x_t` unchanged,
//! so step `t` solves for the first `t · 3K` coordinates only. The implicit gradient
//! ([`super::implicit`]) is the transpose of the same map; forward mode serves a planner that
//! needs `∂x_t/∂U` itself: the states a trial's rollout is predicted to reach, to start each
//! step's solve on the branch the current rollout is on ([`Model::simulate_newton_guided`]).

use super::solve::NewtonSystem;
use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use autodiff::Tensor;

/// `∂x_t/∂U` of a rollout: per step `t = 0…T`, a `(T · 3K) × 3N` tensor whose row `j` is the
/// derivative of `x_t` (full `N × 3` data, control particles included) by control coordinate
/// `j` (the controls' flat order, [`Controls`]).
pub struct ControlTangents {
    /// `T + 1` tensors, the first zero.
    pub steps: Vec<Tensor>,
}

impl ControlTangents {
    /// The predicted move of `x_t` for the controls' move `du` (flat, `T · 3K`): `Σ_j du_j
    /// ∂x_t/∂U_j`, as full `N × 3` data.
    pub fn predict(&self, t: usize, du: &[f64]) -> Vec<f64> {
        let s = &self.steps[t];
        let mut out = vec![0.0; s.cols()];
        for (j, &d) in du.iter().enumerate().filter(|(_, d)| **d != 0.0) {
            for (o, v) in out.iter_mut().zip(s.row(j)) {
                *o += d * v;
            }
        }
        out
    }
}

impl Model {
    /// `∂x_t/∂U` of a rollout simulated with Newton's method ([`Model::simulate_newton`]), by
    /// the implicit function theorem (module docs): one factorization of the exact Hessian per
    /// step.
    ///
    /// # Errors
    /// [`ClothError::NewtonUnsupported`] for a model Newton cannot solve;
    /// [`ClothError::NewtonSaddle`] where a state's exact Hessian is not positive definite (not
    /// a minimizer: its tangent is not defined); a controls shape error.
    ///
    /// # Panics
    /// If `states` holds fewer than `T + 1` states.
    pub fn newton_control_tangents(
        &self,
        states: &[Tensor],
        controls: &Controls,
    ) -> Result<ControlTangents, ClothError> {
        self.check_controls(controls)?;
        let mut system = NewtonSystem::new(self)?;
        let (n, horizon, n_dof) = (self.n_particles(), self.task.horizon, system.pattern.n_dof);
        let width = controls.cols();
        let n_cols = horizon * width;
        let mut steps = vec![Tensor::zeros(n_cols, 3 * n)];
        let mut coupling: Vec<(usize, usize, f64)> = Vec::new();
        for t in 1..=horizon {
            let x = &states[t];
            self.factorize_converged(&mut system, states, controls, t)?;
            coupling.clear();
            system
                .pattern
                .control_coupling(x.data(), |c, f, h| coupling.push((c, f, h)));
            // Directions through step t's controls or earlier ones move x_t.
            let live = t * width;
            let mut moved = steps[t - 1].clone();
            for j in (t - 1) * width..live {
                let (g, d) = ((j % width) / 3, j % 3);
                let p = self.controls.as_slice()[g];
                moved.row_mut(j)[3 * p + d] += 1.0;
            }
            let mut rhs = vec![0.0; n_dof * live];
            for (j, col) in rhs.chunks_exact_mut(n_dof.max(1)).take(live).enumerate() {
                let dx = moved.row(j);
                self.add_previous_tangent(&system, x.data(), steps[t - 1].row(j), col);
                for &(c, f, h) in &coupling {
                    col[f] -= h * dx[c];
                }
                system.contacts.project_tangent(col);
            }
            if n_dof > 0 {
                system.factor.solve_in_place(&mut rhs, live);
            }
            for (j, z) in rhs.chunks_exact_mut(n_dof.max(1)).take(live).enumerate() {
                system.contacts.project_tangent(z);
                system.pattern.scatter(z, moved.row_mut(j));
            }
            steps.push(moved);
        }
        Ok(ControlTangents { steps })
    }
}
