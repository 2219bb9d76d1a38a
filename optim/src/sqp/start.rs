//! The start of a run: the initial Hessian a problem may supply, and the first iterate.

use crate::bfgs::DampedBfgs;
use crate::error::OptimError;
use crate::eval::Evaluator;
use crate::problem::Problem;
use crate::status::{Multipliers, Solution, Status};
use std::time::Instant;

use super::progress::Progress;
use super::state::State;
use super::SqpSolver;

/// The problem's [`Problem::initial_hessian`] as a row-major `n × n` array, checked for its size
/// and for being symmetric positive definite; `None` when the problem supplies none.
pub(super) fn initial_hessian<P: Problem + ?Sized>(
    ev: &Evaluator<'_, P>,
) -> Result<Option<Vec<f64>>, OptimError> {
    let n = ev.n;
    match ev.problem.initial_hessian() {
        None => Ok(None),
        Some(b0) => {
            if b0.nrows() != n || b0.ncols() != n {
                return Err(OptimError::DimensionMismatch {
                    what: "initial Hessian rows/columns".into(),
                    expected: n,
                    got: if b0.nrows() != n {
                        b0.nrows()
                    } else {
                        b0.ncols()
                    },
                });
            }
            if !b0.is_symmetric_positive_definite() {
                return Err(OptimError::InvalidProblem(
                    "initial Hessian must be symmetric positive definite".into(),
                ));
            }
            Ok(Some(b0.as_slice().to_vec()))
        }
    }
}

/// Zero multipliers for every constraint, bound and norm term of the problem.
fn no_multipliers<P: Problem + ?Sized>(ev: &Evaluator<'_, P>) -> Multipliers {
    Multipliers {
        inequality: vec![0.0; ev.m],
        equality: vec![0.0; ev.q],
        lower_bound: vec![0.0; ev.n],
        upper_bound: vec![0.0; ev.n],
        norm_terms: ev.norms.iter().map(|nd| vec![0.0; nd.dim()]).collect(),
    }
}

/// The [`Status::EvaluationFailed`] solution of a run whose starting point (`x`, projected onto
/// the bounds) could not be evaluated, saying so in `message`.
pub(super) fn failed_start<P: Problem + ?Sized>(
    ev: &Evaluator<'_, P>,
    message: String,
    x: Vec<f64>,
    start: Instant,
) -> Solution {
    Solution {
        status: Status::EvaluationFailed,
        message,
        x,
        objective: f64::NAN,
        constraint_violation: f64::NAN,
        kkt_residual: f64::NAN,
        iterations: 0,
        function_evaluations: ev.function_evaluations,
        gradient_evaluations: ev.gradient_evaluations,
        multipliers: no_multipliers(ev),
        solve_time: start.elapsed().as_secs_f64(),
        hessian: None,
    }
}

impl SqpSolver {
    /// The state at the first iterate: `x0` projected onto the bounds, its values and derivatives
    /// (the constraints scaled, [`SqpSettings::max_constraint_gradient`](crate::SqpSettings)),
    /// recorded for the progress test, with the initial penalty weights and the Hessian
    /// approximation `bfgs`. `Err` with a message and the projected `x0` when an evaluation fails.
    pub(super) fn start<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        x0: &[f64],
        bfgs: DampedBfgs,
    ) -> Result<State, (String, Vec<f64>)> {
        let s = &self.settings;
        let mut x = x0.to_vec();
        ev.project(&mut x);
        let mut pt = match ev.values(&x) {
            Ok(v) => v,
            Err(e) => return Err((format!("evaluation failed at the starting point: {e}"), x)),
        };
        let mut dv = match ev.derivatives(&x) {
            Ok(v) => v,
            Err(e) => {
                let msg = format!("derivative evaluation failed at the starting point: {e}");
                return Err((msg, x));
            }
        };

        if s.max_constraint_gradient.is_finite() {
            ev.set_scaling(s.max_constraint_gradient, &mut pt, &mut dv);
        }
        let mut progress = Progress::new(s.progress_window, s.tol_progress, s.tol_feasibility);
        progress.record(pt.objective(), pt.violation_inf(), 1.0);
        Ok(State {
            penalty: vec![s.elastic_weight; ev.m + ev.q],
            iterations: 0,
            last_step_norm: 0.0,
            last_alpha: 0.0,
            best_violation: pt.violation_inf(),
            mult: no_multipliers(ev),
            kkt: f64::INFINITY,
            reported: None,
            pt,
            dv,
            bfgs,
            progress,
        })
    }
}
