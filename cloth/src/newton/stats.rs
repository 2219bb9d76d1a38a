//! What a Newton step's solve did: iteration, factorization and load counts.

/// What one step's Newton solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Newton iterations: steps with a factorization of the exact or projected Hessian at the
    /// iterate, and chord steps ([`StepStats::chord_steps`]).
    pub iterations: usize,
    /// Iterations that reused an earlier iterate's factorization (chord steps).
    pub chord_steps: usize,
    /// Numeric factorizations that succeeded (the Newton matrices, the convergence tests at the
    /// final states, saddle escapes).
    pub factorizations: usize,
    /// Numeric factorizations that found the exact Hessian not positive definite.
    pub failed_factorizations: usize,
    /// Newton directions from preconditioned conjugate gradients ([`crate::LinearSolver::Pcg`])
    /// instead of a factorization.
    pub pcg_solves: usize,
    /// Conjugate gradient iterations, over all attempts.
    pub pcg_iterations: usize,
    /// Attempts of conjugate gradients that gave up (too many iterations, a stalled residual or
    /// negative curvature), so the matrix was factorized.
    pub pcg_fallbacks: usize,
    /// Iterations that fell back to the projected Hessian.
    pub projected: usize,
    /// Final `‖∇Φ‖` relative to its value at `x̃`.
    pub residual: f64,
    /// The tolerance was not reached, but the Newton step had shrunk to the coordinates'
    /// round-off (the residual is the floor `f64` allows).
    pub at_roundoff: bool,
    /// Iterations that were within the tolerance but not at a minimizer (the exact Hessian was
    /// not positive definite), so the solve went on.
    pub at_saddle: usize,
    /// Saddles of `Φ` left along their unstable mode (`cloth/src/newton/curvature.rs`).
    pub escapes: usize,
    /// Load increments solved ([`crate::NewtonSettings::load_steps`] or more, when halved).
    pub loads: usize,
    /// Load increments abandoned and halved because a solve left the region where the exact
    /// Hessian is positive definite.
    pub rejected_loads: usize,
    /// Self-contact: states whose pairs were searched (not filtered from a sweep).
    pub pair_searches: usize,
    /// Self-contact: searches over the whole cloth (a grid of the vertices and one of the
    /// edges), for the pairs of a state or a step filter's sweep; the others are filtered from
    /// the last search's candidate list (`cloth/src/contact/self_candidates.rs`).
    pub grid_searches: usize,
    /// Self-contact: states whose pairs were filtered from the last step filter's sweep
    /// instead of searched.
    pub pair_filters: usize,
    /// Self-contact: step filters (continuous collision detection along a straight motion,
    /// each with a sweep of the cloth).
    pub step_filters: usize,
    /// Self-contact: rebuilds of the Hessian's pattern, each with a new symbolic analysis,
    /// because the pairs coupled other particle blocks.
    pub pattern_rebuilds: usize,
    /// Self-contact: changes of the Hessian's pattern back to one of the last patterns left,
    /// whose symbolic analysis was kept.
    pub pattern_reuses: usize,
    /// The solve started from a guess ([`crate::Model::simulate_newton_guided`]) and converged.
    pub from_guess: bool,
}

impl StepStats {
    /// Adds `other`'s work counts (iterations, chord steps, factorizations, failed
    /// factorizations, conjugate gradients' counts, projected iterations, saddles, escapes,
    /// self-contact's searches, filters, pattern rebuilds and reuses) to these; the residual, the
    /// round-off flag and the load counts stay.
    pub fn add_work(&mut self, other: &StepStats) {
        self.iterations += other.iterations;
        self.chord_steps += other.chord_steps;
        self.factorizations += other.factorizations;
        self.failed_factorizations += other.failed_factorizations;
        self.pcg_solves += other.pcg_solves;
        self.pcg_iterations += other.pcg_iterations;
        self.pcg_fallbacks += other.pcg_fallbacks;
        self.projected += other.projected;
        self.at_saddle += other.at_saddle;
        self.escapes += other.escapes;
        self.pair_searches += other.pair_searches;
        self.pair_filters += other.pair_filters;
        self.step_filters += other.step_filters;
        self.pattern_rebuilds += other.pattern_rebuilds;
        self.pattern_reuses += other.pattern_reuses;
        self.grid_searches += other.grid_searches;
    }
}
