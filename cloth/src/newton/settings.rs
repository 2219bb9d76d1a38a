//! What the Newton solver is asked for: its convergence settings and their defaults, and which
//! method solves each step. Data only, below the model that stores it.

/// Default [`NewtonSettings::tolerance`]: `‖∇Φ‖` at most `1e-10` of its value at `x̃`.
pub const DEFAULT_TOLERANCE: f64 = 1e-10;
/// Default [`NewtonSettings::max_iterations`]: a guard against true non-convergence, not a
/// budget. Near the SQP's iterates on `u_obstacle` a step can need 171 iterations (measured over
/// 200 perturbed controls: long stretches on the projected Hessian while edges are compressed);
/// at the former cap of 50, 17 of those 200 rollouts failed, and the planner's line search,
/// which takes a failed evaluation for "step too long", shrank its steps to 1e-9 and stalled.
pub const DEFAULT_MAX_ITERATIONS: usize = 500;

/// Default [`NewtonSettings::load_halvings`]: the smallest increment is 1/1024 of a step's load.
/// Measured on `u_obstacle` (`optimize --physics newton --search off`): 0 stalls (the rollout
/// jumps between minima), 3 stalls, 6 converges after 244 SQP iterations (its smallest increments
/// still take projected paths), 8, 10 and 12 converge after 77, 63 and 169 to the same plan.
pub const DEFAULT_LOAD_HALVINGS: usize = 10;

/// Default [`LinearSolver::Pcg`] `tolerance`: the inexact Newton condition
/// `‖H d + ∇Φ‖ ≤ tolerance · ‖∇Φ‖` on the direction `d`. Measured on `u_obstacle` 40 × 40
/// (forward pass, 8 iterations at most): 1e-1 takes 295 Newton iterations and 21 rejected load
/// increments (direct: 216 and 17), 1e-2 237 and 17, 1e-3 220 and 17 with 464 conjugate
/// gradient iterations instead of 360.
pub const DEFAULT_PCG_TOLERANCE: f64 = 1e-2;
/// Default [`LinearSolver::Pcg`] `max_iterations`. Each iteration costs a solve with the
/// preconditioner and a product with the matrix (a solve is about a sixteenth of a
/// factorization at `u_obstacle` 40 × 40: criterion `newton_parts`, 0.64 against 10.3 ms), but
/// the limit is seldom what ends an attempt: there (forward pass) 12 or 30 give 107 directions,
/// 332 iterations and 63 fallbacks against 4's 102, 328 and 66, the same time within the noise;
/// the attempts that fall back stall (`super::pcg::STALL`) or meet negative curvature first.
pub const DEFAULT_PCG_MAX_ITERATIONS: usize = 4;

/// How Newton's linear systems are solved (`cloth/src/newton/pcg.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum LinearSolver {
    /// A sparse Cholesky factorization of every Newton matrix (the exact Hessian, or the
    /// projected one where the exact one is not positive definite).
    #[default]
    Direct,
    /// Conjugate gradients preconditioned with the last successful factorization, reused across
    /// iterations and steps; the matrix is factorized (and becomes the preconditioner) when
    /// they need more than `max_iterations`, stall or meet non-positive curvature. The
    /// convergence test at a solve's end and the implicit gradient still factorize. The
    /// returned states are minimizers to the same tolerance as with [`LinearSolver::Direct`],
    /// not the same bits. Not the default: at `u_obstacle` 40 × 40 it halves the factorizations
    /// but not the time (docs/performance.md, "Newton's linear solves by PCG").
    Pcg {
        /// They stop at a residual `‖r‖` at most this fraction of the right-hand side's
        /// (default [`DEFAULT_PCG_TOLERANCE`]).
        tolerance: f64,
        /// Iterations before falling back to a factorization (default
        /// [`DEFAULT_PCG_MAX_ITERATIONS`]).
        max_iterations: usize,
    },
}

