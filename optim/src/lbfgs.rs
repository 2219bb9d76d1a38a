//! L-BFGS for smooth problems without general constraints, optionally with box bounds.
//!
//! * No bounds: classic L-BFGS (two-loop recursion, initial scaling `sᵀy/yᵀy`) with the strong-Wolfe
//!   line search of [`crate::line_search`].
//! * Bounds: a two-metric projection method (Bertsekas 1982) — variables within `ε` of a bound with the
//!   gradient pushing outwards are held by a scaled gradient step, the L-BFGS direction acts on the rest,
//!   and an Armijo backtracking search runs along the projection arc `P(x + αd)`. `ε` shrinks with the
//!   projected-gradient norm, so the active set is identified near a solution. This is simpler than
//!   L-BFGS-B's Cauchy point and subspace minimization, and keeps every iterate feasible.
//!
//! Declared norm terms are added to the objective with the subgradient `0` at a kink (L-BFGS has no
//! exact treatment of them: use the SQP for that). General constraints are rejected.

use crate::error::{EvalError, OptimError};
use crate::eval::Evaluator;
use crate::linalg::{axpy, dot, norm2, norm_inf};
use crate::line_search::{strong_wolfe, Trial, WolfeOutcome, WolfeParams};
use crate::problem::Problem;
use crate::settings::LbfgsSettings;
use crate::status::{IterationInfo, Multipliers, Solution, Status};
use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::time::Instant;

/// The L-BFGS solver.
///
/// ```
/// use optim::{Problem, EvalError, LbfgsSolver, LbfgsSettings, Status};
///
/// struct Bowl;
/// impl Problem for Bowl {
///     fn num_variables(&self) -> usize { 2 }
///     fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
///         Ok((x[0] - 1.0).powi(2) + 10.0 * (x[1] + 2.0).powi(2))
///     }
///     fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
///         g[0] = 2.0 * (x[0] - 1.0);
///         g[1] = 20.0 * (x[1] + 2.0);
///         Ok(())
///     }
/// }
/// let sol = LbfgsSolver::new(LbfgsSettings::default()).unwrap().solve(&mut Bowl, &[0.0, 0.0]).unwrap();
/// assert_eq!(sol.status, Status::Converged);
/// assert!((sol.x[1] + 2.0).abs() < 1e-6);
/// ```
#[derive(Clone, Debug, Default)]
pub struct LbfgsSolver {
    settings: LbfgsSettings,
}

/// Objective (with norm terms) and its gradient at `x`.
fn evaluate<P: Problem + ?Sized>(
    ev: &mut Evaluator<'_, P>,
    x: &[f64],
) -> Result<(f64, Vec<f64>), EvalError> {
    let v = ev.values(x)?;
    // No constraints (checked by the solver): only the gradient is evaluated.
    let mut g = ev.derivatives(x)?.g;
    for (nd, r) in ev.norms.iter().zip(&v.residuals) {
        let nr = norm2(r);
        if nr > 0.0 {
            let y: Vec<f64> = r.iter().map(|ri| nd.weight * ri / nr).collect();
            nd.tmul_add(&y, &mut g);
        }
    }
    Ok((v.objective(), g))
}

/// Two-loop recursion: `H · v` with the stored pairs (`H₀ = γI`).
fn two_loop(pairs: &VecDeque<(Vec<f64>, Vec<f64>, f64)>, v: &[f64], gamma: f64) -> Vec<f64> {
    let mut q = v.to_vec();
    let mut alphas = Vec::with_capacity(pairs.len());
    for (s, y, rho) in pairs.iter().rev() {
        let a = rho * dot(s, &q);
        axpy(-a, y, &mut q);
        alphas.push(a);
    }
    for v in &mut q {
        *v *= gamma;
    }
    for ((s, y, rho), a) in pairs.iter().zip(alphas.iter().rev()) {
        let b = rho * dot(y, &q);
        axpy(a - b, s, &mut q);
    }
    q
}

impl LbfgsSolver {
    /// A solver with validated settings.
    pub fn new(settings: LbfgsSettings) -> Result<Self, OptimError> {
        settings.validate()?;
        Ok(Self { settings })
    }

    /// The settings in use.
    pub fn settings(&self) -> &LbfgsSettings {
        &self.settings
    }

