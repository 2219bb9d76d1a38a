//! Solver settings with documented defaults, a validating builder (modelled on
//! `clarabel::solver::DefaultSettingsBuilder`) and the callback control type.

use crate::error::OptimError;
use serde::{Deserialize, Serialize};

/// Generates a builder with one setter per field, plus `build()` which validates.
macro_rules! settings_builder {
    ($settings:ident, $builder:ident, { $( $field:ident : $ty:ty ),* $(,)? }) => {
        #[doc = concat!("Builder for [`", stringify!($settings), "`]: start from the defaults, set fields, `build()` validates.")]
        #[derive(Clone, Debug, Default)]
        pub struct $builder {
            inner: $settings,
        }

        impl $builder {
            $(
                #[doc = concat!("Sets [`", stringify!($settings), "::", stringify!($field), "`].")]
                pub fn $field(mut self, value: $ty) -> Self {
                    self.inner.$field = value;
                    self
                }
            )*

            /// Validates and returns the settings.
            pub fn build(self) -> Result<$settings, OptimError> {
                self.inner.validate()?;
                Ok(self.inner)
            }
        }

        impl $settings {
            /// A builder starting from the defaults.
            pub fn builder() -> $builder {
                $builder::default()
            }
        }
    };
}

fn check(ok: bool, name: &'static str, reason: &str) -> Result<(), OptimError> {
    if ok {
        Ok(())
    } else {
        Err(OptimError::InvalidSettings {
            name,
            reason: reason.to_string(),
        })
    }
}

fn positive(v: f64, name: &'static str) -> Result<(), OptimError> {
    check(v.is_finite() && v > 0.0, name, "must be finite and > 0")
}

/// Settings of the SQP solver ([`SqpSolver`](crate::SqpSolver)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SqpSettings {
    /// Maximum number of SQP iterations (steps). Default 200.
    pub max_iterations: usize,
    /// Maximum number of objective/constraint evaluations. Default 2000.
    pub max_function_evaluations: usize,
    /// Tolerance on the scaled KKT residual (stationarity of the Lagrangian divided by
    /// `max(1, ‖∇f‖∞)`, complementarity divided by `max(1, |f|)`). Default 1e-6.
    pub tol_optimality: f64,
    /// Tolerance on the max-norm constraint violation (absolute, in the constraints' own units).
    /// Default 1e-8.
    pub tol_feasibility: f64,
    /// A step with `‖d‖∞ ≤ tol_step · (1 + ‖x‖∞)` that does not meet the tolerances counts as no progress
    /// (the Hessian is reset once, then the run is reported [`Stalled`](crate::Status::Stalled)). Default 1e-12.
    pub tol_step: f64,
    /// Initial weight `ν` of the elastic ℓ1 slacks and of the ℓ1 merit function. Default 10.
    pub elastic_weight: f64,
    /// Factor by which `ν` grows when the QP step does not reduce the linearized violation enough. Default 10.
    pub elastic_weight_growth: f64,
    /// Upper limit for `ν`. Default 1e10.
    pub elastic_weight_max: f64,
    /// The step is bounded by `‖d‖∞ ≤ step_bound_scale · max(1, ‖x‖∞)` (a box trust region that keeps
    /// early quasi-Newton steps sane and the feasibility LP bounded). Default 10.
    pub step_bound_scale: f64,
    /// Armijo sufficient-decrease constant of the merit line search. Default 1e-4.
    pub armijo: f64,
    /// Smallest step length tried in the line search before it is declared failed. Default 1e-10.
    pub min_step_length: f64,
    /// Try a second-order correction (re-solve the QP with the constraint values at the trial point)
    /// when the full step is rejected (counters the Maratos effect); the corrected point is evaluated
    /// only when the QP's model predicts that it passes the merit test. Default true.
    pub second_order_correction: bool,
    /// Powell damping threshold of the BFGS update (`sᵀy ≥ θ sᵀBs` is enforced). Default 0.2.
    pub bfgs_damping: f64,
    /// Tolerance handed to Clarabel (gap and feasibility). Default 1e-9.
    pub qp_tolerance: f64,
    /// Iteration limit handed to Clarabel. Default 200.
    pub qp_max_iterations: u32,
    /// Constraint scaling (as in IPOPT): every constraint whose gradient at the starting point has
    /// ∞-norm above this value is scaled down to it, for the whole run. Internal only: reported
    /// violations, `tol_feasibility` and multipliers refer to the unscaled constraints.
    /// `f64::INFINITY` disables scaling. Default 100.
    pub max_constraint_gradient: f64,
    /// Jacobian reuse for far-from-active inequalities: at a new iterate, a row whose (unscaled)
    /// value is at least this margin, and whose previous Jacobian row predicted its change over the
    /// step to 10%, keeps that row instead of being evaluated
    /// ([`Problem::inequality_jacobian_rows`](crate::Problem::inequality_jacobian_rows)). A kept row
    /// is re-evaluated as soon as a QP step brings its linearization below half the margin, and every
    /// kept row is re-evaluated before any verdict but convergence. Such a row is inactive, so its
    /// multiplier is zero and a stale row enters neither the KKT residual nor the BFGS update. It
    /// changes the iterates, so it pays only where rows are costly; `None` (the default) evaluates
    /// every row at every iterate.
    pub jacobian_reuse_margin: Option<f64>,
    /// Progress test: the run ends [`NoProgress`](crate::Status::NoProgress) when the line
    /// search cut every one of the last `progress_window` iterations' steps (`α < 1`), together
    /// they lowered the objective by less than `tol_progress · max(1, |f|)`, and, if any of
    /// their iterates is infeasible (violation > `tol_feasibility`), the max-norm violation by
    /// less than `tol_progress` times its value at the window's start: the QP keeps
    /// promising decreases the function does not deliver (noise, roughness, an inexact
    /// gradient), so the run stops instead of spending its iteration budget (cf. Knitro's
    /// `ftol`/`ftol_iters`, SLSQP's `acc`). A run converging on a smooth problem is not stopped by
    /// it: there the objective stops changing too, but SQP takes unit steps. `None` turns the
    /// test off. Default `Some(10)`.
    pub progress_window: Option<usize>,
    /// Relative decrease of the objective (and of the violation, where an iterate is infeasible)
    /// over `progress_window` iterations below which a run counts as making no progress (see
    /// `progress_window`). Default 1e-6.
    pub tol_progress: f64,
    /// Feasibility restoration at a run's end: a run that ends
    /// [`NoProgress`](crate::Status::NoProgress) or [`Stalled`](crate::Status::Stalled) on an
    /// infeasible iterate takes up to this many minimum-norm corrections onto its rows'
    /// linearization, the objective ignored (each costs an evaluation, and a gradient before
    /// the next one), and ends at the corrected point if that is feasible. Its objective and
    /// noise are what kept the merit line search from restoring the rows. `0` turns it off.
    /// Default 3.
    pub restoration_steps: usize,
}

