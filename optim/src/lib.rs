//! # optim — honest nonlinear optimizers
//!
//! Two solvers for problems described by the [`Problem`] trait:
//!
//! * [`SqpSolver`]: sequential quadratic programming for
//!   `min f(x) + Σ w_k‖A_k x + b_k‖ + Σ v_j‖r_j(x)‖  s.t.  c(x) ≥ 0, h(x) = 0, l ≤ x ≤ u`, with a
//!   damped-BFGS Hessian, elastic ℓ1 QP subproblems solved by [Clarabel](clarabel) (norm terms as
//!   second-order cones, so kinks are handled exactly; nonlinear residual norms by their
//!   Gauss–Newton linearization), penalty steering, an ℓ1 merit line search with second-order
//!   correction, and local-infeasibility detection.
//! * [`LbfgsSolver`]: L-BFGS with a strong-Wolfe line search, optionally with box bounds (two-metric
//!   projection).
//!
//! Both return a [`Solution`] whose [`Status`] is [`Status::Converged`] only when the tolerances in
//! the settings are verifiably met at the returned point:
//!
//! * SQP: max-norm constraint violation `≤ tol_feasibility`, and the scaled KKT residual
//!   `max(‖∇f − J_cᵀλ − J_hᵀμ + Σ A_kᵀy_k − z_l + z_u‖∞ / max(1, ‖∇f‖∞), compl / max(1, |f|))`
//!   `≤ tol_optimality`, where `compl` is the largest of `|λᵢcᵢ|`, `z·(bound gap)` and
//!   `w_k‖r_k‖ − y_kᵀr_k`, evaluated with the problem's own gradients at the returned point and the
//!   multipliers of the QP solved there.
//! * L-BFGS: ∞-norm of the projected gradient `≤ tol_gradient`.
//!
//! Evaluations may fail ([`EvalError`]); a failed trial point shortens the step.

mod bfgs;
mod error;
mod eval;
mod lbfgs;
mod linalg;
mod line_search;
mod problem;
mod qp;
mod settings;
mod sqp;
mod status;
/// Test problems with published optima (feature `test-problems`; on for this crate's own tests).
#[cfg(feature = "test-problems")]
pub mod test_problems;

pub use error::{EvalError, OptimError};
pub use lbfgs::LbfgsSolver;
pub use linalg::{DenseMatrix, Jacobian, SparseMatrix};
pub use problem::{Bounds, NormTerm, Problem, ResidualNorm};
pub use settings::{
    LbfgsSettings, LbfgsSettingsBuilder, SqpSettings, SqpSettingsBuilder, DEFAULT_TOL_FEASIBILITY,
};
pub use sqp::SqpSolver;
pub use status::{IterationInfo, Multipliers, Solution, Status};
pub use std::ops::ControlFlow;