impl LinearSolver {
    /// Conjugate gradients with the default tolerance and iteration limit.
    pub const PCG: LinearSolver = LinearSolver::Pcg {
        tolerance: DEFAULT_PCG_TOLERANCE,
        max_iterations: DEFAULT_PCG_MAX_ITERATIONS,
    };
}

/// Convergence settings of the Newton solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewtonSettings {
    /// A step has converged when `‖∇Φ(x)‖ ≤ tolerance · ‖∇Φ(x̃)‖`.
    pub tolerance: f64,
    /// Newton iterations per step before [`crate::ClothError::NewtonNotConverged`].
    pub max_iterations: usize,
    /// Load steps (continuation) per time step: the step's load (its control move and gravity)
    /// is applied along a path of predicted states from one for which the previous state is the
    /// minimizer to `x̃`, in at least this many equal parts, each solve starting from the last
    /// one's minimizer. `1` with [`NewtonSettings::load_halvings`] `0` is one solve from `x̃`.
    pub load_steps: usize,
    /// Branch following: a load increment whose solve meets a state where the exact Hessian is
    /// not positive definite (so where it ends depends on the path: the start was not in the
    /// convex neighbourhood of the minimizer it continues) is abandoned and halved, at most this
    /// many times; the smallest increment takes whatever path it needs (past a fold or
    /// bifurcation of the branch) and leaves a saddle along its unstable mode. Where a step's
    /// `Φ` has several minima (a cloth that can buckle either way), one solve from `x̃` can end
    /// in either under a `1e-11` change of the controls; following the branch of the previous
    /// state, the rollout jumps only where that branch ends (`cloth/tests/newton_branches.rs`).
    /// The final state is a minimizer of the same `Φ`, so the implicit gradients are unchanged.
    pub load_halvings: usize,
    /// Chord steps (`cloth/src/newton/solve.rs`): after a whole step with the exact Hessian, the
    /// next steps reuse its factorization while the KKT residual falls by `CHORD_CONTRACTION`
    /// (`cloth/src/newton/solve.rs`) per step. The returned state is a minimizer to the same
    /// tolerance either way.
    pub chord_steps: bool,
    /// Where the exact Hessian is indefinite, the iteration takes its per-term semidefinite
    /// projection; with this, once a whole projected step leaves the KKT residual above 90% of
    /// where it started, the solve shifts the exact Hessian instead (by the smallest multiple of
    /// its mean diagonal, in a geometric sequence, that factorizes;
    /// `cloth/src/newton/curvature.rs`). The returned state is a minimizer to the same tolerance
    /// either way, maybe another one where `Φ` has several. Default true: `drop` with its
    /// grippers lowered to the ground at 25 × 25 takes 266 Newton iterations instead of 451.
    pub shift_stalled: bool,
    /// How each Newton matrix is solved.
    pub linear_solver: LinearSolver,
    /// Smooth contact: each solve (under self-contact, each control stage) starts from the
    /// Newton predictor, the cloth moved with the grippers by its first-order response
    /// (`cloth/src/newton/predictor.rs`), as far as the barriers' step filters allow, instead of
    /// where the last solve left it; a solve from there that does not converge within
    /// `PREDICTED_ITERATIONS` is solved again from the plain start. One more factorization per
    /// solve. The returned state is a minimizer to the same tolerance either way, maybe another
    /// one where `Φ` has several. Default true: the task suite's `fold_half` rollout with its
    /// gradient takes 240 Newton iterations in 22 stages instead of 631 in 54, `lay_aside`'s 186
    /// instead of 274 (docs/performance.md).
    pub predictor: bool,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            load_steps: 1,
            load_halvings: DEFAULT_LOAD_HALVINGS,
            chord_steps: true,
            shift_stalled: true,
            linear_solver: LinearSolver::Direct,
            predictor: true,
        }
    }
}

/// Which method solves each quasi-static step.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Solver {
    /// [`crate::Model::iterations`] XPBD Gauss–Seidel sweeps (the paper's method), differentiated by
    /// unrolling.
    #[default]
    Xpbd,
    /// Newton's method to convergence, differentiated implicitly.
    Newton(NewtonSettings),
}
