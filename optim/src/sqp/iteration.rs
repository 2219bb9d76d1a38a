//! One iteration, step by step: the QP step with penalty steering (steps 1–2 of the
//! [module docs](super)), the multipliers and KKT residual (3), the callback and the status
//! tests, the merit line search (4) and the BFGS update (5).

use crate::eval::Evaluator;
use crate::problem::Problem;
use crate::status::{IterationInfo, Status};
use std::ops::ControlFlow;

use super::merit::{predicted_reduction, Search};
use super::retry::kept_row_nears_activity;
use super::state::State;
use super::step::StepBox;
use super::stopping::unusable_step;
use super::SqpSolver;

/// What the iteration loop does after an iteration.
pub(super) enum Next {
    /// Iterates again: from the point the step reached, or from the same iterate after a
    /// refresh of its kept Jacobian rows or a Hessian reset.
    Continue,
    /// The run ends with this status and message.
    Stop(Status, String),
}

impl SqpSolver {
    /// One iteration at `state`'s iterate.
    pub(super) fn iterate<P, F>(
        &self,
        ev: &mut Evaluator<'_, P>,
        state: &mut State,
        callback: &mut F,
    ) -> Next
    where
        P: Problem + ?Sized,
        F: FnMut(&IterationInfo) -> ControlFlow<()>,
    {
        let s = &self.settings;
        let bx = StepBox::new(&state.pt.x, &ev.lower, &ev.upper, s.step_bound_scale);
        let data = bx.qp_data(state.bfgs.matrix(), &state.pt, &state.dv, &ev.norms);
        let mut step = match self.compute_step(&data, &state.pt, &state.dv, &mut state.penalty) {
            Ok(step) => step,
            Err(msg) => {
                return state.retry_or(ev, || {
                    let why = format!("QP subproblem could not be set up: {msg}");
                    (Status::Stalled, why)
                })
            }
        };
        let qp_usable = step.sol.outcome.is_usable();
        if qp_usable && kept_row_nears_activity(ev, &state.pt, &state.dv, &step.sol.d) {
            if let Some(next) = state.refresh_kept_rows(ev) {
                return next;
            }
        }
        if qp_usable {
            state.update_multipliers(ev, &step.sol, bx.delta);
        }
        let viol = state.pt.violation_inf();
        state.best_violation = state.best_violation.min(viol);
        if state.report(ev, &step, viol, callback).is_break() {
            return Next::Stop(Status::Interrupted, "stopped by the callback".into());
        }
        if let Some(next) = self.stop_test(ev, state, qp_usable && step.infeasible_stationary, viol)
        {
            return next;
        }

        // The step and its predicted merit reduction.
        let d = bx.clamp(&step.sol.d);
        let pred = predicted_reduction(
            &state.pt,
            &state.dv,
            &state.bfgs,
            &ev.norms,
            &d,
            &step.penalty,
        );
        if !self.is_usable(qp_usable, &d, pred, bx.xinf) {
            return state.retry_or(ev, || unusable_step(&step, qp_usable, &d, pred));
        }
        let search = self.line_search(
            ev,
            &state.pt,
            &state.dv,
            &d,
            pred,
            &step.penalty,
            &mut step.qp,
            &state.bfgs,
        );
        self.conclude(ev, state, search)
    }

    /// After the line search: the step is taken ([`State::advance`]), or the function
    /// evaluations have run out, or the iteration is repeated ([`State::retry_or`]).
    fn conclude<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        state: &mut State,
        search: Search,
    ) -> Next {
        match search {
            Search::Accepted {
                values,
                derivatives,
                alpha,
            } => {
                state.advance(*values, *derivatives, alpha);
                Next::Continue
            }
            Search::Budget => Next::Stop(
                Status::IterationLimit,
                format!(
                    "{} function evaluations (during a line search)",
                    ev.function_evaluations
                ),
            ),
            Search::Interrupted(why) => Next::Stop(
                Status::Interrupted,
                format!("stopped during a line search: {why}"),
            ),
            Search::Failed {
                all_evaluations_failed,
                last_error,
            } => state.retry_or(ev, || {
                if all_evaluations_failed {
                    (
                        Status::EvaluationFailed,
                        format!(
                            "no evaluable point along the step: {}",
                            last_error.unwrap_or_default()
                        ),
                    )
                } else {
                    (
                        Status::Stalled,
                        "line search failed even after a Hessian reset".into(),
                    )
                }
            }),
        }
    }
}