    /// Minimizes `problem` from `x0` (projected onto the bounds).
    pub fn solve<P: Problem + ?Sized>(
        &self,
        problem: &mut P,
        x0: &[f64],
    ) -> Result<Solution, OptimError> {
        self.solve_with_callback(problem, x0, |_| ControlFlow::Continue(()))
    }

    /// Like [`solve`](LbfgsSolver::solve), calling `callback` once per iteration.
    pub fn solve_with_callback<P, F>(
        &self,
        problem: &mut P,
        x0: &[f64],
        mut callback: F,
    ) -> Result<Solution, OptimError>
    where
        P: Problem + ?Sized,
        F: FnMut(&IterationInfo) -> ControlFlow<()>,
    {
        let start = Instant::now();
        let st = &self.settings;
        st.validate()?;
        let (m, q) = (problem.num_inequalities(), problem.num_equalities());
        if m + q > 0 {
            return Err(OptimError::Unsupported(format!(
                "L-BFGS handles bounds only; this problem has {m} inequality and {q} equality constraints (use SqpSolver)"
            )));
        }
        let mut ev = Evaluator::new(problem, x0)?;
        let n = ev.n;
        let mut x = x0.to_vec();
        ev.project(&mut x);
        let bounded = ev.has_bounds;

        let (mut f, mut g) = match evaluate(&mut ev, &x) {
            Ok(v) => v,
            Err(e) => {
                return Ok(Solution {
                    status: Status::EvaluationFailed,
                    message: format!("evaluation failed at the starting point: {e}"),
                    objective: f64::NAN,
                    constraint_violation: 0.0,
                    kkt_residual: f64::NAN,
                    x,
                    iterations: 0,
                    function_evaluations: ev.function_evaluations,
                    gradient_evaluations: ev.gradient_evaluations,
                    multipliers: Multipliers::default(),
                    solve_time: start.elapsed().as_secs_f64(),
                    hessian: None,
                })
            }
        };
        let mut pairs: VecDeque<(Vec<f64>, Vec<f64>, f64)> = VecDeque::new();
        let mut gamma = 1.0;
        let mut iterations = 0usize;
        let mut last_step = 0.0;
        let mut last_alpha = 0.0;
        let mut fresh_memory = true;
        // A memory reset after a failed line search repeats an iteration; the callback sees each
        // iteration number once.
        let mut reported: Option<usize> = None;

        let projected_gradient = |x: &[f64], g: &[f64], ev: &Evaluator<'_, P>| -> Vec<f64> {
            (0..n)
                .map(|i| x[i] - (x[i] - g[i]).clamp(ev.lower[i], ev.upper[i]))
                .collect()
        };

