//! The status tests: convergence, local infeasibility, no progress and the limits before a
//! step, and the step the iteration cannot take.

use crate::eval::Evaluator;
use crate::linalg::norm_inf;
use crate::problem::Problem;
use crate::status::Status;

use super::iteration::Next;
use super::state::State;
use super::step::Step;
use super::SqpSolver;

impl SqpSolver {
    /// The tests before a step, at an iterate of max-norm violation `viol` whose QP step found
    /// the violation stationary (`infeasible_stationary`, from a usable QP): `Converged`,
    /// `Infeasible` and `NoProgress` (each after a refresh of kept Jacobian rows, which repeats
    /// the iteration instead), and the iteration and evaluation limits. `None`: go on.
    pub(super) fn stop_test<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        state: &mut State,
        infeasible_stationary: bool,
        viol: f64,
    ) -> Option<Next> {
        let s = &self.settings;
        let kkt = state.kkt;
        if viol <= s.tol_feasibility && kkt <= s.tol_optimality {
            return Some(Next::Stop(
                Status::Converged,
                format!("KKT residual {kkt:.2e} and violation {viol:.2e} within tolerance"),
            ));
        }
        if viol > s.tol_feasibility && infeasible_stationary {
            if let Some(next) = state.refresh_kept_rows(ev) {
                return Some(next);
            }
            return Some(Next::Stop(
                Status::Infeasible {
                    best_violation: state.best_violation,
                },
                format!(
                    "no step can reduce the linearized violation {:.3e}: locally infeasible",
                    state.pt.violation_l1()
                ),
            ));
        }
        let goal = ev.problem.goal_reached(&state.pt.x);
        state.progress.annotate_last(kkt, goal);
        if let Some(stall) = state.progress.stalled() {
            if let Some(next) = state.refresh_kept_rows(ev) {
                return Some(next);
            }
            return Some(Next::Stop(
                Status::NoProgress,
                format!("{stall}; KKT residual {kkt:.2e}"),
            ));
        }
        if state.iterations >= s.max_iterations {
            let why = format!("{} iterations", state.iterations);
            return Some(Next::Stop(Status::IterationLimit, why));
        }
        if ev.function_evaluations >= s.max_function_evaluations {
            return Some(Next::Stop(
                Status::IterationLimit,
                format!("{} function evaluations", ev.function_evaluations),
            ));
        }
        None
    }

    /// Whether the clamped QP step `d` (at an iterate of max-norm `xinf`) can be searched: the
    /// QP was usable, `d` is finite and not negligible, and the merit model predicts a
    /// reduction `pred > 0`.
    pub(super) fn is_usable(&self, qp_usable: bool, d: &[f64], pred: f64, xinf: f64) -> bool {
        let negligible = norm_inf(d) <= self.settings.tol_step * (1.0 + xinf);
        let descent = pred > 0.0;
        qp_usable && !negligible && descent && d.iter().all(|v| v.is_finite())
    }
}

/// The `Stalled` status and why, for a step that cannot be searched ([`SqpSolver::is_usable`]).
pub(super) fn unusable_step(
    step: &Step,
    qp_usable: bool,
    d: &[f64],
    pred: f64,
) -> (Status, String) {
    let why = if !qp_usable {
        format!("QP subproblem failed ({:?})", step.sol.outcome)
    } else {
        format!(
            "negligible step (‖d‖∞ = {:.2e}, predicted reduction {pred:.2e})",
            norm_inf(d)
        )
    };
    (Status::Stalled, why)
}