/// Default [`SqpSettings::tol_feasibility`]: the largest max-norm violation of the (unscaled)
/// constraints a converged point may have.
pub const DEFAULT_TOL_FEASIBILITY: f64 = 1e-8;

impl Default for SqpSettings {
    fn default() -> Self {
        Self {
            max_iterations: 200,
            max_function_evaluations: 2000,
            tol_optimality: 1e-6,
            tol_feasibility: DEFAULT_TOL_FEASIBILITY,
            tol_step: 1e-12,
            elastic_weight: 10.0,
            elastic_weight_growth: 10.0,
            elastic_weight_max: 1e10,
            step_bound_scale: 10.0,
            armijo: 1e-4,
            min_step_length: 1e-10,
            second_order_correction: true,
            restoration_steps: 3,
            bfgs_damping: 0.2,
            qp_tolerance: 1e-9,
            qp_max_iterations: 200,
            max_constraint_gradient: 100.0,
            jacobian_reuse_margin: None,
            progress_window: Some(10),
            tol_progress: 1e-6,
        }
    }
}

impl SqpSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), OptimError> {
        check(self.max_iterations > 0, "max_iterations", "must be > 0")?;
        check(
            self.max_function_evaluations > 0,
            "max_function_evaluations",
            "must be > 0",
        )?;
        positive(self.tol_optimality, "tol_optimality")?;
        positive(self.tol_feasibility, "tol_feasibility")?;
        positive(self.tol_step, "tol_step")?;
        positive(self.elastic_weight, "elastic_weight")?;
        check(
            self.elastic_weight_growth.is_finite() && self.elastic_weight_growth > 1.0,
            "elastic_weight_growth",
            "must be finite and > 1",
        )?;
        check(
            self.elastic_weight_max.is_finite() && self.elastic_weight_max >= self.elastic_weight,
            "elastic_weight_max",
            "must be finite and ≥ elastic_weight",
        )?;
        positive(self.step_bound_scale, "step_bound_scale")?;
        check(
            self.armijo > 0.0 && self.armijo < 0.5,
            "armijo",
            "must be in (0, 0.5)",
        )?;
        check(
            self.min_step_length > 0.0 && self.min_step_length < 1.0,
            "min_step_length",
            "must be in (0, 1)",
        )?;
        check(
            self.bfgs_damping > 0.0 && self.bfgs_damping < 1.0,
            "bfgs_damping",
            "must be in (0, 1)",
        )?;
        positive(self.qp_tolerance, "qp_tolerance")?;
        check(
            self.qp_max_iterations > 0,
            "qp_max_iterations",
            "must be > 0",
        )?;
        check(
            self.max_constraint_gradient > 0.0,
            "max_constraint_gradient",
            "must be > 0 (use f64::INFINITY to disable scaling)",
        )?;
        check(
            self.jacobian_reuse_margin
                .is_none_or(|m| m.is_finite() && m > 0.0),
            "jacobian_reuse_margin",
            "must be finite and > 0 (None disables reuse)",
        )?;
        check(
            self.progress_window.is_none_or(|w| w > 0),
            "progress_window",
            "must be > 0 (None disables the progress test)",
        )?;
        check(
            self.tol_progress.is_finite() && self.tol_progress >= 0.0,
            "tol_progress",
            "must be finite and ≥ 0",
        )
    }
}

