//! The cloth crate's errors.

use crate::scene::SceneError;

/// Everything that can go wrong building or running a cloth model.
#[derive(Debug, thiserror::Error)]
pub enum ClothError {
    /// The scene was rejected (malformed, or a field out of range).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A constraint set could not be added.
    #[error("constraint group `{name}`: {reason}")]
    InvalidConstraint {
        /// The group's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// The controls do not match the scene.
    #[error("controls: {0}")]
    Controls(String),
    /// The rollout stayed finite, but a cost or a gradient of it overflowed (controls or scene
    /// values too large for `f64`); `quantity` names it (e.g. `G`, or `dL/dU at step 3, control 1`).
    #[error("{quantity} is not finite ({value}): the rollout's values exceed the range of f64")]
    NonFinite {
        /// What is not finite.
        quantity: String,
        /// Its value.
        value: f64,
    },
    /// The simulation produced a non-finite position.
    #[error("simulation diverged at step {step}: particle {particle} is at {position:?}")]
    Diverged {
        /// Time step (1-based) whose result is not finite.
        step: usize,
        /// First particle with a non-finite coordinate.
        particle: usize,
        /// Its position.
        position: [f64; 3],
    },
    /// A Newton step did not reach `physics.tolerance` within `physics.max_newton_iterations`.
    #[error(
        "Newton solver did not converge at step {step}: relative residual ‖∇Φ‖ {residual:e} after \
         {iterations} iterations (physics.tolerance {tolerance:e}, physics.max_newton_iterations)"
    )]
    NewtonNotConverged {
        /// Time step (1-based).
        step: usize,
        /// Newton iterations performed.
        iterations: usize,
        /// `‖∇Φ‖` relative to its value at the step's predicted state.
        residual: f64,
        /// The tolerance asked for.
        tolerance: f64,
    },
    /// A Newton step came to rest at a stationary point of `Φ` that is not a minimizer (its
    /// exact Hessian is not positive definite): the cloth can buckle either way there, and the
    /// implicit gradient of the step is not defined.
    #[error(
        "Newton solver stopped at step {step} at a saddle of Φ, not a minimizer (the exact Hessian \
         is not positive definite; relative residual ‖∇Φ‖ {residual:e}): the step's gradient is \
         not defined there"
    )]
    NewtonSaddle {
        /// Time step (1-based).
        step: usize,
        /// `‖∇Φ‖` relative to its value at the step's predicted state.
        residual: f64,
    },
    /// The model has a constraint group Newton's method cannot handle.
    #[error("physics.solver \"newton\": constraint group `{group}`: {reason}")]
    NewtonUnsupported {
        /// The group's name.
        group: String,
        /// Why.
        reason: String,
    },
    /// Smooth contact: a step starts with a particle on or inside a collider, where the
    /// barrier potential is infinite.
    #[error(
        "step {step}: particle {particle} is on or inside a collider (signed distance {distance:e}); \
         the smooth contact model needs every particle strictly outside"
    )]
    ContactPenetration {
        /// The step (1-based).
        step: usize,
        /// The particle.
        particle: usize,
        /// Its signed distance to the colliders (≤ 0).
        distance: f64,
    },
    /// Smooth contact along the edges: a step starts with a point of an edge on or inside a
    /// collider narrower than the cloth's edges.
    #[error(
        "step {step}: the edge between particles {edge:?} is on or inside a collider {t} of the way \
         along it (signed distance {distance:e}); the smooth contact model needs every edge \
         strictly outside the colliders narrower than it"
    )]
    EdgeContactPenetration {
        /// The step (1-based).
        step: usize,
        /// The edge's particles.
        edge: [usize; 2],
        /// The point's fraction along the edge.
        t: f64,
        /// Its signed distance to the narrow colliders (≤ 0).
        distance: f64,
    },
    /// Self-contact under Newton: a step starts with two parts of the cloth at or within the
    /// thickness (the control particles' move can bring them there), where the barrier is
    /// infinite.
    #[error(
        "step {step}: particles {particles:?} (a vertex and a triangle, or two edges) are within \
         the self-collision thickness (gap {gap:e}); the self-contact barrier needs every part of \
         the cloth apart by physics.self_collision.thickness (a gripper moved too far in one \
         step, or pressed the cloth onto itself or a collider?)"
    )]
    SelfContactPenetration {
        /// The step (1-based).
        step: usize,
        /// The pair's particles: vertex then triangle, or edge then edge.
        particles: [usize; 4],
        /// Its distance less the thickness (≤ 0).
        gap: f64,
    },
    /// A Newton rollout asked to stay within a number of iterations
    /// ([`crate::Model::simulate_counted`]) passed it.
    #[error(
        "Newton rollout stopped at step {step} after {iterations} iterations: it would take more \
         than the {bound} allowed by the end of that step"
    )]
    NewtonWorkExceeded {
        /// The step (1-based) whose solve would have passed the bound.
        step: usize,
        /// Newton iterations taken (the bound).
        iterations: usize,
        /// The bound: the iterations allowed by the end of that step.
        bound: usize,
    },
    /// Derivatives with respect to a physical parameter ([`crate::Model::parameter_tangents`])
    /// cannot be taken for this model.
    #[error("parameter derivatives: {0}")]
    ParameterDerivative(String),
    /// The guesses a guided rollout starts its steps from ([`crate::Model::simulate_newton_guided`])
    /// do not match the model.
    #[error("guided rollout's guesses: {0}")]
    Guesses(String),
    /// A counted rollout ([`crate::Model::simulate_counted`]) was asked to stop: its deadline
    /// passed or its stop flag was raised ([`crate::RolloutLimits`]).
    #[error("rollout stopped at step {step}: its deadline passed or it was interrupted")]
    RolloutStopped {
        /// The step (1-based) that was being solved.
        step: usize,
    },
}
