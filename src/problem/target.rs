//! How the target term `G = ‖x_targets(T) − p‖` reaches the optimizer ([`TargetModel`]): inside
//! the smooth objective, or as a residual norm whose residual `r = x_targets(T) − p` and Jacobian
//! `∂r/∂U` the problem evaluates (one extra seed per coordinate in the backward pass it makes
//! anyway).

use autodiff::{Tape, Tensor, Var};
use cloth::Model;

/// How the SQP models the target term `G`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum TargetModel {
    /// `G` is a residual norm ([`optim::ResidualNorm`]): each QP holds `‖r + J d‖` in a
    /// second-order cone, the Gauss–Newton (prox-linear) model of `G`, and BFGS learns the
    /// curvature of the rest only. Each backward pass pulls back 3 more seeds per target (1323
    /// on `fold`'s target mesh, where forward duals over the controls would be cheaper). Slower
    /// than [`TargetModel::Bfgs`] on the scenes measured (`docs/performance.md`): the residual
    /// stays large at the plan (the safety rows and `αT + βE` hold the targets back), where the
    /// curvature the model leaves out matters.
    GaussNewton,
    /// `G` is part of the smooth objective `G + βE`, its curvature learnt by damped BFGS: the
    /// paper's formulation, and the default (measured the faster; Gauss–Newton misses `ball_25`).
    #[default]
    Bfgs,
}

impl TargetModel {
    /// Every model, in the order their names are listed.
    pub const ALL: [TargetModel; 2] = [TargetModel::GaussNewton, TargetModel::Bfgs];

    /// The name Python and JSON give it (`"gauss_newton"`, `"bfgs"`; the CLI spells
    /// `gauss_newton` as `gauss-newton`).
    pub fn name(self) -> &'static str {
        match self {
            TargetModel::GaussNewton => "gauss_newton",
            TargetModel::Bfgs => "bfgs",
        }
    }
}

/// Number of residual entries of the target term: 3 per target particle.
pub(super) fn residual_len(model: &Model) -> usize {
    3 * model.task.targets.rows()
}

/// `r = x_targets − p` at the final state `x` (`targets × 3`, row-major).
pub fn residual(model: &Model, x: &Tensor) -> Vec<f64> {
    let task = &model.task;
    (0..task.targets.rows())
        .flat_map(|k| {
            let particle = task.targets.row(k)[0];
            let reached = x.row(particle);
            let target = task.target_positions.row(k);
            (0..3).map(move |j| reached[j] - target[j])
        })
        .collect()
}

/// Records entry `i` of the residual on the final state `x`: `x_targets[i / 3][i % 3]` (the
/// target position, a constant, left out: only the entry's gradient is wanted).
pub(super) fn record_entry(model: &Model, tape: &mut Tape, x: Var, i: usize) -> Var {
    let targets = &model.task.targets;
    let reached = tape.gather(x, targets);
    let mut pick = Tensor::zeros(targets.rows(), 3);
    pick.row_mut(i / 3)[i % 3] = 1.0;
    let pick = tape.leaf(pick);
    tape.dot(reached, pick)
}

/// Records the smooth part of the loss at step `t` on state `x`: `βE`, plus `G` at the last step
/// when `G` is not a residual norm.
pub(super) fn record_smooth_loss(
    model: &Model,
    target_model: TargetModel,
    tape: &mut Tape,
    t: usize,
    x: Var,
    beta: f64,
) -> Option<Var> {
    match target_model {
        TargetModel::Bfgs => model.record_loss(tape, t, x, beta),
        TargetModel::GaussNewton if beta != 0.0 => {
            model.record_energy(tape, x).map(|e| tape.scale(e, beta))
        }
        TargetModel::GaussNewton => None,
    }
}
