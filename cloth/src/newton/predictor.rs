//! Where a control stage of a self-contact step starts: the Newton predictor. Differentiating
//! `∇_f Φ(x_f, x_c) = 0` gives the free particles' first-order response to a move of the control
//! particles, `dx_f = −H_ff⁻¹ H_fc dx_c` (tangent to the active contact rows, as in
//! [`super::implicit`]); with `∇_f Φ` at the start added, it is the first Newton step of the
//! moved system. A stage that moves only the grippers ([`NewtonSystem::solve_moving_controls`])
//! stops where they would squeeze the cloth they press on (the step filter keeps every pair's
//! gap above a tenth of what it was), so a gripper pressed onto cloth lying on a table crawls
//! there in tens of staged solves; moved with the grippers by its response, the cloth makes way
//! in the filter's eyes too.
//!
//! Not used to start every solve: on `drop` lowered by 0.2 m a step, the response compresses
//! the hanging sheet (the mass term holds its bottom back) and Newton from there crawls along
//! the buckling mode for 500 iterations where it converges from the previous state.

use super::assembly::Pattern;
use super::solve::NewtonSystem;
use autodiff::Tensor;

impl Pattern {
    /// The control particles' move from `x` to their places in `xt` (`N × 3` data, zero on the
    /// free particles' rows).
    pub(super) fn control_move(&self, x: &Tensor, xt: &Tensor) -> Vec<f64> {
        let mut delta = vec![0.0; x.data().len()];
        for p in (0..delta.len() / 3).filter(|&p| self.dof(p).is_none()) {
            for k in 0..3 {
                delta[3 * p + k] = xt.data()[3 * p + k] - x.data()[3 * p + k];
            }
        }
        delta
    }
}

impl NewtonSystem {
    /// The fraction of the control particles' move `delta` (from [`Pattern::control_move`]) a
    /// solve from `x` for the predicted state `xt` takes, and the state it starts from, given
    /// that the step filter allows `alpha` of it with the cloth held at `x`: the predictor
    /// `x + a (δ_c, δ_f)`, `δ_f = −H_ff⁻¹ (∇_f Φ(x) + H_fc δ_c)`, at the largest fraction `a`
    /// both barriers allow along it, when that is more than `alpha`; otherwise `(alpha, x)`, as
    /// where the exact Hessian at `x` is not positive definite (the response is not defined
    /// there). Costs one factorization.
    pub(super) fn predicted_start(
        &mut self,
        x: &Tensor,
        xt: &Tensor,
        delta: &[f64],
        alpha: f64,
    ) -> (f64, Tensor) {
        self.fit_self_contact(x.data());
        if !self.factorize_exact(x.data(), xt.data()) {
            return (alpha, x.clone());
        }
        // `factorize_exact` assembled ∇_f Φ(x) too.
        let mut rhs: Vec<f64> = self.grad.iter().map(|g| -g).collect();
        self.pattern
            .control_coupling(x.data(), |c, f, h| rhs[f] -= h * delta[c]);
        self.contacts.project_tangent(&mut rhs);
        self.factor.solve_in_place(&mut rhs, 1);
        self.contacts.project_tangent(&mut rhs);
        let mut full = delta.to_vec();
        for p in 0..full.len() / 3 {
            if let Some(d) = self.pattern.dof(p) {
                full[3 * p..3 * p + 3].copy_from_slice(&rhs[d..d + 3]);
            }
        }
        let a = self.pattern.max_move(x.data(), &full);
        if a > alpha {
            let mut start = x.clone();
            for (s, d) in start.data_mut().iter_mut().zip(&full) {
                *s += a * d;
            }
            (a, start)
        } else {
            (alpha, x.clone())
        }
    }
}