settings_builder!(SqpSettings, SqpSettingsBuilder, {
    max_iterations: usize,
    max_function_evaluations: usize,
    tol_optimality: f64,
    tol_feasibility: f64,
    tol_step: f64,
    elastic_weight: f64,
    elastic_weight_growth: f64,
    elastic_weight_max: f64,
    step_bound_scale: f64,
    armijo: f64,
    min_step_length: f64,
    second_order_correction: bool,
    bfgs_damping: f64,
    qp_tolerance: f64,
    qp_max_iterations: u32,
    max_constraint_gradient: f64,
    jacobian_reuse_margin: Option<f64>,
    progress_window: Option<usize>,
    tol_progress: f64,
    restoration_steps: usize,
});

/// Settings of the L-BFGS solver ([`LbfgsSolver`](crate::LbfgsSolver)).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LbfgsSettings {
    /// Number of stored correction pairs. Default 10.
    pub memory: usize,
    /// Maximum number of iterations. Default 1000.
    pub max_iterations: usize,
    /// Maximum number of objective+gradient evaluations. Default 5000.
    pub max_function_evaluations: usize,
    /// Converged when the ∞-norm of the projected gradient is at most this (absolute). Default 1e-6.
    pub tol_gradient: f64,
    /// A step with `‖s‖∞ ≤ tol_step · (1 + ‖x‖∞)` that does not meet the tolerance counts as no
    /// progress ([`Stalled`](crate::Status::Stalled) after one memory reset). Default 1e-14.
    pub tol_step: f64,
    /// Sufficient-decrease constant `c₁` of the (strong) Wolfe conditions. Default 1e-4.
    pub wolfe_c1: f64,
    /// Curvature constant `c₂` of the strong Wolfe conditions. Default 0.9.
    pub wolfe_c2: f64,
    /// Maximum evaluations per line search. Default 40.
    pub max_line_search_evaluations: usize,
}

impl Default for LbfgsSettings {
    fn default() -> Self {
        Self {
            memory: 10,
            max_iterations: 1000,
            max_function_evaluations: 5000,
            tol_gradient: 1e-6,
            tol_step: 1e-14,
            wolfe_c1: 1e-4,
            wolfe_c2: 0.9,
            max_line_search_evaluations: 40,
        }
    }
}

impl LbfgsSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), OptimError> {
        check(self.memory > 0, "memory", "must be > 0")?;
        check(self.max_iterations > 0, "max_iterations", "must be > 0")?;
        check(
            self.max_function_evaluations > 0,
            "max_function_evaluations",
            "must be > 0",
        )?;
        positive(self.tol_gradient, "tol_gradient")?;
        positive(self.tol_step, "tol_step")?;
        check(
            self.wolfe_c1 > 0.0 && self.wolfe_c1 < 0.5,
            "wolfe_c1",
            "must be in (0, 0.5)",
        )?;
        check(
            self.wolfe_c2 > self.wolfe_c1 && self.wolfe_c2 < 1.0,
            "wolfe_c2",
            "must be in (wolfe_c1, 1)",
        )?;
        check(
            self.max_line_search_evaluations > 1,
            "max_line_search_evaluations",
            "must be > 1",
        )
    }
}

settings_builder!(LbfgsSettings, LbfgsSettingsBuilder, {
    memory: usize,
    max_iterations: usize,
    max_function_evaluations: usize,
    tol_gradient: f64,
    tol_step: f64,
    wolfe_c1: f64,
    wolfe_c2: f64,
    max_line_search_evaluations: usize,
});

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_builder_validates() {
        assert!(SqpSettings::default().validate().is_ok());
        assert!(LbfgsSettings::default().validate().is_ok());
        let s = SqpSettings::builder().max_iterations(7).build().unwrap();
        assert_eq!(s.max_iterations, 7);
        let err = SqpSettings::builder().tol_optimality(-1.0).build();
        assert!(matches!(
            err,
            Err(OptimError::InvalidSettings {
                name: "tol_optimality",
                ..
            })
        ));
        for (bad, field) in [
            (
                SqpSettings::builder().progress_window(Some(0)).build(),
                "progress_window",
            ),
            (
                SqpSettings::builder().tol_progress(-1e-6).build(),
                "tol_progress",
            ),
            (
                SqpSettings::builder().tol_progress(f64::NAN).build(),
                "tol_progress",
            ),
        ] {
            assert!(
                matches!(bad, Err(OptimError::InvalidSettings { name, .. }) if name == field),
                "{field}"
            );
        }
        assert!(SqpSettings::builder().progress_window(None).build().is_ok());
        assert!(LbfgsSettings::builder().wolfe_c2(1e-5).build().is_err());
        assert!(LbfgsSettings::builder().memory(0).build().is_err());
    }
}
