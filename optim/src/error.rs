//! Error types: [`OptimError`] for invalid input, [`EvalError`] for a failed problem evaluation.

use thiserror::Error;

/// An error raised before or outside the iterations: bad settings, inconsistent problem dimensions,
/// an invalid starting point. Failures *during* the iterations are reported through
/// [`Status`](crate::Status) instead.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum OptimError {
    /// A setting is out of its valid range.
    #[error("invalid setting `{name}`: {reason}")]
    InvalidSettings {
        /// The setting's field name.
        name: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// A vector or matrix supplied by the problem has the wrong size.
    #[error("dimension mismatch in {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// What was being checked.
        what: String,
        /// The expected size.
        expected: usize,
        /// The size found.
        got: usize,
    },
    /// The problem description is inconsistent (e.g. a lower bound above its upper bound).
    #[error("invalid problem: {0}")]
    InvalidProblem(String),
    /// The starting point is unusable (wrong length, NaN or infinite entries).
    #[error("invalid starting point: {0}")]
    InvalidStartingPoint(String),
    /// The solver cannot handle this kind of problem (e.g. L-BFGS with general constraints).
    #[error("unsupported problem for this solver: {0}")]
    Unsupported(String),
}

/// A failed evaluation of the objective, the constraints or their derivatives.
///
/// Return it from a [`Problem`](crate::Problem) method when the point cannot be evaluated (a simulation
/// diverged, a domain error, …). The solvers shorten the step and try again; only a failure at the
/// starting point (or a line search that cannot find any evaluable point) ends the run, with
/// [`Status::EvaluationFailed`](crate::Status::EvaluationFailed).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{message}")]
pub struct EvalError {
    message: String,
    interrupt: bool,
}

impl EvalError {
    /// Creates an evaluation error with a human-readable reason.
    pub fn new(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            interrupt: false,
        }
    }

    /// An evaluation the problem declined because the run must stop (its deadline passed, the
    /// user interrupted it): the SQP does not shorten the step but ends the run
    /// [`Interrupted`](crate::Status::Interrupted), returning its last iterate.
    pub fn interrupted(message: impl Into<String>) -> Self {
        Self {
            message: message.into(),
            interrupt: true,
        }
    }

    /// True for an error made by [`EvalError::interrupted`].
    pub fn is_interrupt(&self) -> bool {
        self.interrupt
    }

    /// The reason given when the error was created.
    pub fn message(&self) -> &str {
        &self.message
    }
}
