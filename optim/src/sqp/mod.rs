//! The SQP solver: damped-BFGS quasi-Newton SQP with elastic ℓ1 QP subproblems solved by Clarabel,
//! exact second-order-cone modelling of declared norm terms, and an ℓ1 merit line search with a
//! second-order correction.
//!
//! One iteration at `x`:
//!
//! 1. Build the elastic QP ([`crate::qp`]) with the current `B`, `∇f`, `c`, `J`, norm residuals, and
//!    the step box `max(l−x, −Δ) ≤ d ≤ min(u−x, Δ)`, `Δ = step_bound_scale · max(1, ‖x‖∞)`.
//! 2. Steering of the per-constraint penalty weights `ν` (Byrd–Nocedal–Waltz): if the step leaves
//!    linearized violation, solve the feasibility LP for the best reachable violation and raise the weights
//!    of the constraints the step leaves violated until it achieves a fair share of it (all of it if the
//!    linearization is consistent). If even the LP cannot reduce the violation, `x` is a stationary point
//!    of the violation: locally infeasible.
//! 3. The KKT residual at `x` is computed *explicitly* from the problem's gradients and the QP's
//!    multipliers; `Converged` is reported only if it and the violation are within tolerance.
//! 4. Backtracking on the ℓ1 merit `φ = f + Σw‖Ax+b‖ + Σ νᵢ violᵢ` with the Armijo condition on the QP's
//!    predicted reduction; if the full step is rejected, one second-order correction is tried. A failed
//!    evaluation counts as a rejected trial and halves the step.
//! 5. Damped BFGS update with `y = ∇ₓL(x⁺, λ) − ∇ₓL(x, λ)` of the smooth part.
//!
//! A run whose feasible iterates stop lowering the objective (by less than `tol_progress`,
//! relative, over `progress_window` iterations whose steps the line search all cut) ends
//! `NoProgress` with the measured decrease ([`progress`]).
//!
//! Constraints whose gradient at `x₀` exceeds `max_constraint_gradient` are scaled down once (IPOPT's
//! rule); violations, tolerances and multipliers in the results refer to the unscaled constraints.

use crate::bfgs::DampedBfgs;
use crate::error::OptimError;
use crate::eval::Evaluator;
use crate::linalg::{norm_inf, DenseMatrix};
use crate::problem::Problem;
use crate::qp::{QpData, QpSolution, QpSubproblem};
use crate::settings::SqpSettings;
use crate::status::{IterationInfo, Multipliers, Solution, Status};
use std::ops::ControlFlow;
use std::time::Instant;

mod kkt;
mod merit;
mod progress;
mod step;

use kkt::{extract_multipliers, kkt_residual, lagrangian_gradient};
use merit::{kept_row_nears_activity, predicted_reduction, Search};
use progress::Progress;

/// The SQP solver. Create it with settings, then [`solve`](SqpSolver::solve) any number of problems.
///
/// ```
/// use optim::{Problem, EvalError, Jacobian, SqpSolver, SqpSettings, Status};
///
/// /// min x² + y²  s.t.  x + y ≥ 1
/// struct Tiny;
/// impl Problem for Tiny {
///     fn num_variables(&self) -> usize { 2 }
///     fn num_inequalities(&self) -> usize { 1 }
///     fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> { Ok(x[0] * x[0] + x[1] * x[1]) }
///     fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
///         g[0] = 2.0 * x[0];
///         g[1] = 2.0 * x[1];
///         Ok(())
///     }
///     fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
///         c[0] = x[0] + x[1] - 1.0;
///         Ok(())
///     }
///     fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
///         j.set(0, 0, 1.0);
///         j.set(0, 1, 1.0);
///         Ok(())
///     }
/// }
///
/// let solver = SqpSolver::new(SqpSettings::default()).unwrap();
/// let sol = solver.solve(&mut Tiny, &[3.0, -1.0]).unwrap();
/// assert_eq!(sol.status, Status::Converged);
/// assert!((sol.x[0] - 0.5).abs() < 1e-6 && (sol.x[1] - 0.5).abs() < 1e-6);
/// ```
#[derive(Clone, Debug, Default)]
pub struct SqpSolver {
    settings: SqpSettings,
}

