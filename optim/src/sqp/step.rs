//! Step 1: the elastic QP at an iterate, within the step box.

use crate::eval::{PointDerivatives, PointValues};
use crate::linalg::norm_inf;
use crate::problem::NormData;
use crate::qp::{QpData, QpMode, QpSolution, QpSubproblem};

use super::kkt::linearized_violation;
use super::SqpSolver;

/// The QP step at one iterate, after penalty steering.
pub(super) struct Step {
    pub qp: QpSubproblem,
    pub sol: QpSolution,
    /// Penalty weights the solution was computed with.
    pub penalty: Vec<f64>,
    /// Linearized ℓ1 violation left by `sol.d`.
    pub lin_violation: f64,
    /// The feasibility LP could not reduce the linearized violation.
    pub infeasible_stationary: bool,
}

/// The step box at `x`: `max(l−x, −Δ) ≤ d ≤ min(u−x, Δ)`, `Δ = step_bound_scale · max(1, ‖x‖∞)`.
pub(super) struct StepBox {
    /// `‖x‖∞`.
    pub xinf: f64,
    /// The step bound `Δ`.
    pub delta: f64,
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl StepBox {
    /// The box at `x` within the variable bounds `lower`, `upper`.
    pub fn new(x: &[f64], lower: &[f64], upper: &[f64], step_bound_scale: f64) -> Self {
        let n = x.len();
        let xinf = norm_inf(x);
        let delta = step_bound_scale * xinf.max(1.0);
        let step_lower: Vec<f64> = (0..n).map(|j| (lower[j] - x[j]).max(-delta)).collect();
        let step_upper: Vec<f64> = (0..n).map(|j| (upper[j] - x[j]).min(delta)).collect();
        StepBox {
            xinf,
            delta,
            lower: step_lower,
            upper: step_upper,
        }
    }

    /// The QP data at the iterate `pt` (derivatives `dv`, Hessian approximation `hessian`,
    /// row-major) in this box.
    pub fn qp_data<'a>(
        &'a self,
        hessian: &'a [f64],
        pt: &'a PointValues,
        dv: &'a PointDerivatives,
        norms: &'a [NormData],
    ) -> QpData<'a> {
        QpData {
            n: self.lower.len(),
            hessian,
            gradient: &dv.g,
            ineq: &pt.c,
            ineq_jac: &dv.jc,
            eq: &pt.h,
            eq_jac: &dv.jh,
            norms,
            norm_rows: norms
                .iter()
                .zip(&dv.norm_jac)
                .map(|(nd, jac)| nd.rows(jac))
                .collect(),
            norm_residuals: &pt.residuals,
            step_lower: &self.lower,
            step_upper: &self.upper,
        }
    }

    /// `d` clamped into the box.
    pub fn clamp(&self, d: &[f64]) -> Vec<f64> {
        d.iter()
            .zip(self.lower.iter().zip(&self.upper))
            .map(|(v, (l, u))| v.clamp(*l, *u))
            .collect()
    }
}

impl SqpSolver {
    /// Solves the elastic QP with the penalty weights `penalty` and steers them
    /// ([`SqpSolver::steer_penalty`], which raises `penalty` in place).
    pub(super) fn compute_step(
        &self,
        data: &QpData<'_>,
        pt: &PointValues,
        dv: &PointDerivatives,
        penalty: &mut [f64],
    ) -> Result<Step, String> {
        let s = &self.settings;
        let mut qp = QpSubproblem::new(
            data,
            QpMode::Optimality,
            penalty,
            s.qp_tolerance,
            s.qp_max_iterations,
        )
        .map_err(|e| e.0)?;
        let sol = qp.solve();
        let lin_violation = linearized_violation(pt, dv, &sol.d);
        let mut step = Step {
            qp,
            sol,
            penalty: penalty.to_vec(),
            lin_violation,
            infeasible_stationary: false,
        };
        let scale = 1.0 + norm_inf(&pt.c).max(norm_inf(&pt.h));
        let lin_tol = s.tol_feasibility.max(10.0 * s.qp_tolerance * scale);
        if step.sol.outcome.is_usable() && step.lin_violation > lin_tol {
            self.steer_penalty(data, pt, dv, penalty, &mut step, lin_tol)?;
        }
        Ok(step)
    }
}
