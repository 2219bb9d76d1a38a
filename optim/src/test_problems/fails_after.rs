//! A wrapper whose objective evaluations start failing after a budget.

use crate::error::EvalError;
use crate::linalg::{DenseMatrix, Jacobian};
use crate::problem::{Bounds, NormTerm, Problem};

/// `problem` with a budget of objective evaluations: once `budget` of them have succeeded, every
/// further [`Problem::objective`] call fails with an [`EvalError`] (one that interrupts the run,
/// [`EvalError::interrupted`], when `interrupt` is set, as a planner's deadline does); everything
/// else is forwarded. Exercises how the solvers handle failed evaluations.
#[derive(Clone, Debug)]
pub struct FailsAfter<P> {
    /// The wrapped problem.
    pub problem: P,
    /// Objective evaluations left before they start failing.
    pub budget: usize,
    /// The failures interrupt the run instead of marking a point unevaluable.
    pub interrupt: bool,
    /// Objective calls failed so far.
    pub failed: usize,
}

impl<P> FailsAfter<P> {
    /// `problem` whose objective evaluations fail (as unevaluable points) after `budget`.
    pub fn new(problem: P, budget: usize) -> Self {
        Self {
            problem,
            budget,
            interrupt: false,
            failed: 0,
        }
    }

    /// `problem` whose objective evaluations interrupt the run after `budget`.
    pub fn interrupting(problem: P, budget: usize) -> Self {
        Self {
            interrupt: true,
            ..Self::new(problem, budget)
        }
    }
}

impl<P: Problem> Problem for FailsAfter<P> {
    fn num_variables(&self) -> usize {
        self.problem.num_variables()
    }
    fn num_inequalities(&self) -> usize {
        self.problem.num_inequalities()
    }
    fn num_equalities(&self) -> usize {
        self.problem.num_equalities()
    }
    fn bounds(&self) -> Option<Bounds> {
        self.problem.bounds()
    }
    fn norm_terms(&self) -> Vec<NormTerm> {
        self.problem.norm_terms()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        self.problem.initial_hessian()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        if self.budget == 0 {
            self.failed += 1;
            return Err(if self.interrupt {
                EvalError::interrupted("out of time")
            } else {
                EvalError::new("out of budget")
            });
        }
        self.budget -= 1;
        self.problem.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.problem.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        self.problem.inequalities(x, c)
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.problem.inequality_jacobian(x, jac)
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        self.problem.equalities(x, h)
    }
    fn equality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.problem.equality_jacobian(x, jac)
    }
}
