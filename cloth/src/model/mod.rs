//! A scene compiled to the effects it calls for, and nothing else: the data every solver reads.
//!
//! No bending sets when bending is off, no gravity work when `g = 0`, no collider projection
//! without a collider, no signed-distance evaluation without a safety obstacle. [`compile`] builds
//! a [`Model`] from a scene; every constraint type, built-in or user-written, enters through
//! [`Model::add_constraints`]. The types a model stores are defined below it (`xpbd::set`,
//! `newton::settings`, `contact::self_collision`, `newton::terms`, `sdf`), so nothing here names
//! the modules that step, differentiate or search.

mod compile;

pub use compile::DEFAULT_CHECKPOINT_BUDGET;

use crate::contact::barrier::ColliderBarrier;
use crate::contact::edge_points::EdgeBarrier;
use crate::contact::self_barrier::SelfBarrier;
use crate::contact::self_collision::SelfCollision;
use crate::newton::settings::Solver;
use crate::newton::terms::ConstraintTerms;
use crate::scene::Limits;
use crate::sdf::Union;
use crate::xpbd::set::{Carry, ProjectionSet};
use autodiff::{DynRowFn, RowIndex, Tensor};
use std::sync::Arc;

/// All constraints of one type: their colour sets (in sweep order) and their energy.
#[derive(Clone)]
pub struct ConstraintGroup {
    /// A short name (`stretch`, `bending`, `collider`, or a user's).
    pub name: String,
    /// Number of constraints.
    pub count: usize,
    /// Colour sets, visited in order every iteration.
    pub sets: Vec<ProjectionSet>,
    /// `½ k C²` per constraint, with the particles of every constraint; `None` for inequality and
    /// rigid constraints, which carry no elastic energy.
    pub energy: Option<(Arc<dyn DynRowFn>, Arc<RowIndex>)>,
    /// The constraints with their second derivatives, for the Newton solver.
    pub terms: Arc<dyn ConstraintTerms>,
}

/// The task: targets and cost weights.
#[derive(Clone, Debug)]
pub struct TaskSpec {
    /// Number of time steps `T`.
    pub horizon: usize,
    /// Target particles.
    pub targets: Arc<RowIndex>,
    /// Target positions (`targets × 3`).
    pub target_positions: Tensor,
    /// Weight of the trajectory irregularity `T`.
    pub alpha: f64,
    /// Weight of the elastic energy `E`.
    pub beta: f64,
    /// Safety margin `δ`.
    pub delta: f64,
    /// Robot limits (`task.limits`; empty when the scene sets none).
    pub limits: Limits,
    /// Distance within which a target counts as reached at the final step (`task.tolerance`).
    pub tolerance: f64,
}

/// A compiled, ready-to-simulate scene.
#[derive(Clone)]
pub struct Model {
    /// The cloth's positions at step 0 (`N × 3`): its rest shape or `cloth.initial_state`, with
    /// the particles a smooth collider's barrier reaches moved out to `d̂/2`.
    pub start: Tensor,
    /// The rest shape (`N × 3`), from which the constraints' rest values are measured.
    pub rest_shape: Tensor,
    /// The cloth's triangles (particle indices; [`crate::ClothMesh::triangles`]), for
    /// figures and exports.
    pub triangles: Arc<[[usize; 3]]>,
    /// Inverse mass per particle (0 for control particles).
    pub inv_mass: Vec<f64>,
    /// Control particles, in the order of the controls' rows.
    pub controls: Arc<RowIndex>,
    /// `½ g Δt²` added to every particle each step; `None` when `g = 0`.
    pub gravity_step: Option<[f64; 3]>,
    /// Time step `Δt`.
    pub dt: f64,
    /// Gauss–Seidel iterations per step.
    pub iterations: usize,
    /// Constraint groups in sweep order.
    pub groups: Vec<ConstraintGroup>,
    /// Per-particle signed distance to the safety obstacles (`N × 3 → N × 1`); `None` without any.
    pub safety: Option<Arc<dyn DynRowFn>>,
    /// Per-particle signed distance to each safety primitive (`N × 3 → N × primitives`).
    pub safety_components: Option<Arc<dyn DynRowFn>>,
    /// The safety obstacles themselves (empty without any), shared with the safety row functions.
    pub safety_obstacles: Arc<Union>,
    /// The physical colliders (empty without any), projected as the `collider` group.
    pub colliders: Union,
    /// The task.
    pub task: TaskSpec,
    /// Edge strain `|x_i − x_j|/L₀ − 1` per stretch edge (`6 → 1`) with the edges' particles;
    /// `None` when the cloth has no stretch edge of positive rest length.
    pub strain: Option<(Arc<dyn DynRowFn>, Arc<RowIndex>)>,
    /// Under smooth self-contact, the gap `d − h` of a held particle and a triangle (`12 → 1`)
    /// with every pair of a control particle and a triangle not incident to it
    /// (`rollout::held_clearance`); `None` without the self-contact barrier or grippers.
    pub held: Option<(Arc<dyn DynRowFn>, Arc<RowIndex>)>,
    /// Bytes [`Model::gradients`] may keep in recordings for the backward pass (two at a time:
    /// one pulled back while the next is recorded). A step whose recording would not fit half of
    /// it is recorded in blocks of iterations from checkpoints of a plain forward sweep (kept by
    /// [`Model::evaluate`]'s forward, within a quarter of the budget; else one more forward pass
    /// per step; memory ∝ one block). When the whole rollout's recording fits it,
    /// [`Model::evaluate`] records every step during the first forward instead
    /// ([`Model::simulate_recording`]). The tapes kept between evaluations ([`Model::tapes`])
    /// hold at most this many bytes too.
    pub checkpoint_budget: usize,
    /// The recording tapes of the last evaluation, cleared and kept with their buffers for the
    /// next (within [`Model::checkpoint_budget`]); a clone starts with none.
    pub tapes: crate::rollout::tapes::TapeCache,
    /// The method that solves each step (`physics.solver`).
    pub solver: Solver,
    /// Self-collision (`physics.self_collision`): contact sets found at the start of each step
    /// ([`Model::contact_sets`]); `None` when the scene does not ask for it.
    pub self_collision: Option<Arc<SelfCollision>>,
    /// Smooth contact with the colliders (`physics.contact.model = "smooth"`): a barrier
    /// potential in Newton's energy instead of the rigid `collider` group; `None` otherwise.
    pub contact_barrier: Option<Arc<ColliderBarrier>>,
    /// Smooth contact along the cloth's edges, against the colliders narrower than its longest
    /// edge (`contact::edge_points`); `None` when there are none, or without smooth contact.
    pub edge_barrier: Option<Arc<EdgeBarrier>>,
    /// Self-collision under Newton's method: the barrier potential between parts of the cloth
    /// (`contact::self_barrier`); `None` otherwise.
    pub self_barrier: Option<Arc<SelfBarrier>>,
    /// How step 0 was placed from `cloth.initial_state`; `None` for a cloth starting at rest in
    /// its rest shape.
    pub start_report: Option<StartReport>,
}

