//! The Newton rollout: each step by branch following along its load path
//! ([`NewtonSettings::load_halvings`]), and each step's final factorization (the exact Hessian
//! at its converged state, which the implicit gradient needs too) kept for the gradient pass
//! within a memory budget ([`NewtonRollout`]).

use super::factor::NumericFactor;
use super::solve::{NewtonSystem, StepStats};
use super::NewtonSettings;
use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::rollout::limits::RolloutLimits;
use crate::scene::MAX_LOAD_HALVINGS;
use crate::xpbd::sim::check_finite;
use autodiff::Tensor;

/// A Newton rollout and what its implicit gradients can reuse.
pub struct NewtonRollout {
    /// `T + 1` states, the first the rest state.
    pub states: Vec<Tensor>,
    /// Each step's statistics.
    pub stats: Vec<StepStats>,
    /// The system and the kept factorizations.
    pub kept: NewtonKept,
}

/// What a Newton rollout keeps for its gradients ([`Model::newton_gradients_kept`]): the system
/// (pattern, ordering, symbolic analysis) and, per step, the factorization of the exact Hessian
/// at its converged state with the matrix it factorizes, as many steps as fit the budget given
/// to [`Model::simulate_newton_keeping`]. The gradient pass reuses a kept factorization only
/// where the matrix it assembles equals the kept one bit for bit, so the gradients are the same
/// bits as with none kept.
pub struct NewtonKept {
    pub(super) system: NewtonSystem,
    /// Step `t`'s factorization at `t − 1`.
    pub(super) factors: Vec<Option<NumericFactor>>,
    /// Step `t`'s self-contact blocks of the pattern it converged with, at `t − 1` (every step,
    /// whether its factorization fits the budget or not; none without self-contact).
    pub(super) patterns: Vec<Vec<(u32, u32)>>,
}

impl NewtonKept {
    /// Steps whose factorization is kept.
    pub fn steps(&self) -> usize {
        self.factors.iter().flatten().count()
    }

    /// Searches for a saddle's unstable mode during the rollout (Lanczos runs), rejected load
    /// increments' included.
    pub fn saddle_searches(&self) -> usize {
        self.system.saddle_searches
    }

    /// Bytes of the kept factorizations (factors and matrices).
    pub fn bytes(&self) -> usize {
        self.factors
            .iter()
            .flatten()
            .map(NumericFactor::bytes)
            .sum()
    }
}

impl Model {
    /// [`Model::simulate`] with Newton's method: `T + 1` states and each step's statistics.
    ///
    /// # Errors
    /// As [`Model::simulate`]; [`ClothError::NewtonUnsupported`] for a rigid constraint group;
    /// [`ClothError::NewtonNotConverged`] naming the step that did not converge.
    pub fn simulate_newton(
        &self,
        controls: &Controls,
        settings: &NewtonSettings,
    ) -> Result<(Vec<Tensor>, Vec<StepStats>), ClothError> {
        let r = self.simulate_newton_keeping(controls, settings, 0)?;
        Ok((r.states, r.stats))
    }

    /// [`Model::simulate_newton`], keeping each step's final factorization while their bytes
    /// stay within `budget` (the first steps' when not all fit), for
    /// [`Model::newton_gradients_kept`].
    ///
    /// # Errors
    /// As [`Model::simulate_newton`].
    pub fn simulate_newton_keeping(
        &self,
        controls: &Controls,
        settings: &NewtonSettings,
        budget: usize,
    ) -> Result<NewtonRollout, ClothError> {
        self.newton_rollout(controls, settings, budget, &RolloutLimits::default(), None)
    }

