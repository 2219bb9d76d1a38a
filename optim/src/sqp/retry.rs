//! Repeating an iteration: with fresh Jacobian rows where some were kept from earlier iterates
//! ([`SqpSettings::jacobian_reuse_margin`](crate::SqpSettings)), or with a reset Hessian
//! approximation after a step failed.

use crate::eval::{Evaluator, PointDerivatives, PointValues};
use crate::problem::Problem;
use crate::status::Status;

use super::iteration::Next;
use super::state::State;

impl State {
    /// Re-evaluates the Jacobian rows kept from earlier iterates, to repeat the iteration with
    /// them: `None` when no row is kept.
    pub fn refresh_kept_rows<P: Problem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, P>,
    ) -> Option<Next> {
        if !self.dv.has_kept_rows() {
            return None;
        }
        Some(match ev.derivatives(&self.pt.x) {
            Ok(fresh) => {
                self.dv = fresh;
                Next::Continue
            }
            Err(e) => Next::Stop(
                Status::EvaluationFailed,
                format!("derivative evaluation failed at an iterate: {e}"),
            ),
        })
    }

    /// After a failed step: repeats the iteration with the kept Jacobian rows refreshed, or else
    /// with the Hessian approximation reset; when it is fresh already, the run ends as `stop`
    /// says.
    pub fn retry_or<P: Problem + ?Sized>(
        &mut self,
        ev: &mut Evaluator<'_, P>,
        stop: impl FnOnce() -> (Status, String),
    ) -> Next {
        if let Some(next) = self.refresh_kept_rows(ev) {
            return next;
        }
        if !self.bfgs.is_fresh() {
            self.bfgs.reset();
            return Next::Continue;
        }
        let (status, message) = stop();
        Next::Stop(status, message)
    }
}

/// True when the QP step `d` brings the linearization of a kept (not evaluated here) Jacobian row
/// below half of the reuse margin: that row may be about to matter, so it must be evaluated.
pub(super) fn kept_row_nears_activity<P: Problem + ?Sized>(
    ev: &Evaluator<'_, P>,
    pt: &PointValues,
    dv: &PointDerivatives,
    d: &[f64],
) -> bool {
    let Some(margin) = ev.reuse_margin else {
        return false;
    };
    if !dv.has_kept_rows() {
        return false;
    }
    let mut jd = vec![0.0; ev.m];
    dv.jc.mul_vec(d, &mut jd);
    (0..ev.m).any(|i| dv.kept[i] && (pt.c[i] + jd[i]) / ev.c_scale[i] < 0.5 * margin)
}
