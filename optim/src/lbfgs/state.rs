//! The L-BFGS iterate: its evaluation, what the callback sees of it, and the solution it ends in.

use crate::error::EvalError;
use crate::eval::Evaluator;
use crate::linalg::{norm2, norm_inf};
use crate::problem::{tmul_add, Problem};
use crate::status::{IterationInfo, Multipliers, Solution, Status};
use std::ops::ControlFlow;
use std::time::Instant;

/// Objective (with norm terms) and its gradient at `x`.
pub(super) fn evaluate<P: Problem + ?Sized>(
    ev: &mut Evaluator<'_, P>,
    x: &[f64],
) -> Result<(f64, Vec<f64>), EvalError> {
    // After an interrupting error the line search's further trials do not reach the problem.
    if let Some(why) = &ev.interruption {
        return Err(EvalError::interrupted(why.clone()));
    }
    let v = ev.values(x)?;
    // No constraints (checked by the solver): only the gradient is evaluated.
    let dv = ev.derivatives(x)?;
    let mut g = dv.g;
    for ((nd, r), jac) in ev.norms.iter().zip(&v.residuals).zip(&dv.norm_jac) {
        let nr = norm2(r);
        if nr > 0.0 {
            let y: Vec<f64> = r.iter().map(|ri| nd.weight * ri / nr).collect();
            tmul_add(nd.rows(jac), &y, &mut g);
        }
    }
    Ok((v.objective(), g))
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
        objective: f64::NAN,
        constraint_violation: 0.0,
        kkt_residual: f64::NAN,
        x,
        iterations: 0,
        function_evaluations: ev.function_evaluations,
        gradient_evaluations: ev.gradient_evaluations,
        multipliers: Multipliers::default(),
        solve_time: start.elapsed().as_secs_f64(),
        hessian: None,
    }
}

/// The current iterate and the iteration's counters.
pub(super) struct Iterate {
    pub x: Vec<f64>,
    /// Objective at `x`.
    pub f: f64,
    /// Gradient at `x`.
    pub g: Vec<f64>,
    /// Steps taken.
    pub iterations: usize,
    /// `‖s‖∞` of the last step (0 before the first).
    pub last_step: f64,
    /// Step length of the last step (0 before the first).
    pub last_alpha: f64,
    /// The last iteration number the callback saw: a memory reset after a failed line search
    /// repeats an iteration, and the callback sees each iteration number once.
    reported: Option<usize>,
}

impl Iterate {
    /// The first iterate, at `x` (within the bounds); `Err` with a message and `x` when it
    /// cannot be evaluated.
    pub fn start<P: Problem + ?Sized>(
        ev: &mut Evaluator<'_, P>,
        x: Vec<f64>,
    ) -> Result<Self, (String, Vec<f64>)> {
        match evaluate(ev, &x) {
            Ok((f, g)) => Ok(Iterate {
                x,
                f,
                g,
                iterations: 0,
                last_step: 0.0,
                last_alpha: 0.0,
                reported: None,
            }),
            Err(e) => Err((format!("evaluation failed at the starting point: {e}"), x)),
        }
    }

    /// The projected gradient `x − P(x − g)` (the gradient without bounds).
    fn projected_gradient<P: Problem + ?Sized>(&self, ev: &Evaluator<'_, P>) -> Vec<f64> {
        let (x, g) = (&self.x, &self.g);
        if ev.has_bounds {
            (0..ev.n)
                .map(|i| x[i] - (x[i] - g[i]).clamp(ev.lower[i], ev.upper[i]))
                .collect()
        } else {
            g.clone()
        }
    }

    /// `‖x − P(x − g)‖∞`, the first-order optimality measure.
    pub fn projected_gradient_norm<P: Problem + ?Sized>(&self, ev: &Evaluator<'_, P>) -> f64 {
        norm_inf(&self.projected_gradient(ev))
    }

    /// Calls `callback` with the iteration's [`IterationInfo`] (`pg_norm` as its KKT residual),
    /// unless it has seen this iteration number already.
    pub fn report<P, F>(
        &mut self,
        ev: &Evaluator<'_, P>,
        pg_norm: f64,
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
            objective: self.f,
            constraint_violation: 0.0,
            kkt_residual: pg_norm,
            step_norm: self.last_step,
            step_length: self.last_alpha,
            penalty: 0.0,
            linearized_violation: 0.0,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            x: self.x.clone(),
        };
        callback(&info)
    }

    /// The run's solution at this iterate, with bound multipliers from the gradient at the
    /// active bounds.
    pub fn into_solution<P: Problem + ?Sized>(
        self,
        ev: &Evaluator<'_, P>,
        status: Status,
        message: String,
        start: Instant,
    ) -> Solution {
        let pg = self.projected_gradient(ev);
        let (x, g) = (&self.x, &self.g);
        let n = ev.n;
        let mut lower_bound = vec![0.0; n];
        let mut upper_bound = vec![0.0; n];
        for i in 0..n {
            if x[i] <= ev.lower[i] && g[i] > 0.0 {
                lower_bound[i] = g[i];
            }
            if x[i] >= ev.upper[i] && g[i] < 0.0 {
                upper_bound[i] = -g[i];
            }
        }
        Solution {
            status,
            message,
            objective: self.f,
            constraint_violation: 0.0,
            kkt_residual: norm_inf(&pg),
            x: self.x,
            iterations: self.iterations,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            multipliers: Multipliers {
                inequality: Vec::new(),
                equality: Vec::new(),
                lower_bound,
                upper_bound,
                norm_terms: Vec::new(),
            },
            solve_time: start.elapsed().as_secs_f64(),
            hessian: None,
        }
    }
}
