//! Newton's method on one step's `Φ` (the rollout built from it is in [`super::continuation`]).
//!
//! Each iteration assembles `∇Φ` and the exact Hessian; when its Cholesky factorization fails
//! (the Hessian is indefinite away from the minimizer), the Hessian is rebuilt with every
//! constraint's block projected to positive semidefinite, which with the mass term is positive
//! definite. The step is scaled by backtracking (Armijo) on `Φ`. Where `Φ`'s predicted decrease is
//! below its round-off, the full step is taken if it reduces `‖∇Φ‖`; otherwise (and when the step
//! itself is round-off) the state is as converged as `f64` allows ([`StepStats::at_roundoff`]).
//! A state is returned as converged only where the exact Hessian is positive definite (a
//! minimizer, where the implicit gradient is defined): a loose tolerance can be met at a saddle of
//! `Φ` (measured: `physics.tolerance` 1e-4 on `u_obstacle`), and the solve then goes on.
//!
//! *Chord steps* ([`NewtonSettings::chord_steps`]): near convergence (relative residual at most
//! [`CHORD_RESIDUAL`]), after a whole step with the exact Hessian's factorization, the next step
//! first solves with that same factorization (a triangular solve and a gradient instead of an
//! assembly and a factorization); it is kept when it lowers `Φ` and the KKT residual by at least
//! [`CHORD_CONTRACTION`], else the iteration refactorizes at the current state. Chord steps do
//! not change what is returned: the convergence test still factorizes the exact Hessian at the
//! final state, and only a minimizer is returned.

use super::assembly::{HessianKind, Pattern};
use super::contact::Contacts;
use super::curvature::{shift_after, Escape};
use super::factor::{Factor, FactorCounts};
pub use super::stats::StepStats;
use super::{check_supported, NewtonSettings};
use crate::error::ClothError;
use crate::geometry::euclidean as norm;
use crate::model::Model;
use crate::rollout::limits::RolloutLimits;
use crate::xpbd::sim::check_finite;
use autodiff::Tensor;

/// Armijo's sufficient-decrease constant.
const ARMIJO: f64 = 1e-4;
/// A Newton step no larger than this many ulps of the largest coordinate is round-off.
const ROUNDOFF_STEP: f64 = 16.0;
/// A predicted decrease of `Φ` below this many ulps of `Φ` is round-off.
const PHI_ROUNDOFF: f64 = 1024.0;
/// Halvings of the step before the line search gives up.
const MAX_HALVINGS: usize = 40;
/// A chord step is kept when the KKT residual falls at least by this factor.
pub const CHORD_CONTRACTION: f64 = 0.25;
/// Chord steps are tried only where the relative residual is at most this. Farther out they
/// cost more than they save (the Hessian changes fast along a buckling cloth's soft modes), and
/// their iterates, which no factorization tests, can leave the convex region unseen, so the
/// branch following would judge a load increment by another path than Newton's. Measured on
/// `u_obstacle` at n = 40 (factorizations per forward, chord steps): none 180; 1e-6: 143, 66;
/// 1e-5: 142, 101; 1e-3: 142, 125; everywhere: 165, 165 (and 22 rejected load increments
/// instead of 16).
pub const CHORD_RESIDUAL: f64 = 1e-5;

/// A model's Newton system with its buffers: built once per rollout.
pub struct NewtonSystem {
    /// The sparse pattern and the energy.
    pub pattern: Pattern,
    /// The Cholesky factorization.
    pub factor: Factor,
    /// The contact rows and their active set at the last state assembled.
    pub contacts: Contacts,
    pub(super) values: Vec<f64>,
    pub(super) grad: Vec<f64>,
    pub(super) dir: Vec<f64>,
    /// Self-contact: the last patterns left for another, with their symbolic analyses.
    pub(super) recent: Vec<(Pattern, Factor)>,
    /// `dir` holds the Newton direction from conjugate gradients: set by `newton_matrix`
    /// (`super::pcg`), taken by the next `newton_direction`.
    pub(super) pcg_direction: bool,
    /// What a counted rollout may spend ([`Model::simulate_counted`]): Newton iterations by
    /// the end of each step, a deadline, a stop flag; none by default.
    pub(super) limits: RolloutLimits,
    /// Newton iterations of the solves so far.
    pub(super) work_done: usize,
    /// Searches for a saddle's unstable mode so far (`leave_saddle`'s Lanczos runs).
    pub(super) saddle_searches: usize,
}

