//! The safety rows' terms: at the steps only, or continuous (the straight motion between the
//! steps too, [`TaskOptions::swept`](super::TaskOptions::swept)).
//!
//! A continuous row of step `t` constrains every particle's straight path from `x^(t−1)` to
//! `x^(t)`, so together the rows keep the whole motion `δ` away, except one thing no plan can
//! change: a particle whose rest state is already within `δ` of a safety obstacle (a start the
//! verdict warns about) has its first step held at its step-1 state only, its path of step 1
//! made a point there.

use super::{SafetyForm, TrajectoryProblem};
use autodiff::{RowIndex, Tape, Var};
use cloth::Model;
use std::sync::Arc;

impl TrajectoryProblem<'_> {
    /// Number of safety rows (0, 1 or `T`).
    pub(super) fn safety_rows(&self) -> usize {
        match (self.options.safety, self.model.safety.is_some()) {
            (Some(SafetyForm::PerStep), true) => self.model.task.horizon,
            (Some(SafetyForm::Scalar | SafetyForm::Aggregate), true) => 1,
            _ => 0,
        }
    }

    /// The state a continuous row of step `t` starts the paths from: `x_prev`, but at step 1 with
    /// the rows of the particles that start within `δ` ([`start_inside_margin`]) taken from `x`.
    fn path_start(&self, tape: &mut Tape, t: usize, x_prev: Var, x: Var) -> Var {
        match (&self.start_inside_margin, t) {
            (Some(index), 1) => {
                let here = tape.gather(x, index);
                tape.assign_rows(x_prev, index, here)
            }
            _ => x_prev,
        }
    }

    /// Records the per-step safety term of step `t` (row `t − 1`): the soft minimum of its
    /// entries less `δ`, the entries those of the state `x` (step-only) or of the paths from
    /// `x_prev` to `x` too ([`Model::record_swept_components_for_soft_min`]).
    pub(super) fn record_step_safety(
        &self,
        tape: &mut Tape,
        t: usize,
        x_prev: Var,
        x: Var,
    ) -> Option<Var> {
        let kappa = self.options.kappa;
        let entries = if self.options.swept {
            let start = self.path_start(tape, t, x_prev, x);
            self.model
                .record_swept_components_for_soft_min(tape, start, x, kappa)?
        } else {
            self.model
                .record_sdf_components_for_soft_min(tape, x, kappa)?
        };
        let soft = tape.soft_min(entries, kappa);
        Some(tape.add_scalar(soft, -self.options.delta))
    }

    /// Records the scalar form's term of step `t`: `−Σᵢ relu(δ − dᵢ)` over the particles'
    /// distances at `x` (step-only) or their paths' minima from `x_prev`
    /// ([`Model::record_swept_safety`]).
    pub(super) fn record_scalar_safety(
        &self,
        tape: &mut Tape,
        t: usize,
        x_prev: Var,
        x: Var,
    ) -> Option<Var> {
        let delta = self.options.delta;
        if self.options.swept {
            let start = self.path_start(tape, t, x_prev, x);
            self.model.record_swept_safety(tape, start, x, delta)
        } else {
            self.model.record_safety(tape, x, delta)
        }
    }
}

/// The particles whose rest state lies within `delta` of `model`'s safety obstacles (none
/// without safety obstacles).
pub fn start_inside_margin(model: &Model, delta: f64) -> Vec<usize> {
    let mut tape = autodiff::Tape::new();
    let rest = tape.leaf(model.start.clone());
    let Some(d) = model.record_sdf(&mut tape, rest) else {
        return Vec::new();
    };
    let d = tape.value(d).data();
    (0..d.len()).filter(|&p| d[p] < delta).collect()
}

/// [`start_inside_margin`] as a row index, `None` when there are none.
pub(super) fn start_inside_margin_index(model: &Model, delta: f64) -> Option<Arc<RowIndex>> {
    let inside = start_inside_margin(model, delta);
    (!inside.is_empty()).then(|| Arc::new(RowIndex::single(inside)))
}
