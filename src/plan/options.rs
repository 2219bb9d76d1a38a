//! What a planning run is asked to do: [`Optimizer`], the optimizer that runs it, and
//! [`PlanOptions`], its settings with their documented defaults and their validation.

use crate::error::Result;
use crate::problem::TaskOptions;
use crate::result::FEASIBILITY_TOLERANCE;
use crate::validate::{
    ensure_iterations, ensure_non_negative, ensure_positive, ensure_positive_or_infinite,
};
use cloth::Model;
use optim::{DenseMatrix, SqpSettings};
use serde::Serialize;
use std::time::Instant;

/// The planner's progress test tolerance ([`PlanOptions::tol_progress`]): a stage whose last 10
/// iterations, every step cut by the line search, lowered `L` by less than 1e-3 · max(1, |L|)
/// would lower it by less than 2% in its whole 200-iteration budget at that rate, so it stops
/// and leaves the time to the search's other stages. The SQP's own default (1e-6) is for
/// problems without a clock; on the task suite a stage stuck at a rollout's jump crept on for 30
/// iterations at the looser tolerance (docs/experiments.md, "The progress test's tolerance").
pub const PLAN_TOL_PROGRESS: f64 = 1e-3;

/// The optimizer that runs a planning problem (`--solver`, Python's `solver=`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Optimizer {
    /// SQP on Clarabel: constraints, and the trajectory term's kinks as second-order cones.
    Sqp,
    /// L-BFGS: unconstrained only; the trajectory term's kinks get the sub-gradient 0.
    Lbfgs,
}

impl Optimizer {
    /// Every optimizer, in the order their names are listed.
    pub const ALL: [Optimizer; 2] = [Optimizer::Sqp, Optimizer::Lbfgs];

    /// The name the CLI, Python and JSON give it (`"sqp"`, `"lbfgs"`).
    pub fn name(self) -> &'static str {
        match self {
            Optimizer::Sqp => "sqp",
            Optimizer::Lbfgs => "lbfgs",
        }
    }
}

/// Everything a planning run needs besides the model.
#[derive(Clone, Debug)]
pub struct PlanOptions {
    /// The task's weights, margin and safety form.
    pub task: TaskOptions,
    /// Iteration limit of the solver, per κ stage (see `kappa_warmup`): a warmed-up plan may take
    /// up to twice as many in all.
    pub iterations: usize,
    /// The optimizer.
    pub solver: Optimizer,
    /// SQP step bound: `‖d‖∞ ≤ scale · max(1, ‖U‖∞)`, in control units (a control is a
    /// displacement per step; 0.5 is half a cloth width).
    pub step_bound: f64,
    /// Scaled KKT (stationarity) tolerance for `converged`. The default 1e-4 is met once the
    /// objective stops changing in its 8th digit on the built-in scenes; much tighter values hit
    /// the accuracy of the QP multipliers at the trajectory term's kinks (≈1e-5) and end `stalled`.
    pub tol_optimality: f64,
    /// Continuation in the soft minimum's sharpness: with the per-step or aggregate safety form,
    /// first solve at this κ (smoother, more conservative; tolerance ×10), then at `task.kappa` from
    /// that plan. `None` solves at `task.kappa` directly. Default 200 (with `task.kappa` = 3000):
    /// measured on u_obstacle, solving at 3000 directly stalls at δ = 0.4, at 200 alone the plan
    /// is ~1% conservative (L 0.8795 vs 0.8692 at δ = 0.2).
    pub kappa_warmup: Option<f64>,
    /// SQP Jacobian reuse (length units): at a new iterate, a safety row more than this above its
    /// margin, whose kept gradient predicted its change over the last step, keeps that gradient
    /// instead of costing a backward pass ([`optim::SqpSettings::jacobian_reuse_margin`]). Such a
    /// row is inactive (multiplier 0), so a stale gradient enters neither the KKT test nor the BFGS
    /// update, and it is pulled back again once a step approaches it. Default ∞ (off): measured on
    /// `u_obstacle`, a band of 0.1 saves 14–16% CPU at δ = 0.2 (69 instead of 70 iterations, same L)
    /// but takes 326 instead of 189 iterations at δ = 0.4 from the δ = 0.2 plan.
    pub reuse_band: f64,
    /// Largest max-norm violation (length units) of the optimizer's rows at which a plan still
    /// counts as feasible. Default [`FEASIBILITY_TOLERANCE`] (1e-8).
    pub tol_feasibility: f64,
    /// The SQP's progress test, per stage ([`optim::SqpSettings::progress_window`]): a stage
    /// whose last `progress_window` iterations lower the objective by less than
    /// `tol_progress · max(1, |f|)` (and, where an iterate is infeasible, the violation by less
    /// than `tol_progress` of its value) ends `no_progress` when all their steps were cut by the
    /// line search, or when their iterates all reach every target within the task's tolerance
    /// and their KKT residual stays (steps whole but going nowhere); a warm-up
    /// ending so with no safety row active is the plan (the sharp stage is not run, see
    /// [`super::sharp_stage_needed`]). `None` turns it off. Default the SQP's, `Some(10)`.
    pub progress_window: Option<usize>,
    /// The relative decrease of the progress test (see `progress_window`). Default
    /// [`PLAN_TOL_PROGRESS`].
    pub tol_progress: f64,
    /// Plan even when the cloth starts inside an obstacle (step 0 cannot be made safe); the
    /// result then carries a warning instead of the run failing. Default false.
    pub allow_unsafe_start: bool,
    /// Stop at this instant and return the best feasible iterate so far (status `time_limit`).
    /// Default none.
    pub deadline: Option<Instant>,
    /// Stop when this flag is raised (e.g. by SIGINT) and return the best feasible iterate so
    /// far (status `interrupted`). Default none.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// The quasi-Newton Hessian the first stage starts from (`n × n`, symmetric positive
    /// definite), e.g. an earlier plan's [`crate::result::PlanResult::hessian`]. Default none: the identity.
    pub initial_hessian: Option<DenseMatrix>,
}