    /// [`Model::simulate_newton`] with each step's solve started from a guess: `from[t]` moved
    /// by `moves[t]` (`T + 1` states and moves of all particles, the first unused), as far along
    /// it as the barriers allow (the Newton predictor's filter: `from[t]` must be outside them,
    /// as an earlier rollout's states are), so that the solve ends in the minimum of `Φ` whose basin
    /// holds the guess. A planner's trial keeps to the branch of the rollout it moves from, with
    /// the moves predicted by [`Model::newton_control_tangents`]. Where a guess cannot start a
    /// solve or its solve does not converge, the step is solved as [`Model::simulate_newton`]
    /// solves it. Returns the rollout and how many steps started from their guess.
    ///
    /// # Errors
    /// As [`Model::simulate_newton`]; [`ClothError::Guesses`] when `from` or `moves` do not hold
    /// `T + 1` states of the model's shape.
    pub fn simulate_newton_guided(
        &self,
        controls: &Controls,
        settings: &NewtonSettings,
        from: &[Tensor],
        moves: &[Tensor],
    ) -> Result<(NewtonRollout, usize), ClothError> {
        let (n, horizon) = (self.n_particles(), self.task.horizon);
        for (what, states) in [("from", from), ("moves", moves)] {
            if states.len() != horizon + 1 {
                return Err(ClothError::Guesses(format!(
                    "{what}: {} states for a horizon of {horizon} steps (expected {})",
                    states.len(),
                    horizon + 1
                )));
            }
            if let Some((t, g)) = (states.iter().enumerate()).find(|(_, g)| g.shape() != (n, 3)) {
                return Err(ClothError::Guesses(format!(
                    "{what}: state {t} is {} × {}, expected {n} × 3",
                    g.rows(),
                    g.cols()
                )));
            }
        }
        let limits = RolloutLimits::default();
        let r = self.newton_rollout(controls, settings, 0, &limits, Some((from, moves)))?;
        let guided = r.stats.iter().filter(|s| s.from_guess).count();
        Ok((r, guided))
    }

    /// [`Model::simulate`] that also counts the solver's work, each step's Newton iterations
    /// (zeros under XPBD, whose cost does not depend on the controls), and gives up past
    /// `limits`: a planner's line search uses it to cut short a trial whose rollout costs far
    /// more than its iterate's (`TaskOptions`'s trial work factor in the `clothopt` package), or
    /// that runs past the planner's deadline.
    ///
    /// # Errors
    /// As [`Model::simulate`]; [`ClothError::NewtonWorkExceeded`] past the schedule of
    /// iterations; [`ClothError::RolloutStopped`] past the deadline or once the flag is raised
    /// (XPBD checks them before the rollout only).
    pub fn simulate_counted(
        &self,
        controls: &Controls,
        limits: &RolloutLimits,
    ) -> Result<(Vec<Tensor>, Vec<usize>), ClothError> {
        match &self.solver {
            crate::Solver::Newton(settings) => {
                let r = self.newton_rollout(controls, settings, 0, limits, None)?;
                Ok((r.states, r.stats.iter().map(|s| s.iterations).collect()))
            }
            crate::Solver::Xpbd => {
                if limits.halted() {
                    return Err(ClothError::RolloutStopped { step: 1 });
                }
                Ok((self.simulate(controls)?, vec![0; self.task.horizon]))
            }
        }
    }

