//! The line searches: strong Wolfe without bounds, Armijo backtracking along the projection arc
//! with them.

use crate::eval::Evaluator;
use crate::linalg::{dot, norm_inf};
use crate::line_search::{strong_wolfe, Trial, WolfeOutcome, WolfeParams};
use crate::problem::Problem;

use super::state::evaluate;
use super::LbfgsSolver;

/// An accepted trial point: `x`, its objective and gradient, and the step length.
pub(super) type Accepted = (Vec<f64>, f64, Vec<f64>, f64);

impl LbfgsSolver {
    /// The strong-Wolfe search ([`strong_wolfe`]) from `x` (objective `f`, gradient `g`) along
    /// `d`, starting at the step length `alpha0`, within the evaluation budgets.
    /// `Err(true)` if every trial failed to evaluate.
    pub(super) fn wolfe_search<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        x: &[f64],
        f: f64,
        g: &[f64],
        d: &[f64],
        alpha0: f64,
    ) -> Result<Accepted, bool> {
        let st = &self.settings;
        let slope0 = dot(g, d);
        let params = WolfeParams {
            c1: st.wolfe_c1,
            c2: st.wolfe_c2,
            max_evaluations: st
                .max_line_search_evaluations
                .min(
                    st.max_function_evaluations
                        .saturating_sub(ev.function_evaluations),
                )
                .max(1),
            alpha_max: 1e10,
        };
        let xc = x.to_vec();
        let dc = d.to_vec();
        let outcome = strong_wolfe(
            |alpha| {
                let xt: Vec<f64> = xc.iter().zip(&dc).map(|(a, b)| a + alpha * b).collect();
                let (ft, gt) = evaluate(ev, &xt)?;
                Ok(Trial {
                    alpha,
                    value: ft,
                    slope: dot(&gt, &dc),
                    gradient: gt,
                })
            },
            f,
            slope0,
            alpha0,
            params,
        );
        match outcome {
            WolfeOutcome::Wolfe(t) | WolfeOutcome::Armijo(t) => {
                let xt: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + t.alpha * b).collect();
                Ok((xt, t.value, t.gradient, t.alpha))
            }
            WolfeOutcome::Failed {
                evaluation_failures,
                trials,
            } => Err(evaluation_failures == trials && trials > 0),
        }
    }

    /// Armijo backtracking along the projection arc `P(x + αd)`.
    /// `Err(true)` if every trial failed to evaluate.
    pub(super) fn projected_search<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        x: &[f64],
        f: f64,
        g: &[f64],
        d: &[f64],
        alpha0: f64,
    ) -> Result<Accepted, bool> {
        let st = &self.settings;
        let mut alpha = alpha0;
        let (mut trials, mut failures) = (0usize, 0usize);
        let noise = 10.0 * f64::EPSILON * f.abs().max(1.0);
        while trials < st.max_line_search_evaluations
            && ev.function_evaluations < st.max_function_evaluations
        {
            trials += 1;
            let mut xt: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + alpha * b).collect();
            ev.project(&mut xt);
            let step: Vec<f64> = xt.iter().zip(x).map(|(a, b)| a - b).collect();
            let decrease = dot(g, &step);
            if norm_inf(&step) == 0.0 {
                break;
            }
            match evaluate(ev, &xt) {
                Ok((ft, gt)) => {
                    if decrease < 0.0 && ft <= f + st.wolfe_c1 * decrease + noise {
                        return Ok((xt, ft, gt, alpha));
                    }
                }
                Err(_) => failures += 1,
            }
            alpha *= 0.5;
        }
        Err(trials > 0 && failures == trials)
    }
}
