//! What a run reports: the [`Status`], per-iteration [`IterationInfo`] and the final [`Solution`].

use crate::DenseMatrix;
use serde::{Deserialize, Serialize};
use std::fmt;

/// How a run ended. Only [`Status::Converged`] means the tolerances were met.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Status {
    /// The KKT residual and the constraint violation are both within their tolerances at the returned point.
    Converged,
    /// Locally infeasible: the iterates reached a stationary point of the constraint violation that
    /// does not satisfy the constraints. `best_violation` is the smallest max-norm violation reached.
    Infeasible {
        /// Smallest max-norm constraint violation over all iterates.
        best_violation: f64,
    },
    /// The iteration or function-evaluation limit was reached first.
    IterationLimit,
    /// No further progress was possible (line search failed even after a Hessian reset, or the step
    /// became negligible) before the tolerances were met.
    Stalled,
    /// SQP's progress test ([`SqpSettings::progress_window`](crate::SqpSettings::progress_window)):
    /// the last iterations, all with steps cut by the line search, lowered the objective (and,
    /// where an iterate was infeasible, the violation) by less than `tol_progress` before the
    /// tolerances were met. The message gives the measured decreases.
    NoProgress,
    /// The problem could not be evaluated at the starting point, or no evaluable point was found along
    /// the search direction.
    EvaluationFailed,
    /// The per-iteration callback asked to stop.
    Interrupted,
}

impl Status {
    /// `true` only for [`Status::Converged`].
    pub fn is_converged(&self) -> bool {
        matches!(self, Status::Converged)
    }

    /// A short lowercase name (`"converged"`, `"infeasible"`, …) for tables and logs.
    pub fn name(&self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::Infeasible { .. } => "infeasible",
            Status::IterationLimit => "iteration_limit",
            Status::Stalled => "stalled",
            Status::NoProgress => "no_progress",
            Status::EvaluationFailed => "evaluation_failed",
            Status::Interrupted => "interrupted",
        }
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Status::Infeasible { best_violation } => {
                write!(f, "infeasible (best violation {best_violation:.3e})")
            }
            other => f.write_str(other.name()),
        }
    }
}

/// A snapshot handed to the per-iteration callback (after the convergence measures of the current
/// iterate are known, before the step is taken).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationInfo {
    /// Iteration number, 0 for the starting point.
    pub iteration: usize,
    /// Total objective (smooth part plus norm terms) at the current iterate.
    pub objective: f64,
    /// Max-norm constraint violation at the current iterate (0 for unconstrained problems).
    pub constraint_violation: f64,
    /// Scaled KKT residual at the current iterate (L-BFGS: ∞-norm of the projected gradient).
    pub kkt_residual: f64,
    /// ∞-norm of the step that led to this iterate (0 at iteration 0).
    pub step_norm: f64,
    /// Line-search step length of that step (0 at iteration 0).
    pub step_length: f64,
    /// Largest per-constraint ℓ1 penalty / elastic weight (SQP; 0 for L-BFGS).
    pub penalty: f64,
    /// Linearized ℓ1 constraint violation left by the QP step from this iterate, in the solver's
    /// internally scaled constraint units (SQP; 0 for L-BFGS). Positive means the linearization was
    /// inconsistent and the elastic slacks were used.
    pub linearized_violation: f64,
    /// Objective (and constraint) evaluations so far.
    pub function_evaluations: usize,
    /// Gradient (and Jacobian) evaluations so far.
    pub gradient_evaluations: usize,
    /// The current iterate (e.g. for a caller that keeps the best feasible point so far).
    pub x: Vec<f64>,
}

impl std::fmt::Display for IterationInfo {
    /// The one-line iteration report used by every log:
    /// `it    3  f   0.87952300  viol   4.53e-9  kkt   1.14e-3  step   2.10e-2  α   1.0e0  ν   1.0e1  evals 5`
    /// (step norm, line-search length α, largest penalty ν, function evaluations so far).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "it {:>4}  f {:>12.8}  viol {:>9.2e}  kkt {:>9.2e}  step {:>9.2e}  α {:>7.1e}  ν {:>7.1e}  evals {}",
            self.iteration,
            self.objective,
            self.constraint_violation,
            self.kkt_residual,
            self.step_norm,
            self.step_length,
            self.penalty,
            self.function_evaluations
        )
    }
}

/// Lagrange multipliers at the returned point (SQP: from the last QP subproblem; L-BFGS: bound
/// multipliers from the gradient).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Multipliers {
    /// One per inequality, `≥ 0`, with `∇f = Σ λᵢ ∇cᵢ + …` at a KKT point.
    pub inequality: Vec<f64>,
    /// One per equality.
    pub equality: Vec<f64>,
    /// One per variable, `≥ 0`, for active lower bounds.
    pub lower_bound: Vec<f64>,
    /// One per variable, `≥ 0`, for active upper bounds.
    pub upper_bound: Vec<f64>,
    /// For each norm term, then each residual norm, the subgradient vector `y` with `‖y‖ ≤ w` and
    /// `Aᵀy` (`J(x)ᵀy` for a residual norm) its contribution to the gradient of the objective.
    pub norm_terms: Vec<Vec<f64>>,
}

/// The outcome of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Solution {
    /// How the run ended.
    pub status: Status,
    /// A one-line explanation of the status.
    pub message: String,
    /// The returned point: the final iterate (for [`Status::Infeasible`], the stationary point of the
    /// violation where the run stopped).
    pub x: Vec<f64>,
    /// Total objective at `x` (smooth part plus norm terms).
    pub objective: f64,
    /// Max-norm constraint violation at `x`.
    pub constraint_violation: f64,
    /// Scaled KKT residual at `x` (see the crate docs for its definition).
    pub kkt_residual: f64,
    /// Steps taken.
    pub iterations: usize,
    /// Objective (and constraint) evaluations.
    pub function_evaluations: usize,
    /// Gradient (and Jacobian) evaluations.
    pub gradient_evaluations: usize,
    /// Lagrange multipliers at `x`.
    pub multipliers: Multipliers,
    /// Wall-clock time of the run in seconds.
    pub solve_time: f64,
    /// SQP: the final quasi-Newton approximation `B ≈ ∇²ₓₓL` (`n × n`, symmetric positive
    /// definite), to warm-start a related solve through [`crate::Problem::initial_hessian`] —
    /// e.g. the next stage of a continuation. `None` for L-BFGS, a failed start, and a matrix
    /// too badly conditioned to pass [`DenseMatrix::is_symmetric_positive_definite`].
    #[serde(skip)]
    pub hessian: Option<DenseMatrix>,
}

#[cfg(test)]
mod tests {
    use super::IterationInfo;

    #[test]
    fn an_iteration_prints_itself_on_one_line() {
        let info = IterationInfo {
            iteration: 3,
            objective: 0.879523,
            constraint_violation: 4.53e-9,
            kkt_residual: 1.14e-3,
            step_norm: 2.1e-2,
            step_length: 1.0,
            penalty: 10.0,
            linearized_violation: 0.0,
            function_evaluations: 5,
            gradient_evaluations: 4,
            x: vec![1.0],
        };
        assert_eq!(
            info.to_string(),
            "it    3  f   0.87952300  viol   4.53e-9  kkt   1.14e-3  step   2.10e-2  α   1.0e0  ν   1.0e1  evals 5"
        );
    }
}
