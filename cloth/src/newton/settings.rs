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
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            load_steps: 1,
            load_halvings: DEFAULT_LOAD_HALVINGS,
            chord_steps: true,
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