impl NewtonSystem {
    /// The system of `model`.
    ///
    /// # Errors
    /// [`ClothError::NewtonUnsupported`] for a rigid constraint group that is not a contact row.
    pub fn new(model: &Model) -> Result<NewtonSystem, ClothError> {
        check_supported(model)?;
        let pattern = Pattern::new(model);
        let factor = Factor::new(&pattern);
        let contacts = Contacts::new(model, &pattern);
        let (nnz, n) = (pattern.nnz(), pattern.n_dof);
        Ok(NewtonSystem {
            pattern,
            factor,
            contacts,
            values: vec![0.0; nnz],
            grad: vec![0.0; n],
            dir: vec![0.0; n],
            recent: Vec::new(),
            pcg_direction: false,
            limits: RolloutLimits::default(),
            work_done: 0,
            saddle_searches: 0,
        })
    }

    /// Starts a step from `y` (the previous state): lags the smooth contact's friction there
    /// ([`Pattern::begin_step`]).
    pub fn begin_step(&mut self, y: &Tensor) {
        self.pattern.begin_step(y.data());
    }

    /// Assembles `∇Φ` and the Hessian of `kind` at `x`; with contact rows, the active set at `x`
    /// and the reduced matrix `K` ([`Contacts::reduce`]; `curvature` for the exact Lagrangian).
    pub(super) fn assemble_at(&mut self, x: &[f64], xt: &[f64], kind: HessianKind) {
        self.fit_self_contact(x);
        let values = Some((&mut self.values[..], kind));
        self.pattern.assemble(x, xt, &mut self.grad, values);
        if self.contacts.any() {
            self.contacts.activate(x, &self.grad);
            let curvature = kind == HessianKind::Exact;
            self.contacts
                .reduce(&self.pattern, &mut self.values, curvature);
        }
    }

    /// Assembles `∇Φ` at `x` (and the contacts' active set), without a Hessian.
    pub(super) fn assemble_gradient_at(&mut self, x: &[f64], xt: &[f64]) {
        self.pattern.assemble(x, xt, &mut self.grad, None);
        if self.contacts.any() {
            self.contacts.activate(x, &self.grad);
        }
    }

    /// One chord step from `x`: the direction from the current factorization (of the exact
    /// Hessian at an earlier state, made with the contacts' active set `set`), taken whole and
    /// kept when it lowers `Φ` (to its round-off) and the KKT residual by
    /// [`CHORD_CONTRACTION`]; returns the new `Φ`. `None` (and `x` unchanged) when it is not
    /// kept, when `x` is within the tolerance (the convergence test needs the exact Hessian at
    /// `x`) or outside [`CHORD_RESIDUAL`], when the active set has changed, or at the iteration
    /// limit. `fresh` says that the last assembly was at `x` (after an accepted chord step).
    #[allow(clippy::too_many_arguments)]
    fn chord_step(
        &mut self,
        x: &mut Tensor,
        trial: &mut Tensor,
        xt_d: &[f64],
        (r0, phi): (f64, f64),
        set: &[bool],
        settings: &NewtonSettings,
        stats: &mut StepStats,
        fresh: bool,
    ) -> Option<f64> {
        if stats.iterations == settings.max_iterations {
            return None;
        }
        if !fresh {
            self.assemble_gradient_at(x.data(), xt_d);
        }
        let res = self.residual();
        let relative = res / r0;
        if !(relative > settings.tolerance && relative <= CHORD_RESIDUAL)
            || self.contacts.active_set() != set
        {
            return None;
        }
        self.newton_direction();
        if self.pattern.max_step(x.data(), 1.0, &self.dir) < 1.0 {
            return None;
        }
        trial.data_mut().copy_from_slice(x.data());
        self.pattern.add_scaled(trial.data_mut(), 1.0, &self.dir);
        self.contacts.project(trial.data_mut());
        let phi_t = self.pattern.energy(trial.data(), xt_d);
        self.assemble_gradient_at(trial.data(), xt_d);
        let res_t = self.residual();
        let lower = phi_t <= phi + PHI_ROUNDOFF * f64::EPSILON * phi.abs();
        if lower && res_t <= CHORD_CONTRACTION * res {
            std::mem::swap(x, trial);
            stats.iterations += 1;
            stats.chord_steps += 1;
            Some(phi_t)
        } else {
            None
        }
    }

