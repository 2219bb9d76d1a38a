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
//!    predicted reduction; if the full step is rejected, one second-order correction is tried (its
//!    point evaluated only when the QP's model predicts it passes the test). A failed
//!    evaluation counts as a rejected trial and halves the step.
//! 5. Damped BFGS update with `y = ∇ₓL(x⁺, λ) − ∇ₓL(x, λ)` of the smooth part.
//!
//! A residual norm `v‖r(x)‖` ([`Problem::residual_norms`](crate::Problem::residual_norms)) enters
//! the QP as the norm term `v‖r(x) + J(x)d‖` (Gauss–Newton, prox-linear): the QP and the predicted
//! reduction use this model, the merit the true `‖r(x⁺)‖`, and the BFGS update leaves it out of `y`
//! (the smooth part's Lagrangian gradient only), so `B` learns the curvature of the rest.
//!
//! A run whose iterates stop lowering the objective and, where they are infeasible, the violation
//! (by less than `tol_progress`, relative, over `progress_window` iterations whose steps the line
//! search all cut, or whose whole steps leave the KKT residual where it was at iterates that meet
//! the problem's goal) ends `NoProgress` with the measured decreases ([`progress`]). A run that
//! ends `NoProgress` or `Stalled` on an infeasible iterate is moved onto its rows by minimum-norm
//! corrections when they reach a feasible point ([`restoration`]).
//!
//! Constraints whose gradient at `x₀` exceeds `max_constraint_gradient` are scaled down once (IPOPT's
//! rule); violations, tolerances and multipliers in the results refer to the unscaled constraints.
//!
//! The files of this module follow the iteration: [`start`] (the initial Hessian, the first
//! iterate), [`state`] (what the iteration carries from one iterate to the next),
//! [`iteration`] (one iteration, step by step), [`step`] and [`steering`] (1 and 2), [`kkt`] (3),
//! [`stopping`] (the status tests), [`merit`] (4), [`update`] (5), [`retry`] (repeating an
//! iteration after a refresh of kept Jacobian rows or a Hessian reset), [`progress`] and
//! [`restoration`] (after the last iteration).

use crate::bfgs::DampedBfgs;
use crate::error::OptimError;
use crate::eval::Evaluator;
use crate::problem::Problem;
use crate::settings::SqpSettings;
use crate::status::{IterationInfo, Solution, Status};
use std::ops::ControlFlow;
use std::time::Instant;

mod iteration;
mod kkt;
mod merit;
mod progress;
mod restoration;
mod retry;
mod start;
mod state;
mod steering;
mod step;
mod stopping;
mod update;

use iteration::Next;
use start::{failed_start, initial_hessian};

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
    /// `ControlFlow::Break(())` stops the run with [`Status::Interrupted`](crate::Status::Interrupted).
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
        let bfgs = DampedBfgs::new(ev.n, initial_hessian(&ev)?, s.bfgs_damping);
        let mut state = match self.start(&mut ev, x0, bfgs) {
            Ok(state) => state,
            Err((message, x)) => return Ok(failed_start(&ev, message, x, start)),
        };
        let (status, mut message) = loop {
            if let Next::Stop(status, message) = self.iterate(&mut ev, &mut state, &mut callback) {
                break (status, message);
            }
        };
        if matches!(status, Status::NoProgress | Status::Stalled) {
            if let Some(restored) = self.restore_feasibility(&mut ev, &mut state) {
                message = format!("{message}; {restored}");
            }
        }
        Ok(state.into_solution(&ev, status, message, start))
    }
}