/// How a scene's `cloth.initial_state` became step 0 ([`Model::start`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StartReport {
    /// Where the positions came from: `"positions"`, `"obj"` or `"recipe"`.
    pub source: &'static str,
    /// The recipe's held steps and its settling steps after letting go (0 without a recipe).
    pub recipe_steps: usize,
    /// Quasi-static steps (the grippers held) that settled the start; 0 when it was at rest.
    pub settle_steps: usize,
    /// Free particles within `d̂/2` of a collider moved out to `d̂/2` (smooth contact).
    pub lifted: usize,
    /// The largest distance of step 0's positions from the given (or the recipe's) ones, and its
    /// particle.
    pub moved: (f64, usize),
}

impl Model {
    /// Number of particles `N`.
    pub fn n_particles(&self) -> usize {
        self.start.rows()
    }

    /// Number of control particles.
    pub fn n_controls(&self) -> usize {
        self.controls.rows()
    }

    /// Projections performed per solver iteration (rows over all sets).
    pub fn projections_per_iteration(&self) -> usize {
        self.groups.iter().map(|g| g.count).sum()
    }

    /// Colour sets visited per solver iteration.
    pub fn sets_per_iteration(&self) -> usize {
        self.groups.iter().map(|g| g.sets.len()).sum()
    }

    /// The group called `name`, if the model has it.
    pub fn group(&self, name: &str) -> Option<&ConstraintGroup> {
        self.groups.iter().find(|g| g.name == name)
    }

    /// A one-line list of the effects this model simulates.
    pub fn effects(&self) -> String {
        let mut parts: Vec<String> = self
            .groups
            .iter()
            .map(|g| {
                format!(
                    "{} ({} constraints, {} sets)",
                    g.name,
                    g.count,
                    g.sets.len()
                )
            })
            .collect();
        if self.sets().any(|s| s.carry != Carry::Multiplier) {
            parts.push("friction".into());
        }
        if let Some(b) = &self.contact_barrier {
            parts.push(format!(
                "smooth contact (d̂ {:e}, κ {:e}{})",
                b.barrier.d_hat,
                b.barrier.kappa,
                if b.friction.is_some() {
                    ", friction"
                } else {
                    ""
                }
            ));
        }
        if let Some(e) = &self.edge_barrier {
            parts.push(format!(
                "edge contact ({} points, {:e} apart, on {} narrow colliders)",
                e.points.len(),
                e.spacing,
                e.barrier.field.component_count()
            ));
        }
        if let Some(sc) = &self.self_collision {
            parts.push(format!("self-collision (thickness {})", sc.thickness));
        }
        if self.gravity_step.is_some() {
            parts.push("gravity".into());
        }
        if self.safety.is_some() {
            parts.push("safety SDF".into());
        }
        parts.join(", ")
    }
}