    /// The KKT residual `‖∇Φ‖` (normal components of active contacts removed) of the last
    /// [`NewtonSystem::assemble_at`].
    pub(super) fn residual(&self) -> f64 {
        if self.contacts.any() {
            self.contacts.residual_norm(&self.grad)
        } else {
            norm(&self.grad)
        }
    }

    /// `x + M⁻¹∇E(x)` (control particles as in `x`), with `E` the constraint energy and `M`
    /// the masses `1/inv_mass`: the predicted state for which `x` is stationary (a minimizer when
    /// `x` was one of any step's `Φ`: the Hessian does not depend on the predicted state).
    pub fn rest_predicted(&mut self, x: &Tensor, inv_mass: &[f64]) -> Tensor {
        self.pattern
            .assemble(x.data(), x.data(), &mut self.grad, None);
        let mut out = x.clone();
        for (p, &w) in inv_mass.iter().enumerate() {
            if let Some(d) = self.pattern.dof(p) {
                for k in 0..3 {
                    out.data_mut()[3 * p + k] += w * self.grad[d + k];
                }
            }
        }
        out
    }

    /// `x` is as converged as `f64` allows: `None` (and [`StepStats::at_roundoff`]) when it is
    /// a minimizer, else it leaves the saddle ([`NewtonSystem::leave_saddle`]) and returns the new
    /// `Φ`.
    ///
    /// # Errors
    /// [`ClothError::NewtonSaddle`] when the saddle cannot be left.
    fn settle(
        &mut self,
        x: &mut Tensor,
        xt_d: &[f64],
        minimizer: bool,
        stats: &mut StepStats,
        step: usize,
    ) -> Result<Option<f64>, ClothError> {
        stats.at_roundoff = minimizer;
        if minimizer {
            return Ok(None);
        }
        let residual = stats.residual;
        match self.leave_saddle(x, xt_d, stats) {
            Escape::Left(phi) => Ok(Some(phi)),
            _ => Err(ClothError::NewtonSaddle { step, residual }),
        }
    }

    /// Factorizes the exact Hessian of `Φ` at `x` for the predicted state `xt` (with contact
    /// rows: the reduced exact Hessian of the Lagrangian on the active set at `x`); false when
    /// it is not positive definite.
    pub fn factorize_exact(&mut self, x: &[f64], xt: &[f64]) -> bool {
        self.assemble_at(x, xt, HessianKind::Exact);
        self.factor.factorize(&self.pattern, &self.values)
    }