impl PlanOptions {
    /// Defaults for `model`: its own task, SQP, 200 iterations, step bound 0.5, KKT tolerance 1e-4.
    pub fn for_model(model: &Model) -> Self {
        let sqp = SqpSettings::default();
        PlanOptions {
            task: TaskOptions::for_model(model),
            iterations: 200,
            solver: Optimizer::Sqp,
            step_bound: 0.5,
            tol_optimality: 1e-4,
            kappa_warmup: Some(200.0),
            reuse_band: f64::INFINITY,
            tol_feasibility: FEASIBILITY_TOLERANCE,
            progress_window: sqp.progress_window,
            tol_progress: PLAN_TOL_PROGRESS,
            allow_unsafe_start: false,
            deadline: None,
            stop: None,
            initial_hessian: None,
        }
    }

    /// Checks every option, naming the first bad one: `δ`, `α`, `β` finite and ≥ 0; `κ` finite
    /// and positive (the soft minimum divides by it); the reuse band > 0 (∞ allowed); at least
    /// one iteration (and a progress window of at least one); a finite positive step bound and
    /// tolerance; `tol_progress` finite and ≥ 0. [`super::plan`] calls it, so a bad
    /// option is an error instead of a panic or a silently NaN objective.
    pub fn validate(&self) -> Result<()> {
        let t = &self.task;
        for (name, v) in [("delta", t.delta), ("alpha", t.alpha), ("beta", t.beta)] {
            ensure_non_negative(name, v)?;
        }
        let positive = [
            ("kappa", t.kappa),
            ("step_bound", self.step_bound),
            ("tol_optimality", self.tol_optimality),
            ("tol_feasibility", self.tol_feasibility),
        ];
        for (name, v) in positive {
            ensure_positive(name, v)?;
        }
        if let Some(kappa) = self.kappa_warmup {
            ensure_positive("kappa_warmup", kappa)?;
        }
        ensure_positive_or_infinite("reuse_band", self.reuse_band)?;
        ensure_non_negative("tol_progress", self.tol_progress)?;
        if let Some(window) = self.progress_window {
            ensure_iterations("progress_window", window)?;
        }
        ensure_iterations("iterations", self.iterations)
    }
}