    /// [`Model::simulate_newton_keeping`], giving up past `limits`
    /// ([`Model::simulate_counted`]), each step's solve started from its guess where `guides`
    /// (states and moves) are given ([`Model::simulate_newton_guided`]).
    fn newton_rollout(
        &self,
        controls: &Controls,
        settings: &NewtonSettings,
        budget: usize,
        limits: &RolloutLimits,
        guides: Option<(&[Tensor], &[Tensor])>,
    ) -> Result<NewtonRollout, ClothError> {
        self.check_controls(controls)?;
        let mut system = NewtonSystem::new(self)?;
        system.limits = limits.clone();
        let horizon = self.task.horizon;
        let mut states = Vec::with_capacity(horizon + 1);
        let mut stats = Vec::with_capacity(horizon);
        let mut factors = Vec::with_capacity(horizon);
        let mut patterns = Vec::new();
        let mut kept_bytes = 0;
        states.push(self.start.clone());
        for t in 0..horizon {
            if limits.halted() {
                return Err(ClothError::RolloutStopped { step: t + 1 });
            }
            let u = self.step_controls(controls, t);
            let guide = guides.map(|(from, moves)| (&from[t + 1], &moves[t + 1]));
            let guided = guide.and_then(|g| {
                self.solve_from_guess(&mut system, (&states[t], &u), g, t + 1, settings)
            });
            let (x, s) = match guided {
                Some(solved) => solved?,
                None => self.solve_step_newton(&mut system, &states[t], &u, t + 1, settings)?,
            };
            check_finite(&x, t + 1)?;
            // Every solve ends with the exact Hessian's factorization at the state it returns.
            let bytes = system.factor.kept_bytes();
            factors.push((kept_bytes + bytes <= budget).then(|| {
                kept_bytes += bytes;
                system.factor.current()
            }));
            if system.pattern.self_barrier.is_some() {
                patterns.push(system.pattern.self_blocks.clone());
            }
            states.push(x);
            stats.push(s);
        }
        Ok(NewtonRollout {
            states,
            stats,
            kept: NewtonKept {
                system,
                factors,
                patterns,
            },
        })
    }