    /// Minimizes `Φ` from `xt` (the step's predicted state, see [`Model::begin_step`]).
    ///
    /// # Errors
    /// [`ClothError::NewtonNotConverged`] when the tolerance is not reached.
    #[cfg(any(test, feature = "internals"))]
    pub fn solve(
        &mut self,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<(Tensor, StepStats), ClothError> {
        self.solve_from(xt, xt, step, settings)
    }

    /// Minimizes `Φ` for the predicted state `xt`, starting from `start`'s free particles (the
    /// control particles are held at `xt`'s positions), subject to the contact rows (the start
    /// and every trial state are projected onto them). The tolerance stays relative to
    /// `‖∇Φ(xt)‖` (with contact rows: to the larger of that and `‖∇Φ‖` at the projected `xt`,
    /// whose mass term is the contact forces' scale).
    ///
    /// # Errors
    /// [`ClothError::NewtonNotConverged`] when the tolerance is not reached.
    pub fn solve_from(
        &mut self,
        start: &Tensor,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
    ) -> Result<(Tensor, StepStats), ClothError> {
        let (x, stats) = self.solve_inner(start, xt, step, settings, false)?;
        Ok((
            x.expect("a solve that may leave the convex region returns a state"),
            stats,
        ))
    }

    /// [`NewtonSystem::solve_from`]; with `convex_only`, the solve gives up (`None`, with the
    /// statistics so far) at the first iterate whose exact Hessian is not positive definite: the
    /// start was not in the convex neighbourhood of a minimizer, so where Newton ends depends on
    /// the path ([`Model::simulate_newton`]'s branch following).
    pub(super) fn solve_inner(
        &mut self,
        start: &Tensor,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
        convex_only: bool,
    ) -> Result<(Option<Tensor>, StepStats), ClothError> {
        let (before, self_before) = (self.factor.counts(), self.pattern.self_counts());
        let (x, mut stats) = self.solve_core(start, xt, step, settings, convex_only)?;
        self.work_done += stats.iterations;
        let FactorCounts {
            factorized, failed, ..
        } = self.factor.counts().since(before);
        stats.factorizations = factorized;
        stats.failed_factorizations = failed;
        (self.pattern.self_counts()).add_since(self_before, &mut stats);
        Ok((x, stats))
    }

    /// [`NewtonSystem::solve_inner`] without the factorization counts.
    fn solve_core(
        &mut self,
        start: &Tensor,
        xt: &Tensor,
        step: usize,
        settings: &NewtonSettings,
        convex_only: bool,
    ) -> Result<(Option<Tensor>, StepStats), ClothError> {
        let xt_d = xt.data();
        let stats = StepStats::default();
        let (x, r0) = self.start_at(start, xt);
        self.pattern.check_outside(x.data(), step)?;
        if let Some((particles, gap)) = self.pattern.self_penetration(x.data()) {
            return Err(ClothError::SelfContactPenetration {
                step,
                particles,
                gap,
            });
        }
        if r0 == 0.0 {
            // x̃ is already stationary; it must still be a minimizer for the implicit gradient.
            return if self.factorize_exact(xt_d, xt_d) {
                Ok((Some(xt.clone()), stats))
            } else {
                Err(ClothError::NewtonSaddle {
                    step,
                    residual: stats.residual,
                })
            };
        }
        let mut run = Run {
            xt_d,
            r0,
            step,
            settings,
            convex_only,
            phi: self.pattern.energy(x.data(), xt_d),
            trial: x.clone(),
            x,
            stats,
            stay_projected: false,
            chord: false,
            chord_set: Vec::new(),
            projected_from: None,
            shift: None,
        };
        loop {
            match self.iteration(&mut run)? {
                None => {}
                Some(End::Minimizer) => return Ok((Some(run.x), run.stats)),
                Some(End::LeftConvex) => return Ok((None, run.stats)),
            }
        }
    }

    /// The start of a solve for the predicted state `xt`: `start` with the control particles
    /// held at `xt` (and projected onto the contact rows), and the residual the tolerance is
    /// relative to ([`NewtonSystem::solve_from`]).
    pub(super) fn start_at(&mut self, start: &Tensor, xt: &Tensor) -> (Tensor, f64) {
        let xt_d = xt.data();
        self.pattern.assemble(xt_d, xt_d, &mut self.grad, None);
        let mut r0 = norm(&self.grad);
        let mut x = start.clone();
        self.pattern.hold_fixed(xt_d, x.data_mut());
        if self.contacts.any() {
            let mut projected = xt.clone();
            self.contacts.project(projected.data_mut());
            self.pattern
                .assemble(projected.data(), xt_d, &mut self.grad, None);
            r0 = r0.max(norm(&self.grad));
            self.contacts.project(x.data_mut());
        }
        if self.pattern.has_barrier() {
            // x̃ may be inside a collider, where the barrier adds nothing to the scale: the
            // start's forces count too.
            self.pattern.assemble(x.data(), xt_d, &mut self.grad, None);
            r0 = r0.max(norm(&self.grad));
        }
        (x, r0)
    }

    /// One Newton iteration at `run.x`, after the chord steps the last one allows: the
    /// convergence test (and the saddle escape), the Newton step with the exact or else the
    /// projected Hessian, and its line search. `Some` when the solve ends.
    fn iteration(&mut self, run: &mut Run<'_>) -> Result<Option<End>, ClothError> {
        // Chord steps only right after a whole exact step (`chord` is set again below).
        if std::mem::take(&mut run.chord) {
            self.chord_steps(run);
        }
        let test = self.test_iterate(run)?;
        if test.within_tolerance {
            if test.exact_pd {
                return Ok(Some(End::Minimizer));
            }
            // Within the tolerance but at a saddle of Φ: leave it along its unstable mode (none
            // found: keep descending; Φ flat along it to round-off: give up, `Escape`).
            run.stats.at_saddle += 1;
            if !run.convex_only {
                match self.leave_saddle(&mut run.x, run.xt_d, &mut run.stats) {
                    Escape::Left(phi_t) => {
                        (run.phi, run.stay_projected) = (phi_t, false);
                        return Ok(None);
                    }
                    Escape::TooShallow => {
                        let (step, residual) = (run.step, run.stats.residual);
                        return Err(ClothError::NewtonSaddle { step, residual });
                    }
                    Escape::NoDirection => {}
                }
            }
        }
        if run.stats.iterations == run.settings.max_iterations {
            return Err(run.not_converged());
        }
        if run.convex_only && !test.exact_pd {
            return Ok(Some(End::LeftConvex));
        }
        self.within_limits(run.step, run.stats.iterations)?;
        run.stats.iterations += 1;
        let stalled_from = run.projected_from.take();
        run.shift = shift_after(
            run.shift,
            stalled_from,
            test.res,
            run.settings.shift_stalled,
        );
        if !test.exact_pd {
            run.stats.projected += 1;
            let shift = run.shift.filter(|_| test.exact_tried);
            let shifted = shift.and_then(|last| self.shift_exact(last));
            if shifted.is_some() {
                run.shift = shifted;
            } else {
                if test.exact_tried {
                    self.assemble_at(run.x.data(), run.xt_d, HessianKind::Projected);
                }
                if !self.newton_matrix(true, run.settings, &mut run.stats) {
                    return Err(run.not_converged());
                }
            }
        }
        self.newton_direction();
        // A step at the coordinates' round-off cannot improve x: converged as far as f64 goes.
        if self.is_roundoff_step(&run.x) {
            return self.at_roundoff(run, &test);
        }
        let slope: f64 = self.dir.iter().zip(&self.grad).map(|(d, g)| d * g).sum();
        let (accepted, alpha) = if -slope <= PHI_ROUNDOFF * f64::EPSILON * run.phi.abs() {
            // Φ's predicted decrease is below its round-off, so Φ cannot rank the step:
            // take the full step if the residual drops; if it does not, x is as converged as
            // f64 allows.
            if self.full_step_residual(run) >= test.res {
                return self.at_roundoff(run, &test);
            }
            (Some(self.pattern.energy(run.trial.data(), run.xt_d)), 1.0)
        } else {
            self.armijo(run, slope)
        };
        let Some(phi_t) = accepted else {
            return Err(run.not_converged());
        };
        self.take_step(run, phi_t, test.exact_pd, alpha);
        if run.shift.is_some() {
            // The next iteration assembles the exact Hessian, to shift it if need be.
            run.stay_projected = false;
        } else if !test.exact_pd && alpha == 1.0 {
            run.projected_from = Some(test.res);
        }
        Ok(None)
    }

    /// Chord steps from `run.x` with the current factorization, as long as they are kept
    /// ([`NewtonSystem::chord_step`]).
    fn chord_steps(&mut self, run: &mut Run<'_>) {
        let mut fresh = false;
        while self.work_done + run.stats.iterations < self.limits.iterations_by(run.step) {
            let Some(phi_t) = self.chord_step(
                &mut run.x,
                &mut run.trial,
                run.xt_d,
                (run.r0, run.phi),
                &run.chord_set,
                run.settings,
                &mut run.stats,
                fresh,
            ) else {
                break;
            };
            run.phi = phi_t;
            fresh = true;
        }
    }

    /// Assembles at `run.x` (the projected Hessian while `run.stay_projected`), records the
    /// relative residual and tests it against the tolerance; factorizes the exact Hessian when
    /// it was assembled, or when the tolerance is met (the convergence test needs it).
    fn test_iterate(&mut self, run: &mut Run<'_>) -> Result<Test, ClothError> {
        let kind = if run.stay_projected {
            HessianKind::Projected
        } else {
            HessianKind::Exact
        };
        self.assemble_at(run.x.data(), run.xt_d, kind);
        let res = self.residual();
        run.stats.residual = res / run.r0;
        if !run.stats.residual.is_finite() {
            check_finite(&run.x, run.step)?;
        }
        let within_tolerance = run.stats.residual <= run.settings.tolerance;
        if kind == HessianKind::Projected && within_tolerance {
            // The convergence test needs the exact Hessian.
            self.assemble_at(run.x.data(), run.xt_d, HessianKind::Exact);
        }
        // The exact Hessian's factorization: the Newton matrix below, and the test that x is
        // a minimizer (the implicit gradient needs it positive definite at the returned state).
        let exact_tried = kind == HessianKind::Exact || within_tolerance;
        let exact_pd =
            exact_tried && self.newton_matrix(!within_tolerance, run.settings, &mut run.stats);
        Ok(Test {
            res,
            within_tolerance,
            exact_tried,
            exact_pd,
        })
    }

    /// The Newton direction `−K⁻¹∇Φ` (in the active contacts' tangent space) with the current
    /// factorization, into `dir` (already there when conjugate gradients found it).
    fn newton_direction(&mut self) {
        if std::mem::take(&mut self.pcg_direction) {
            return;
        }
        for (d, g) in self.dir.iter_mut().zip(&self.grad) {
            *d = -g;
        }
        self.contacts.project_tangent(&mut self.dir);
        self.factor.solve_in_place(&mut self.dir, 1);
        self.contacts.project_tangent(&mut self.dir);
    }

    /// The direction is at most [`ROUNDOFF_STEP`] ulps of `x`'s largest coordinate.
    fn is_roundoff_step(&self, x: &Tensor) -> bool {
        let x_max = x.data().iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let d_max = self.dir.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        d_max <= ROUNDOFF_STEP * f64::EPSILON * x_max
    }

    /// `run.x` is as converged as `f64` allows: the solve ends when it is a minimizer, else it
    /// leaves the saddle ([`NewtonSystem::settle`]) and goes on (`None`).
    fn at_roundoff(&mut self, run: &mut Run<'_>, test: &Test) -> Result<Option<End>, ClothError> {
        // As converged as f64 allows, but only a minimizer has an implicit gradient.
        // (Conjugate gradients' direction is no proof that the Hessian is positive definite.)
        let minimizer = if test.exact_pd {
            self.factor.holds(&self.values) || self.factorize_exact(run.x.data(), run.xt_d)
        } else {
            !test.exact_tried && self.factorize_exact(run.x.data(), run.xt_d)
        };
        match self.settle(&mut run.x, run.xt_d, minimizer, &mut run.stats, run.step)? {
            None => Ok(Some(End::Minimizer)),
            Some(phi_t) => {
                (run.phi, run.stay_projected) = (phi_t, false);
                Ok(None)
            }
        }
    }

    /// The KKT residual at the full step from `run.x` (into `run.trial`, projected onto the
    /// contact rows, with the active set there).
    fn full_step_residual(&self, run: &mut Run<'_>) -> f64 {
        let p = &self.pattern;
        if p.max_step(run.x.data(), 1.0, &self.dir) < 1.0 {
            // The full step would pass a collider (smooth contact): not a step to take.
            return f64::INFINITY;
        }
        let trial = &mut run.trial;
        trial.data_mut().copy_from_slice(run.x.data());
        p.add_scaled(trial.data_mut(), 1.0, &self.dir);
        let mut g = vec![0.0; self.grad.len()];
        if self.contacts.any() {
            self.contacts.project(trial.data_mut());
            p.assemble(trial.data(), run.xt_d, &mut g, None);
            let mut at_trial = self.contacts.clone();
            at_trial.activate(trial.data(), &g);
            at_trial.residual_norm(&g)
        } else {
            p.assemble(trial.data(), run.xt_d, &mut g, None);
            norm(&g)
        }
    }

    /// Backtracking (Armijo) on `Φ` from `run.x` along the direction, into `run.trial`: its
    /// `Φ` (`None` after [`MAX_HALVINGS`] halvings) and the step length.
    fn armijo(&self, run: &mut Run<'_>, slope: f64) -> (Option<f64>, f64) {
        let p = &self.pattern;
        // Smooth contact: no trial state may pass a collider (the step filter).
        let mut alpha = p.max_step(run.x.data(), 1.0, &self.dir);
        if alpha == 0.0 {
            return (None, alpha);
        }
        for _ in 0..MAX_HALVINGS {
            run.trial.data_mut().copy_from_slice(run.x.data());
            p.add_scaled(run.trial.data_mut(), alpha, &self.dir);
            self.contacts.project(run.trial.data_mut());
            let phi_t = p.energy(run.trial.data(), run.xt_d);
            if phi_t <= run.phi + ARMIJO * alpha * slope {
                return (Some(phi_t), alpha);
            }
            alpha *= 0.5;
        }
        (None, alpha)
    }

    /// Moves to the accepted trial state (`Φ` = `phi_t`, step length `alpha`): the next
    /// iteration stays with the projected Hessian after a shortened projected step and tries
    /// chord steps after a whole exact one.
    fn take_step(&self, run: &mut Run<'_>, phi_t: f64, exact_pd: bool, alpha: f64) {
        run.stay_projected = !exact_pd && alpha < 1.0;
        run.chord = run.settings.chord_steps && exact_pd && alpha == 1.0;
        if run.chord {
            run.chord_set.clear();
            run.chord_set.extend_from_slice(self.contacts.active_set());
        }
        run.phi = phi_t;
        std::mem::swap(&mut run.x, &mut run.trial);
    }
}

/// One solve under way: what it was asked, its iterate and what each iteration leaves the next.
struct Run<'a> {
    /// The predicted state's coordinates.
    xt_d: &'a [f64],
    /// The residual the tolerance is relative to.
    r0: f64,
    step: usize,
    settings: &'a NewtonSettings,
    convex_only: bool,
    x: Tensor,
    /// The line search's trial state (swapped with `x` when accepted).
    trial: Tensor,
    /// `Φ(x)`.
    phi: f64,
    stats: StepStats,
    /// After a projected iteration whose line search shortened the step, x is still far from
    /// the region where the exact Hessian is positive definite: the next iteration goes
    /// straight to the projected Hessian (one factorization instead of a failed exact one and
    /// the projected one). A full projected step, or the tolerance, tries the exact one again.
    stay_projected: bool,
    /// Chord steps may use the current factorization: the exact Hessian, positive definite, at
    /// the last iterate, from which the step was whole.
    chord: bool,
    /// The contacts' active set of that factorization.
    chord_set: Vec<bool>,
    /// The residual where the last whole step with the projected Hessian started.
    projected_from: Option<f64>,
    /// Once the projected Hessian has stalled: the last shift of the exact one that factorized
    /// (in units of its mean diagonal).
    shift: Option<f64>,
}

impl Run<'_> {
    /// [`ClothError::NewtonNotConverged`] with the iterations and residual so far.
    fn not_converged(&self) -> ClothError {
        ClothError::NewtonNotConverged {
            step: self.step,
            iterations: self.stats.iterations,
            residual: self.stats.residual,
            tolerance: self.settings.tolerance,
        }
    }
}

/// How a solve ends without an error.
enum End {
    /// At a minimizer: the state is returned.
    Minimizer,
    /// `convex_only`, at an iterate whose exact Hessian is not positive definite.
    LeftConvex,
}

/// The tests at an iterate ([`NewtonSystem::test_iterate`]).
struct Test {
    /// The KKT residual `‖∇Φ‖`.
    res: f64,
    within_tolerance: bool,
    /// The exact Hessian was factorized ...
    exact_tried: bool,
    /// ... and is positive definite.
    exact_pd: bool,
}
