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
//!
//! Files: [`state`] (the iterate, its evaluation and the solution), [`memory`] (the pairs, the
//! two-loop recursion and the search direction), [`search`] (the two line searches).

use crate::error::OptimError;
use crate::eval::Evaluator;
use crate::linalg::norm_inf;
use crate::problem::Problem;
use crate::settings::LbfgsSettings;
use crate::status::{IterationInfo, Solution, Status};
use std::ops::ControlFlow;
use std::time::Instant;

mod memory;
mod search;
mod state;

use memory::Memory;
use state::{failed_start, Iterate};

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

/// What the iteration loop does after an iteration.
enum Next {
    /// Iterates again: from the point the step reached, or from the same iterate after a memory
    /// reset.
    Continue,
    /// The run ends with this status and message.
    Stop(Status, String),
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
        let mut x = x0.to_vec();
        ev.project(&mut x);
        let mut it = match Iterate::start(&mut ev, x) {
            Ok(it) => it,
            Err((message, x)) => return Ok(failed_start(&ev, message, x, start)),
        };
        let mut memory = Memory::new();
        let (status, message) = loop {
            if let Next::Stop(status, message) =
                self.iterate(&mut ev, &mut it, &mut memory, &mut callback)
            {
                break (status, message);
            }
        };
        Ok(it.into_solution(&ev, status, message, start))
    }

    /// One iteration at `it`: the callback, the status tests, the search direction, the line
    /// search and the memory update.
    fn iterate<P, F>(
        &self,
        ev: &mut Evaluator<'_, P>,
        it: &mut Iterate,
        memory: &mut Memory,
        callback: &mut F,
    ) -> Next
    where
        P: Problem + ?Sized,
        F: FnMut(&IterationInfo) -> ControlFlow<()>,
    {
        let pg_norm = it.projected_gradient_norm(ev);
        if it.report(ev, pg_norm, callback).is_break() {
            return Next::Stop(Status::Interrupted, "stopped by the callback".to_string());
        }
        if let Some(stop) = self.stop_test(ev, it, pg_norm) {
            return stop;
        }
        let (d, alpha0) = memory.direction(ev, &it.x, &it.g, pg_norm);
        let accepted = if ev.has_bounds {
            self.projected_search(ev, &it.x, it.f, &it.g, &d, alpha0)
        } else {
            self.wolfe_search(ev, &it.x, it.f, &it.g, &d, alpha0)
        };
        match accepted {
            Ok(step) => self.take_step(it, memory, step),
            Err(_) if ev.interruption.is_some() => Next::Stop(
                Status::Interrupted,
                format!(
                    "stopped during a line search: {}",
                    ev.interruption.take().unwrap_or_default()
                ),
            ),
            Err(all_failed) => {
                if !memory.fresh {
                    memory.reset();
                    return Next::Continue;
                }
                if all_failed {
                    return Next::Stop(
                        Status::EvaluationFailed,
                        "no evaluable point along the search direction".to_string(),
                    );
                }
                Next::Stop(
                    Status::Stalled,
                    "line search failed after a memory reset".to_string(),
                )
            }
        }
    }

    /// The tests before a step at `it`, whose projected gradient has the max-norm `pg_norm`:
    /// `Converged`, and the iteration and evaluation limits. `None`: go on.
    fn stop_test<P: Problem + ?Sized>(
        &self,
        ev: &Evaluator<'_, P>,
        it: &Iterate,
        pg_norm: f64,
    ) -> Option<Next> {
        let st = &self.settings;
        if pg_norm <= st.tol_gradient {
            return Some(Next::Stop(
                Status::Converged,
                format!("projected gradient {pg_norm:.2e} within tolerance"),
            ));
        }
        if it.iterations >= st.max_iterations {
            let why = format!("{} iterations", it.iterations);
            return Some(Next::Stop(Status::IterationLimit, why));
        }
        if ev.function_evaluations >= st.max_function_evaluations {
            return Some(Next::Stop(
                Status::IterationLimit,
                format!("{} function evaluations", ev.function_evaluations),
            ));
        }
        None
    }

    /// Moves `it` to the point the line search accepted, storing the pair `(s, y)` in `memory`
    /// when it has positive curvature; a negligible step resets the memory (once: with a fresh
    /// memory it ends the run `Stalled`).
    fn take_step(&self, it: &mut Iterate, memory: &mut Memory, step: search::Accepted) -> Next {
        let st = &self.settings;
        let (xn, fn_, gn, alpha) = step;
        let s: Vec<f64> = xn.iter().zip(&it.x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&it.g).map(|(a, b)| a - b).collect();
        memory.store(&s, y, st.memory);
        it.last_step = norm_inf(&s);
        it.last_alpha = alpha;
        let tiny = it.last_step <= st.tol_step * (1.0 + norm_inf(&it.x));
        it.x = xn;
        it.f = fn_;
        it.g = gn;
        it.iterations += 1;
        if tiny {
            if !memory.fresh {
                memory.clear();
                return Next::Continue;
            }
            return Next::Stop(Status::Stalled, "negligible step".to_string());
        }
        memory.fresh = false;
        Next::Continue
    }
}
