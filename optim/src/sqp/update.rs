//! Step 5: moving to the point the line search accepted, with the damped BFGS update of the
//! Hessian approximation.

use crate::eval::{PointDerivatives, PointValues};
use crate::linalg::norm_inf;

use super::kkt::lagrangian_gradient;
use super::state::State;

impl State {
    /// Moves to the accepted point (`values`, `derivatives`, reached at step length `alpha`):
    /// updates the Hessian approximation with `s = x⁺ − x` and `y = ∇ₓL(x⁺, λ) − ∇ₓL(x, λ)`,
    /// counts the step and records it for the progress test. The new iterate's multipliers and
    /// KKT residual come from its own QP.
    pub fn advance(&mut self, values: PointValues, derivatives: PointDerivatives, alpha: f64) {
        let s_vec: Vec<f64> = values
            .x
            .iter()
            .zip(&self.pt.x)
            .map(|(a, b)| a - b)
            .collect();
        // `mult` are this step's multipliers (the QP was usable to get here).
        let gl_old = lagrangian_gradient(&self.dv, &self.mult);
        let gl_new = lagrangian_gradient(&derivatives, &self.mult);
        let y: Vec<f64> = gl_new.iter().zip(&gl_old).map(|(a, b)| a - b).collect();
        self.bfgs.update(&s_vec, &y);
        self.last_step_norm = norm_inf(&s_vec);
        self.last_alpha = alpha;
        self.pt = values;
        self.dv = derivatives;
        self.iterations += 1;
        self.progress
            .record(self.pt.objective(), self.pt.violation_inf(), alpha);
        // Multipliers/KKT of the new point come from its own QP next iteration.
        self.kkt = f64::INFINITY;
    }
}