/// The QP step at one iterate, after penalty steering.
struct Step {
    qp: QpSubproblem,
    sol: QpSolution,
    /// Penalty weights the solution was computed with.
    penalty: Vec<f64>,
    /// Linearized ℓ1 violation left by `sol.d`.
    lin_violation: f64,
    /// The feasibility LP could not reduce the linearized violation.
    infeasible_stationary: bool,
}

impl SqpSolver {
    /// A solver with validated settings.
    pub fn new(settings: SqpSettings) -> Result<Self, OptimError> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings in use.
    pub fn settings(&self) -> &SqpSettings {
        &self.settings
    }

    /// Minimizes `problem` from `x0` (projected onto the bounds first).
    ///
    /// `Err` only for invalid input (dimensions, bounds, starting point, initial Hessian); everything
    /// that happens during the iterations is reported in [`Solution::status`].
    pub fn solve<P: Problem + ?Sized>(
        &self,
        problem: &mut P,
        x0: &[f64],
    ) -> Result<Solution, OptimError> {
        self.solve_with_callback(problem, x0, |_| ControlFlow::Continue(()))
    }

    /// Like [`solve`](SqpSolver::solve), calling `callback` once per iteration; returning
    /// `ControlFlow::Break(())` stops the run with [`Status::Interrupted`].
    pub fn solve_with_callback<P, F>(
        &self,
        problem: &mut P,
        x0: &[f64],
        mut callback: F,
    ) -> Result<Solution, OptimError>
    where
        P: Problem + ?Sized,
        F: FnMut(&IterationInfo) -> ControlFlow<()>,
    {
        let start = Instant::now();
        let s = &self.settings;
        s.validate()?;
        let mut ev = Evaluator::new(problem, x0)?;
        ev.reuse_margin = s.jacobian_reuse_margin;
        let n = ev.n;
        let initial_hessian = match ev.problem.initial_hessian() {
            None => None,
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
                Some(b0.as_slice().to_vec())
            }
        };
        let mut bfgs = DampedBfgs::new(n, initial_hessian, s.bfgs_damping);
        let norms = ev.norms.clone();