        let (status, message) = loop {
            let pg = if bounded {
                projected_gradient(&x, &g, &ev)
            } else {
                g.clone()
            };
            let pg_norm = norm_inf(&pg);
            if reported != Some(iterations) {
                reported = Some(iterations);
                let info = IterationInfo {
                    iteration: iterations,
                    objective: f,
                    constraint_violation: 0.0,
                    kkt_residual: pg_norm,
                    step_norm: last_step,
                    step_length: last_alpha,
                    penalty: 0.0,
                    linearized_violation: 0.0,
                    function_evaluations: ev.function_evaluations,
                    gradient_evaluations: ev.gradient_evaluations,
                    x: x.clone(),
                };
                if callback(&info).is_break() {
                    break (Status::Interrupted, "stopped by the callback".to_string());
                }
            }
            if pg_norm <= st.tol_gradient {
                break (
                    Status::Converged,
                    format!("projected gradient {pg_norm:.2e} within tolerance"),
                );
            }
            if iterations >= st.max_iterations {
                break (Status::IterationLimit, format!("{iterations} iterations"));
            }
            if ev.function_evaluations >= st.max_function_evaluations {
                break (
                    Status::IterationLimit,
                    format!("{} function evaluations", ev.function_evaluations),
                );
            }

            // Search direction.
            let eps = pg_norm.min(1e-3);
            let held: Vec<bool> = (0..n)
                .map(|i| {
                    bounded
                        && ((x[i] - ev.lower[i] <= eps && g[i] > 0.0)
                            || (ev.upper[i] - x[i] <= eps && g[i] < 0.0))
                })
                .collect();
            let masked: Vec<f64> = (0..n).map(|i| if held[i] { 0.0 } else { g[i] }).collect();
            let mut d: Vec<f64> = two_loop(&pairs, &masked, gamma)
                .into_iter()
                .map(|v| -v)
                .collect();
            for i in 0..n {
                if held[i] {
                    d[i] = -gamma * g[i];
                }
            }
            let descent = dot(&d, &masked) < 0.0;
            if !descent && norm_inf(&masked) > 0.0 {
                pairs.clear();
                fresh_memory = true;
                d = g.iter().map(|gi| -gamma * gi).collect();
            }
            let alpha0 = if pairs.is_empty() {
                (1.0 / norm_inf(&d).max(1e-300)).min(1.0)
            } else {
                1.0
            };

            // Line search.
            let accepted = if bounded {
                self.projected_search(&mut ev, &x, f, &g, &d, alpha0)
            } else {
                let slope0 = dot(&g, &d);
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
                let xc = x.clone();
                let dc = d.clone();
                let outcome = strong_wolfe(
                    |alpha| {
                        let xt: Vec<f64> = xc.iter().zip(&dc).map(|(a, b)| a + alpha * b).collect();
                        let (ft, gt) = evaluate(&mut ev, &xt)?;
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
                        let xt: Vec<f64> = x.iter().zip(&d).map(|(a, b)| a + t.alpha * b).collect();
                        Ok((xt, t.value, t.gradient, t.alpha))
                    }
                    WolfeOutcome::Failed {
                        evaluation_failures,
                        trials,
                    } => Err(evaluation_failures == trials && trials > 0),
                }
            };
            match accepted {
                Ok((xn, fn_, gn, alpha)) => {
                    let s: Vec<f64> = xn.iter().zip(&x).map(|(a, b)| a - b).collect();
                    let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
                    let sy = dot(&s, &y);
                    let yy = dot(&y, &y);
                    if sy > 1e-12 * norm2(&s) * norm2(&y) && sy > 0.0 {
                        gamma = sy / yy;
                        pairs.push_back((s.clone(), y, 1.0 / sy));
                        if pairs.len() > st.memory {
                            pairs.pop_front();
                        }
                    }
                    last_step = norm_inf(&s);
                    last_alpha = alpha;
                    let tiny = last_step <= st.tol_step * (1.0 + norm_inf(&x));
                    x = xn;
                    f = fn_;
                    g = gn;
                    iterations += 1;
                    if tiny {
                        if !fresh_memory {
                            pairs.clear();
                            fresh_memory = true;
                            continue;
                        }
                        break (Status::Stalled, "negligible step".to_string());
                    }
                    fresh_memory = false;
                }
                Err(all_failed) => {
                    if !fresh_memory {
                        pairs.clear();
                        gamma = 1.0;
                        fresh_memory = true;
                        continue;
                    }
                    if all_failed {
                        break (
                            Status::EvaluationFailed,
                            "no evaluable point along the search direction".to_string(),
                        );
                    }
                    break (
                        Status::Stalled,
                        "line search failed after a memory reset".to_string(),
                    );
                }
            }
        };

        let pg = if bounded {
            projected_gradient(&x, &g, &ev)
        } else {
            g.clone()
        };
        // Bound multipliers from the gradient at active bounds.
        let mut lower_bound = vec![0.0; n];
        let mut upper_bound = vec![0.0; n];
        for i in 0..n {
            if x[i] <= ev.lower[i] && g[i] > 0.0 {
                lower_bound[i] = g[i];
            }
            if x[i] >= ev.upper[i] && g[i] < 0.0 {
                upper_bound[i] = -g[i];
            }
        }
        Ok(Solution {
            status,
            message,
            objective: f,
            constraint_violation: 0.0,
            kkt_residual: norm_inf(&pg),
            x,
            iterations,
            function_evaluations: ev.function_evaluations,
            gradient_evaluations: ev.gradient_evaluations,
            multipliers: Multipliers {
                inequality: Vec::new(),
                equality: Vec::new(),
                lower_bound,
                upper_bound,
                norm_terms: Vec::new(),
            },
            solve_time: start.elapsed().as_secs_f64(),
            hessian: None,
        })
    }

    /// Armijo backtracking along the projection arc `P(x + αd)`.
    /// `Err(true)` if every trial failed to evaluate.
    #[allow(clippy::type_complexity)]
    fn projected_search<P: Problem + ?Sized>(
        &self,
        ev: &mut Evaluator<'_, P>,
        x: &[f64],
        f: f64,
        g: &[f64],
        d: &[f64],
        alpha0: f64,
    ) -> Result<(Vec<f64>, f64, Vec<f64>, f64), bool> {
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
