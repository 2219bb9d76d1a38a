//! The step at an iterate: the elastic QP and the steering of its penalty weights.

use crate::eval::{PointDerivatives, PointValues};
use crate::linalg::norm_inf;
use crate::qp::{QpData, QpMode, QpSubproblem};

use super::kkt::{linearized_violation, linearized_violations};
use super::{SqpSolver, Step};

impl SqpSolver {
    /// Solves the elastic QP and steers the penalty.
    pub(super) fn compute_step(
        &self,
        data: &QpData<'_>,
        pt: &PointValues,
        dv: &PointDerivatives,
        penalty: &mut [f64],
    ) -> Result<Step, String> {
        let s = &self.settings;
        let mut qp = QpSubproblem::new(
            data,
            QpMode::Optimality,
            penalty,
            s.qp_tolerance,
            s.qp_max_iterations,
        )
        .map_err(|e| e.0)?;
        let mut sol = qp.solve();
        let mut lin_violation = linearized_violation(pt, dv, &sol.d);
        let mut step_penalty = penalty.to_vec();
        let mut infeasible_stationary = false;
        let lv0 = pt.violation_l1();
        let scale = 1.0 + norm_inf(&pt.c).max(norm_inf(&pt.h));
        let lin_tol = s.tol_feasibility.max(10.0 * s.qp_tolerance * scale);
        if sol.outcome.is_usable() && lin_violation > lin_tol {
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
                infeasible_stationary = v > lin_tol && lv0 - v <= s.tol_optimality * lv0;
                v.min(lin_violation)
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
            while !good_enough(lin_violation) {
                // Raise the weights of the constraints the step leaves violated (all, if none stands out).
                let per = linearized_violations(pt, dv, &sol.d);
                let mut next = penalty.to_vec();
                let mut raised = false;
                for (w, v) in next.iter_mut().zip(&per) {
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
                if !raised || qp.update_penalty(&next).is_err() {
                    break;
                }
                penalty.copy_from_slice(&next);
                let trial = qp.solve();
                if !trial.outcome.is_usable() {
                    // Keep the last usable step; restore the QP to its weights for a consistent SOC.
                    let _ = qp.update_penalty(&step_penalty);
                    break;
                }
                step_penalty = next;
                lin_violation = linearized_violation(pt, dv, &trial.d);
                sol = trial;
            }
        }
        Ok(Step {
            qp,
            sol,
            penalty: step_penalty,
            lin_violation,
            infeasible_stationary,
        })
    }
}
