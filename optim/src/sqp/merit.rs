//! The ℓ1 merit line search: backtracking with the Armijo test on the QP's predicted reduction,
//! one second-order correction, and accepting a trial point (step 4); the reduction the QP's model
//! predicts.

use crate::bfgs::DampedBfgs;
use crate::error::EvalError;
use crate::eval::{Evaluator, PointDerivatives, PointValues, Reuse};
use crate::linalg::{dot, norm2, norm_inf, symv};
use crate::problem::{NormData, Problem};
use crate::qp::QpSubproblem;

use super::kkt::{linearized_violations, violations_after};
use super::SqpSolver;

/// Outcome of the merit line search.
pub(super) enum Search {
    Accepted {
        values: Box<PointValues>,
        derivatives: Box<PointDerivatives>,
        alpha: f64,
    },
    Failed {
        all_evaluations_failed: bool,
        last_error: Option<String>,
    },
    Budget,
    /// An evaluation said the run must stop ([`EvalError::interrupted`]).
    Interrupted(String),
}

impl SqpSolver {
    /// Backtracking on the ℓ1 merit with one second-order correction.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn line_search<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        pt: &PointValues,
        dv: &PointDerivatives,
        d: &[f64],
        pred: f64,
        penalty: &[f64],
        qp: &mut QpSubproblem,
        bfgs: &DampedBfgs,
    ) -> Search {
        let s = &self.settings;
        let phi0 = pt.merit(penalty);
        let noise = 10.0 * f64::EPSILON * phi0.abs().max(1.0);
        // Armijo: the largest merit accepted at step length `alpha` (with a rounding allowance).
        let threshold = |alpha: f64| phi0 - s.armijo * alpha * pred + noise;
        let mut alpha = 1.0_f64;
        let mut trials = 0usize;
        let mut failures = 0usize;
        let mut last_error = None;
        let mut tried_soc = false;
        while alpha >= s.min_step_length {
            if ev.function_evaluations >= s.max_function_evaluations {
                return Search::Budget;
            }
            trials += 1;
            let mut xt: Vec<f64> = pt.x.iter().zip(d).map(|(x, di)| x + alpha * di).collect();
            ev.project(&mut xt);
            let vt = match ev.values(&xt) {
                Ok(v) => v,
                Err(e) if e.is_interrupt() => return Search::Interrupted(e.to_string()),
                Err(e) => {
                    failures += 1;
                    last_error = Some(e.to_string());
                    alpha *= 0.5;
                    continue;
                }
            };
            let phit = vt.merit(penalty);
            if phit <= threshold(alpha) {
                match accept(ev, pt, dv, &xt, vt, alpha) {
                    Ok(accepted) => return accepted,
                    Err(e) if e.is_interrupt() => return Search::Interrupted(e.to_string()),
                    Err(e) => {
                        failures += 1;
                        last_error = Some(e.to_string());
                        alpha *= 0.5;
                        continue;
                    }
                }
            }
            // Second-order correction after a rejected full step, held to the full step's test.
            if alpha == 1.0
                && !tried_soc
                && s.second_order_correction
                && (ev.m + ev.q) > 0
                && ev.function_evaluations < s.max_function_evaluations
            {
                tried_soc = true;
                let rejected = Rejected {
                    d,
                    values: &vt,
                    weights: penalty,
                    threshold: threshold(1.0),
                };
                if let Some((xs, vs)) = second_order_correction(ev, pt, dv, bfgs, &rejected, qp) {
                    if vs.merit(penalty) <= rejected.threshold {
                        if let Ok(accepted) = accept(ev, pt, dv, &xs, vs, 1.0) {
                            return accepted;
                        }
                    }
                }
            }
            alpha = next_step_length(alpha, phi0, phit, pred);
        }
        Search::Failed {
            all_evaluations_failed: trials > 0 && failures == trials,
            last_error,
        }
    }
}

/// The step length after `alpha` was rejected with merit `phit` (`phi0` at the iterate, `pred`
/// the predicted reduction of the full step): the minimizer of the quadratic interpolation of the
/// merit along the step, safeguarded to [0.1α, 0.5α].
fn next_step_length(alpha: f64, phi0: f64, phit: f64, pred: f64) -> f64 {
    let denom = 2.0 * (phit - phi0 + alpha * pred);
    let interp = if denom > 0.0 {
        pred * alpha * alpha / denom
    } else {
        0.5 * alpha
    };
    interp.clamp(0.1 * alpha, 0.5 * alpha)
}

/// Accepts the trial point `x` of step length `alpha`, whose values are known, once its derivatives
/// are evaluated (far-from-active rows may keep their values in `previous`, those at the iterate
/// `from`).
fn accept<P: Problem + ?Sized>(
    ev: &mut Evaluator<'_, P>,
    from: &PointValues,
    previous: &PointDerivatives,
    x: &[f64],
    values: PointValues,
    alpha: f64,
) -> Result<Search, EvalError> {
    let reuse = Reuse {
        from,
        previous,
        values: &values,
    };
    let derivatives = ev.derivatives_reusing(x, Some(reuse))?;
    Ok(Search::Accepted {
        values: Box::new(values),
        derivatives: Box::new(derivatives),
        alpha,
    })
}