    /// One step (number `step`, 1-based) from `x_prev` with control move `u`, by continuation
    /// along the load path ([`NewtonSettings::load_steps`], [`NewtonSettings::load_halvings`]):
    /// the predicted state moves from the one whose minimizer is `x_prev` to `x̃` over increasing
    /// load fractions `s` up to 1, each solve starting from the last one's minimizer (the first
    /// from `x_prev`). A solve whose iterate
    /// leaves the region where the exact Hessian is positive definite is abandoned and the
    /// increment halved (at most `load_halvings` times; at the smallest increment the solve
    /// takes whatever path it needs); after an accepted solve the increment doubles again, up to
    /// `1/load_steps`. Under self-contact, an increment whose control move puts the cloth within
    /// its thickness of itself is halved too, and at the smallest increment its grippers move in
    /// filtered stages ([`NewtonSystem::solve_moving_controls`]). The iteration counts are
    /// summed, the residual is the last solve's.
    fn solve_step_newton(
        &self,
        system: &mut NewtonSystem,
        x_prev: &Tensor,
        u: &Tensor,
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<(Tensor, StepStats), ClothError> {
        let xt = self.begin_step(x_prev, u);
        system.begin_step(x_prev);
        let mut stats = StepStats::default();
        if settings.load_steps <= 1 && settings.load_halvings == 0 {
            // Smooth contact starts from the previous state, which is outside the colliders
            // (x̃ may not be).
            if system.pattern.self_barrier.is_some() {
                return system.solve_moving_controls(x_prev, &xt, step, settings);
            }
            if !system.pattern.has_barrier() {
                let (x, s) = system.solve_from(&xt, &xt, step, settings)?;
                return Ok((x, StepStats { loads: 1, ..s }));
            }
            // From the Newton predictor (`super::predictor`), or else the previous state.
            let delta = system.pattern.control_move(x_prev, &xt);
            let (_, x, s) = system.solve_stage((x_prev, &xt), (&delta, 1.0), step, settings)?;
            return Ok((x, StepStats { loads: 1, ..s }));
        }
        // The path of predicted states x̂(s) = (1 − s) x̂₀ + s x̃, with x̂₀ = x_prev + M⁻¹∇E(x_prev):
        // x_prev is the minimizer at s = 0 (same Hessian as the step it ended), x̃ at s = 1.
        let x0 = system.rest_predicted(x_prev, &self.inv_mass);
        // Load fractions in units of 1/(load_steps · 2^halvings), so that they are exact.
        let finest = 1usize << settings.load_halvings.min(MAX_LOAD_HALVINGS);
        let total = settings.load_steps.max(1) * finest;
        let (mut done, mut increment, mut smallest) = (0, finest, 1);
        let mut x = x_prev.clone();
        while done < total {
            let next = (done + increment).min(total);
            let xs = if next == total {
                xt.clone()
            } else {
                let s = next as f64 / total as f64;
                let mut xs = x0.clone();
                xs.data_mut()
                    .iter_mut()
                    .zip(xt.data())
                    .for_each(|(a, b)| *a += s * (b - *a));
                xs
            };
            // The smallest increment takes whatever path it needs (past a fold or a bifurcation
            // of the branch); where that ends at a saddle too shallow to leave (just past a
            // bifurcation its unstable mode lowers Φ by less than Φ's round-off), it is doubled.
            let convex_only = increment > smallest;
            let (xj, sj) = match system.solve_inner(&x, &xs, step, settings, convex_only) {
                Err(ClothError::NewtonSaddle { .. }) if next < total => {
                    stats.rejected_loads += 1;
                    smallest = (2 * smallest).min(total - done);
                    increment = smallest;
                    continue;
                }
                // Self-contact: the increment's control move put the cloth within the thickness
                // of itself at the solve's start; a smaller one may not.
                Err(ClothError::SelfContactPenetration { .. }) if increment > 1 => {
                    stats.rejected_loads += 1;
                    increment /= 2;
                    continue;
                }
                // At the finest increment the control move alone still does: the grippers move
                // in filtered stages instead, as without branch following, the cloth making way.
                Err(ClothError::SelfContactPenetration { .. }) => {
                    let (xj, sj) = system.solve_moving_controls(&x, &xs, step, settings)?;
                    (Some(xj), sj)
                }
                r => r?,
            };
            stats.add_work(&sj);
            let Some(xj) = xj else {
                stats.rejected_loads += 1;
                increment /= 2;
                continue;
            };
            stats.loads += 1;
            stats.residual = sj.residual;
            stats.at_roundoff = sj.at_roundoff;
            x = xj;
            done = next;
            increment = (2 * increment).min(finest);
            smallest = 1;
        }
        Ok((x, stats))
    }
}

impl Model {
    /// Step `step` from `x_prev` with control move `u`, solved from `from` moved by `delta` as
    /// far as the barriers allow ([`Model::simulate_newton_guided`]): `None` where that cannot
    /// start a solve or its solve does not converge (the step is then solved without it), else
    /// the solve's state or the rollout limits' error.
    fn solve_from_guess(
        &self,
        system: &mut NewtonSystem,
        (x_prev, u): (&Tensor, &Tensor),
        (from, delta): (&Tensor, &Tensor),
        step: usize,
        settings: &NewtonSettings,
    ) -> Option<Result<(Tensor, StepStats), ClothError>> {
        let xt = self.begin_step(x_prev, u);
        system.begin_step(x_prev);
        let a = system.pattern.max_move(from.data(), delta.data());
        let mut guess = from.clone();
        (guess.data_mut().iter_mut())
            .zip(delta.data())
            .for_each(|(g, d)| *g += a * d);
        match system.solve_from(&guess, &xt, step, settings) {
            Ok((x, s)) => Some(Ok((
                x,
                StepStats {
                    loads: 1,
                    from_guess: true,
                    ..s
                },
            ))),
            Err(
                e @ (ClothError::NewtonWorkExceeded { .. } | ClothError::RolloutStopped { .. }),
            ) => Some(Err(e)),
            Err(_) => None,
        }
    }
}

impl NewtonSystem {
    /// Whether step `step`'s solve, `iterations` into it, may take another Newton iteration
    /// within the counted rollout's limits ([`Model::simulate_counted`]).
    pub(super) fn within_limits(&self, step: usize, iterations: usize) -> Result<(), ClothError> {
        let bound = self.limits.iterations_by(step);
        if self.work_done + iterations >= bound {
            return Err(ClothError::NewtonWorkExceeded {
                step,
                iterations: self.work_done + iterations,
                bound,
            });
        }
        if self.limits.halted() {
            return Err(ClothError::RolloutStopped { step });
        }
        Ok(())
    }
}