        // The starting point; from the first evaluation on, the iterate is `pt.x`.
        let mut x = x0.to_vec();
        ev.project(&mut x);
        let empty_mult = Multipliers {
            inequality: vec![0.0; ev.m],
            equality: vec![0.0; ev.q],
            lower_bound: vec![0.0; n],
            upper_bound: vec![0.0; n],
            norm_terms: ev.norms.iter().map(|nd| vec![0.0; nd.rows.len()]).collect(),
        };
        let failed_start = |ev: &Evaluator<'_, P>, msg: String, x: Vec<f64>| Solution {
            status: Status::EvaluationFailed,
            message: msg,
            x,
            objective: f64::NAN,
            constraint_violation: f64::NAN,
            kkt_residual: f64::NAN,
            iterations: 0,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            multipliers: empty_mult.clone(),
            solve_time: start.elapsed().as_secs_f64(),
            hessian: None,
        };
        let mut pt = match ev.values(&x) {
            Ok(v) => v,
            Err(e) => {
                let msg = format!("evaluation failed at the starting point: {e}");
                return Ok(failed_start(&ev, msg, x));
            }
        };
        let mut dv = match ev.derivatives(&x) {
            Ok(v) => v,
            Err(e) => {
                let msg = format!("derivative evaluation failed at the starting point: {e}");
                return Ok(failed_start(&ev, msg, x));
            }
        };

        if s.max_constraint_gradient.is_finite() {
            ev.set_scaling(s.max_constraint_gradient, &mut pt, &mut dv);
        }
        let mut progress = Progress::new(s.progress_window, s.tol_progress);
        progress.record(pt.objective(), pt.violation_inf() <= s.tol_feasibility, 1.0);
        let mut penalty = vec![s.elastic_weight; ev.m + ev.q];
        let mut iterations = 0usize;
        let mut last_step_norm = 0.0;
        let mut last_alpha = 0.0;
        let mut best_violation = pt.violation_inf();
        let mut mult = empty_mult.clone();
        let mut kkt = f64::INFINITY;
        // A Hessian reset repeats an iteration; the callback sees each iteration number once.
        let mut reported: Option<usize> = None;

        // Re-evaluates the Jacobian rows kept from earlier iterates and repeats the iteration.
        macro_rules! refresh_kept_rows {
            () => {
                if dv.has_kept_rows() {
                    match ev.derivatives(&pt.x) {
                        Ok(fresh) => {
                            dv = fresh;
                            continue;
                        }
                        Err(e) => {
                            break (
                                Status::EvaluationFailed,
                                format!("derivative evaluation failed at an iterate: {e}"),
                            )
                        }
                    }
                }
            };
        }

        let (status, message) = loop {
            let xinf = norm_inf(&pt.x);
            let delta = s.step_bound_scale * xinf.max(1.0);
            let step_lower: Vec<f64> = (0..n)
                .map(|j| (ev.lower[j] - pt.x[j]).max(-delta))
                .collect();
            let step_upper: Vec<f64> = (0..n).map(|j| (ev.upper[j] - pt.x[j]).min(delta)).collect();
            let data = QpData {
                n,
                hessian: bfgs.matrix(),
                gradient: &dv.g,
                ineq: &pt.c,
                ineq_jac: &dv.jc,
                eq: &pt.h,
                eq_jac: &dv.jh,
                norms: &norms,
                norm_residuals: &pt.residuals,
                step_lower: &step_lower,
                step_upper: &step_upper,
            };
            let mut step = match self.compute_step(&data, &pt, &dv, &mut penalty) {
                Ok(step) => step,
                Err(msg) => {
                    refresh_kept_rows!();
                    if !bfgs.is_fresh() {
                        bfgs.reset();
                        continue;
                    }
                    break (
                        Status::Stalled,
                        format!("QP subproblem could not be set up: {msg}"),
                    );
                }
            };
            let qp_usable = step.sol.outcome.is_usable();
            if qp_usable && kept_row_nears_activity(&ev, &pt, &dv, &step.sol.d) {
                refresh_kept_rows!();
            }
            if qp_usable {
                mult =
                    extract_multipliers(&step.sol, &pt.x, &ev.lower, &ev.upper, delta, &ev.norms);
                kkt = kkt_residual(&pt, &dv, &mult, &ev.norms, &ev.lower, &ev.upper);
            }
            let viol = pt.violation_inf();
            best_violation = best_violation.min(viol);
            if reported != Some(iterations) {
                reported = Some(iterations);
                let info = IterationInfo {
                    iteration: iterations,
                    objective: pt.objective(),
                    constraint_violation: viol,
                    kkt_residual: kkt,
                    step_norm: last_step_norm,
                    step_length: last_alpha,
                    penalty: step.penalty.iter().fold(0.0, |a: f64, b| a.max(*b)),
                    linearized_violation: step.lin_violation,
                    function_evaluations: ev.function_evaluations,
                    gradient_evaluations: ev.gradient_evaluations,
                    x: pt.x.clone(),
                };
                if callback(&info).is_break() {
                    break (Status::Interrupted, "stopped by the callback".into());
                }
            }
            if viol <= s.tol_feasibility && kkt <= s.tol_optimality {
                break (
                    Status::Converged,
                    format!("KKT residual {kkt:.2e} and violation {viol:.2e} within tolerance"),
                );
            }
            if qp_usable && viol > s.tol_feasibility && step.infeasible_stationary {
                refresh_kept_rows!();
                break (
                    Status::Infeasible { best_violation },
                    format!(
                        "no step can reduce the linearized violation {:.3e}: locally infeasible",
                        pt.violation_l1()
                    ),
                );
            }
            if let Some(stall) = progress.stalled() {
                refresh_kept_rows!();
                break (
                    Status::NoProgress,
                    format!("{stall}; KKT residual {kkt:.2e}"),
                );
            }
            if iterations >= s.max_iterations {
                break (Status::IterationLimit, format!("{iterations} iterations"));
            }
            if ev.function_evaluations >= s.max_function_evaluations {
                break (
                    Status::IterationLimit,
                    format!("{} function evaluations", ev.function_evaluations),
                );
            }

            // The step and its predicted merit reduction.
            let d: Vec<f64> = step
                .sol
                .d
                .iter()
                .zip(step_lower.iter().zip(&step_upper))
                .map(|(v, (l, u))| v.clamp(*l, *u))
                .collect();
            let pred = predicted_reduction(&pt, &dv, &bfgs, &ev.norms, &d, &step.penalty);
            let negligible = norm_inf(&d) <= s.tol_step * (1.0 + xinf);
            let descent = pred > 0.0;
            if !qp_usable || negligible || !descent || d.iter().any(|v| !v.is_finite()) {
                refresh_kept_rows!();
                if !bfgs.is_fresh() {
                    bfgs.reset();
                    continue;
                }
                let why = if !qp_usable {
                    format!("QP subproblem failed ({:?})", step.sol.outcome)
                } else {
                    format!(
                        "negligible step (‖d‖∞ = {:.2e}, predicted reduction {pred:.2e})",
                        norm_inf(&d)
                    )
                };
                break (Status::Stalled, why);
            }

            let search = self.line_search(&mut ev, &pt, &dv, &d, pred, &step.penalty, &mut step.qp);
            match search {
                Search::Accepted {
                    values,
                    derivatives,
                    alpha,
                } => {
                    let s_vec: Vec<f64> = values.x.iter().zip(&pt.x).map(|(a, b)| a - b).collect();
                    // `mult` are this step's multipliers (the QP was usable to get here).
                    let gl_old = lagrangian_gradient(&dv, &mult);
                    let gl_new = lagrangian_gradient(&derivatives, &mult);
                    let y: Vec<f64> = gl_new.iter().zip(&gl_old).map(|(a, b)| a - b).collect();
                    bfgs.update(&s_vec, &y);
                    last_step_norm = norm_inf(&s_vec);
                    last_alpha = alpha;
                    pt = *values;
                    dv = *derivatives;
                    iterations += 1;
                    progress.record(
                        pt.objective(),
                        pt.violation_inf() <= s.tol_feasibility,
                        alpha,
                    );
                    // Multipliers/KKT of the new point come from its own QP next iteration.
                    kkt = f64::INFINITY;
                }
                Search::Budget => {
                    break (
                        Status::IterationLimit,
                        format!(
                            "{} function evaluations (during a line search)",
                            ev.function_evaluations
                        ),
                    );
                }
                Search::Failed {
                    all_evaluations_failed,
                    last_error,
                } => {
                    refresh_kept_rows!();
                    if !bfgs.is_fresh() {
                        bfgs.reset();
                        continue;
                    }
                    if all_evaluations_failed {
                        break (
                            Status::EvaluationFailed,
                            format!(
                                "no evaluable point along the step: {}",
                                last_error.unwrap_or_default()
                            ),
                        );
                    }
                    break (
                        Status::Stalled,
                        "line search failed even after a Hessian reset".into(),
                    );
                }
            }
        };

        // Multipliers of the scaled constraints sᵢcᵢ → multipliers of cᵢ.
        for (l, sc) in mult.inequality.iter_mut().zip(&ev.c_scale) {
            *l *= sc;
        }
        for (l, sc) in mult.equality.iter_mut().zip(&ev.h_scale) {
            *l *= sc;
        }
        Ok(Solution {
            status,
            message,
            objective: pt.objective(),
            constraint_violation: pt.violation_inf(),
            kkt_residual: kkt,
            x: pt.x,
            iterations,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            multipliers: mult,
            solve_time: start.elapsed().as_secs_f64(),
            // Only a matrix another solve accepts as its initial Hessian: BFGS keeps it symmetric,
            // but in floating point a badly conditioned one can fail the Cholesky test.
            hessian: DenseMatrix::from_row_major(n, n, bfgs.matrix().to_vec())
                .filter(DenseMatrix::is_symmetric_positive_definite),
        })
    }
}
