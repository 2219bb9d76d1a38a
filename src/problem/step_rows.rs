//! Rows recorded on each step's state, `T` of each kind (row `r` of a kind constrains step
//! `r + 1`), pulled back through the rollout with the loss: the `max_strain` limit, and the held
//! particles' clearance from the rest of the cloth under smooth self-contact.
//!
//! A gripper that presses the particle it holds onto cloth that cannot give way (a layer lying
//! on the table) makes the rollout fail: the self-contact barrier stops the held particle's
//! move ([`cloth::ClothError::SelfContactPenetration`]). To the optimizer a failed rollout is a
//! step too long, so a plan whose loss pulls a gripper down onto the cloth creeps along that
//! wall by halvings. The clearance row shows it the wall while the rollouts still succeed: the
//! smallest gap between a held particle and a triangle not incident to it stays above
//! [`HELD_MARGIN`] of the barrier's reach `d̂`. Off by default
//! ([`super::TaskOptions::held_clearance`]).

use super::TrajectoryProblem;
use autodiff::{Tape, Var};

/// The held particles' clearance rows keep every held particle's gap to the rest of the cloth
/// at least this fraction of the self-contact barrier's reach `d̂`: inside the barrier's range
/// (where it bears the cloth it lies on), far from the gaps at which a pressed gripper's move
/// stalls.
pub const HELD_MARGIN: f64 = 0.1;

/// The soft minimum over the held pairs is sharp enough to lie within half the margin of the
/// true minimum when this many pairs are near it (`κ = 2 ln(n)/margin`); far pairs (a rest
/// edge off) add nothing measurable.
const HELD_NEAR_PAIRS: f64 = 8.0;

/// A kind of step row.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepRow {
    /// `max_strain − smooth max strain` ([`super::TaskOptions::strain_kappa`]).
    Strain,
    /// `smooth min of the held pairs' gaps − HELD_MARGIN · d̂` ([`cloth::Model::held`]).
    HeldClearance,
}

impl TrajectoryProblem<'_> {
    /// The kinds of step rows of this task, in row order: the strain rows with a `max_strain`
    /// limit on a cloth with stretch edges, the clearance rows where the model has held pairs
    /// (smooth self-contact and grippers) and [`super::TaskOptions::held_clearance`] asks for
    /// them.
    pub(super) fn step_row_kinds(&self) -> Vec<StepRow> {
        let model = self.model;
        let strain = model.task.limits.max_strain.is_some() && model.strain.is_some();
        let held = model.held.is_some() && self.options.held_clearance;
        [(strain, StepRow::Strain), (held, StepRow::HeldClearance)]
            .into_iter()
            .filter_map(|(has, kind)| has.then_some(kind))
            .collect()
    }

    /// Number of step rows: `T` per kind.
    pub(super) fn step_rows(&self) -> usize {
        self.step_row_kinds().len() * self.model.task.horizon
    }

    /// Records the row of `kind` on the state `x`.
    pub(super) fn record_step_row(&self, kind: StepRow, tape: &mut Tape, x: Var) -> Option<Var> {
        let model = self.model;
        match kind {
            StepRow::Strain => {
                let limit = model.task.limits.max_strain?;
                let soft = model.record_soft_max_strain(tape, x, self.options.strain_kappa)?;
                let negated = tape.neg(soft);
                Some(tape.add_scalar(negated, limit))
            }
            StepRow::HeldClearance => {
                let margin = HELD_MARGIN * model.self_barrier.as_ref()?.barrier.d_hat;
                let kappa = 2.0 * HELD_NEAR_PAIRS.ln() / margin;
                let soft = model.record_soft_min_held_gap(tape, x, kappa)?;
                Some(tape.add_scalar(soft, -margin))
            }
        }
    }
}
