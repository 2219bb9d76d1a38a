//! What the iteration carries from one iterate to the next, what the callback sees of it, and
//! the solution it ends in.

use crate::bfgs::DampedBfgs;
use crate::eval::{Evaluator, PointDerivatives, PointValues};
use crate::linalg::DenseMatrix;
use crate::problem::Problem;
use crate::qp::QpSolution;
use crate::status::{IterationInfo, Multipliers, Solution, Status};
use std::ops::ControlFlow;
use std::time::Instant;

use super::kkt::{extract_multipliers, kkt_residual};
use super::progress::Progress;
use super::step::Step;

/// The state of the iteration at the current iterate.
pub(super) struct State {
    /// Values at the iterate `pt.x` (constraints scaled).
    pub pt: PointValues,
    /// Derivatives at the iterate (some inequality rows may be kept from earlier iterates).
    pub dv: PointDerivatives,
    /// The damped-BFGS approximation of the Lagrangian's Hessian.
    pub bfgs: DampedBfgs,
    /// The recent iterates, for the progress test.
    pub progress: Progress,
    /// The per-constraint penalty weights `ν`, raised by the steering.
    pub penalty: Vec<f64>,
    /// Steps taken.
    pub iterations: usize,
    /// `‖s‖∞` of the last step taken (0 before the first).
    pub last_step_norm: f64,
    /// The line search's step length of the last step taken (0 before the first).
    pub last_alpha: f64,
    /// The smallest max-norm violation of the iterates so far.
    pub best_violation: f64,
    /// The multipliers from the last usable QP (those of the scaled constraints).
    pub mult: Multipliers,
    /// The KKT residual with `mult`; infinite until the iterate's QP gives multipliers.
    pub kkt: f64,
    /// The last iteration number the callback saw: a Hessian reset repeats an iteration, and the
    /// callback sees each iteration number once.
    pub reported: Option<usize>,
}

impl State {
    /// The multipliers of the QP solution `sol` in the problem's conventions (`delta`, the step
    /// bound, tells variable bounds from step bounds) and the KKT residual they give at the
    /// iterate.
    pub fn update_multipliers<P: Problem + ?Sized>(
        &mut self,
        ev: &Evaluator<'_, P>,
        sol: &QpSolution,
        delta: f64,
    ) {
        self.mult = extract_multipliers(sol, &self.pt.x, &ev.lower, &ev.upper, delta, &ev.norms);
        self.kkt = kkt_residual(
            &self.pt, &self.dv, &self.mult, &ev.norms, &ev.lower, &ev.upper,
        );
    }

    /// Calls `callback` with the iteration's [`IterationInfo`] (the max-norm violation `viol`
    /// and the QP step `step`), unless it has seen this iteration number already.
    pub fn report<P, F>(
        &mut self,
        ev: &Evaluator<'_, P>,
        step: &Step,
        viol: f64,
        callback: &mut F,
    ) -> ControlFlow<()>
    where
        P: Problem + ?Sized,
        F: FnMut(&IterationInfo) -> ControlFlow<()>,
    {
        if self.reported == Some(self.iterations) {
            return ControlFlow::Continue(());
        }
        self.reported = Some(self.iterations);
        let info = IterationInfo {
            iteration: self.iterations,
            objective: self.pt.objective(),
            constraint_violation: viol,
            kkt_residual: self.kkt,
            step_norm: self.last_step_norm,
            step_length: self.last_alpha,
            penalty: step.penalty.iter().fold(0.0, |a: f64, b| a.max(*b)),
            linearized_violation: step.lin_violation,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            x: self.pt.x.clone(),
        };
        callback(&info)
    }

    /// The run's solution: the iterate, with the multipliers of the unscaled constraints.
    pub fn into_solution<P: Problem + ?Sized>(
        mut self,
        ev: &Evaluator<'_, P>,
        status: Status,
        message: String,
        start: Instant,
    ) -> Solution {
        // Multipliers of the scaled constraints sᵢcᵢ → multipliers of cᵢ.
        for (l, sc) in self.mult.inequality.iter_mut().zip(&ev.c_scale) {
            *l *= sc;
        }
        for (l, sc) in self.mult.equality.iter_mut().zip(&ev.h_scale) {
            *l *= sc;
        }
        let n = ev.n;
        Solution {
            status,
            message,
            objective: self.pt.objective(),
            constraint_violation: self.pt.violation_inf(),
            kkt_residual: self.kkt,
            x: self.pt.x,
            iterations: self.iterations,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            multipliers: self.mult,
            solve_time: start.elapsed().as_secs_f64(),
            // Only a matrix another solve accepts as its initial Hessian: BFGS keeps it symmetric,
            // but in floating point a badly conditioned one can fail the Cholesky test.
            hessian: DenseMatrix::from_row_major(n, n, self.bfgs.matrix().to_vec())
                .filter(DenseMatrix::is_symmetric_positive_definite),
        }
    }
}