/// A second-order correction smaller than this fraction of the step (largest coordinate) is not
/// tried: the corrected point is the rejected trial to about as many digits as the merit's value.
const MIN_CORRECTION: f64 = 1e-9;

/// A rejected full step, for [`second_order_correction`].
struct Rejected<'a> {
    /// The step.
    d: &'a [f64],
    /// The values at `x + d`.
    values: &'a PointValues,
    /// The merit's penalty weights.
    weights: &'a [f64],
    /// The largest merit the full step's test accepts.
    threshold: f64,
}

/// The second-order-corrected point and its values: re-solves the QP with the constraint values at
/// the rejected full step `x + d`, i.e. `c(x+d) + J(x)(d̂ − d) ≥ 0`, and evaluates `x + d̂`.
/// `None` (nothing evaluated) if the corrected QP fails, the correction is below
/// [`MIN_CORRECTION`], or the QP's model says the corrected point fails the full step's test: its
/// merit predicted as the rejected trial's objective plus the model's change from `d` to `d̂`
/// ([`model_terms`]) plus the violation left by the corrected linearization. A correction repairs
/// the rows' curvature; when the objective's own rise is what failed the test, the prediction says
/// so and the evaluation (a whole simulation, for a planner) is saved.
fn second_order_correction<P: Problem + ?Sized>(
    ev: &mut Evaluator<'_, P>,
    pt: &PointValues,
    dv: &PointDerivatives,
    bfgs: &DampedBfgs,
    rejected: &Rejected<'_>,
    qp: &mut QpSubproblem,
) -> Option<(Vec<f64>, PointValues)> {
    let (d, trial) = (rejected.d, rejected.values);
    let mut jd = vec![0.0; ev.m];
    dv.jc.mul_vec(d, &mut jd);
    let c_hat: Vec<f64> = trial.c.iter().zip(&jd).map(|(c, a)| c - a).collect();
    let mut hd = vec![0.0; ev.q];
    dv.jh.mul_vec(d, &mut hd);
    let h_hat: Vec<f64> = trial.h.iter().zip(&hd).map(|(h, a)| h - a).collect();
    qp.update_constraint_values(&c_hat, &h_hat).ok()?;
    let sol = qp.solve();
    if !sol.outcome.is_usable() || sol.d.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // A correction too small to change the merit beyond its test's rounding allowance would
    // evaluate the rejected trial again (a whole simulation, for a planner).
    let correction = sol.d.iter().zip(d).map(|(a, b)| (a - b).abs());
    if correction.fold(0.0, f64::max) <= MIN_CORRECTION * norm_inf(d) {
        return None;
    }
    let left = violations_after(&c_hat, &h_hat, dv, &sol.d);
    let ((quad_hat, norms_hat), (quad, norms)) = (
        model_terms(pt, dv, bfgs, &ev.norms, &sol.d),
        model_terms(pt, dv, bfgs, &ev.norms, d),
    );
    let predicted = trial.objective() + (quad_hat + norms_hat) - (quad + norms)
        + weighted_sum(&left, rejected.weights);
    if predicted > rejected.threshold {
        return None;
    }
    let mut xs: Vec<f64> = pt.x.iter().zip(&sol.d).map(|(x, di)| x + di).collect();
    ev.project(&mut xs);
    let vs = ev.values(&xs).ok()?;
    Some((xs, vs))
}

/// The QP model's objective terms for the step `d`: `gᵀd + ½dᵀBd` and `Σ w‖r + Ad‖` (`A` the
/// Jacobian at `x` of a residual norm's residual).
fn model_terms(
    pt: &PointValues,
    dv: &PointDerivatives,
    bfgs: &DampedBfgs,
    norms: &[NormData],
    d: &[f64],
) -> (f64, f64) {
    let n = d.len();
    let mut bd = vec![0.0; n];
    symv(bfgs.matrix(), n, d, &mut bd);
    let quad = dot(&dv.g, d) + 0.5 * dot(d, &bd);
    let norms_new: f64 = norms
        .iter()
        .zip(&pt.residuals)
        .zip(&dv.norm_jac)
        .map(|((nd, r), jac)| nd.weight * norm2(&nd.model_residual(&pt.x, r, jac, d)))
        .sum();
    (quad, norms_new)
}

/// `m(0) − m(d)` for the ℓ1 model `f + gᵀd + ½dᵀBd + Σw‖r + Ad‖ + ν·linviol(d)` (`A` the
/// Jacobian at `x` of a residual norm's residual).
pub(super) fn predicted_reduction(
    pt: &PointValues,
    dv: &PointDerivatives,
    bfgs: &DampedBfgs,
    norms: &[NormData],
    d: &[f64],
    weights: &[f64],
) -> f64 {
    let lin_weighted = weighted_sum(&linearized_violations(pt, dv, d), weights);
    let (quad, norms_new) = model_terms(pt, dv, bfgs, norms, d);
    -quad + (pt.f_norms - norms_new) + (pt.weighted_violation(weights) - lin_weighted)
}

/// `Σ wᵢ vᵢ`: per-row violations weighted by the merit's penalty weights.
fn weighted_sum(violations: &[f64], weights: &[f64]) -> f64 {
    violations.iter().zip(weights).map(|(v, w)| v * w).sum()
}
