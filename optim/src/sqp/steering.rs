//! Step 2: steering of the per-constraint penalty weights (Byrd–Nocedal–Waltz) when the QP step
//! leaves linearized violation.

use crate::eval::{PointDerivatives, PointValues};
use crate::qp::{QpData, QpMode, QpSubproblem};

use super::kkt::{linearized_violation, linearized_violations};
use super::step::Step;
use super::SqpSolver;

impl SqpSolver {
    /// Solves the feasibility LP for the best reachable linearized violation (and tells whether
    /// the iterate is stationary for the violation), then raises the weights of the constraints
    /// `step` leaves violated, re-solving its QP, until the step achieves a fair share of that
    /// reduction (all of it if the linearization is consistent, i.e. down to `lin_tol`).
    /// `penalty` keeps the last weights tried; `step` the last usable solution and its weights.
    pub(super) fn steer_penalty(
        &self,
        data: &QpData<'_>,
        pt: &PointValues,
        dv: &PointDerivatives,
        penalty: &mut [f64],
        step: &mut Step,
        lin_tol: f64,
    ) -> Result<(), String> {
        let s = &self.settings;
        let lv0 = pt.violation_l1();
        let mut fqp = QpSubproblem::new(
            data,
            QpMode::Feasibility,
            &[],
            s.qp_tolerance,
            s.qp_max_iterations,
        )
        .map_err(|e| e.0)?;
        let fsol = fqp.solve();
        let lv_min = if fsol.outcome.is_usable() {
            let v = linearized_violation(pt, dv, &fsol.d);
            // Stationary for the violation only if the LP cannot reduce it by more than a
            // relative tol_optimality (relative at every size: an absolute floor would call a
            // 1e-7 violation that the LP halves stationary).
            step.infeasible_stationary = v > lin_tol && lv0 - v <= s.tol_optimality * lv0;
            v.min(step.lin_violation)
        } else {
            0.0
        };
        let good_enough = |lv: f64| {
            if lv_min <= lin_tol {
                lv <= lin_tol
            } else {
                lv0 - lv >= 0.1 * (lv0 - lv_min)
            }
        };
        let count = penalty.len().max(1) as f64;
        while !good_enough(step.lin_violation) {
            let per = linearized_violations(pt, dv, &step.sol.d);
            let Some(next) = self.raised_weights(penalty, &per, lin_tol, count) else {
                break;
            };
            if step.qp.update_penalty(&next).is_err() {
                break;
            }
            penalty.copy_from_slice(&next);
            let trial = step.qp.solve();
            if !trial.outcome.is_usable() {
                // Keep the last usable step; restore the QP to its weights for a consistent SOC.
                let _ = step.qp.update_penalty(&step.penalty);
                break;
            }
            step.penalty = next;
            step.lin_violation = linearized_violation(pt, dv, &trial.d);
            step.sol = trial;
        }
        Ok(())
    }

    /// The weights `penalty` raised (by `elastic_weight_growth`, up to `elastic_weight_max`) for
    /// the constraints whose linearized violation `per` exceeds their share of `lin_tol` among
    /// `count`, or for all constraints if none stands out; `None` when no weight can rise.
    fn raised_weights(
        &self,
        penalty: &[f64],
        per: &[f64],
        lin_tol: f64,
        count: f64,
    ) -> Option<Vec<f64>> {
        let s = &self.settings;
        let mut next = penalty.to_vec();
        let mut raised = false;
        for (w, v) in next.iter_mut().zip(per) {
            if *v > lin_tol / count && *w < s.elastic_weight_max {
                *w = (*w * s.elastic_weight_growth).min(s.elastic_weight_max);
                raised = true;
            }
        }
        if !raised {
            for w in next.iter_mut() {
                if *w < s.elastic_weight_max {
                    *w = (*w * s.elastic_weight_growth).min(s.elastic_weight_max);
                    raised = true;
                }
            }
        }
        raised.then_some(next)
    }
}
