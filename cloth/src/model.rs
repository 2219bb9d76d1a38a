//! A scene compiled to the effects it calls for, and nothing else.
//!
//! No bending sets when bending is off, no gravity work when `g = 0`, no collider projection
//! without a collider, no signed-distance evaluation without a safety obstacle. Every constraint
//! type, built-in or user-written, enters through [`Model::add_constraints`].

use crate::coloring::{greedy_coloring, independent_sets};
use crate::constraint::{Collision, Constraint, DihedralBending, Distance, MAX_ARITY};
use crate::contact::friction::FrictionalContact;
use crate::contact::self_collision::SelfCollision;
use crate::error::ClothError;
use crate::newton::terms::{ConstraintTerms, Terms};
use crate::newton::Solver;
use crate::projection::Projection;
use crate::scene::{BendingModel, Limits, Obstacle, Scene, Stiffness};
use crate::sdf::{SignedDistance, Union};
use crate::strain::EdgeStrain;
use autodiff::{DynRowFn, Real, RowFn, RowIndex, Tensor};
use nalgebra::Vector3;
use std::sync::Arc;

/// One Gauss–Seidel colour set: a projection and the particles of each of its rows.
#[derive(Clone)]
pub struct ProjectionSet {
    /// The projection row function (row = one constraint).
    pub projection: Arc<dyn DynRowFn>,
    /// Particles of each row.
    pub index: Arc<RowIndex>,
    /// What each row carries through a step's iterations besides its particles.
    pub carry: Carry,
}

/// The per-row values a colour set carries through a step's Gauss–Seidel iterations (the
/// `carry` of [`autodiff::update::update_rows`]), and how each step starts them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Carry {
    /// One XPBD multiplier `λ`, zero at each step's start.
    Multiplier,
    /// The row's (single) particle's position at the step's start, copied from the previous
    /// state, then `width − 3` values starting at zero ([`crate::contact::friction`]).
    StartPosition {
        /// Carried values per row (≥ 3).
        width: usize,
    },
}

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
    /// Rest (initial) positions, `N × 3`.
    pub rest: Tensor,
    /// The cloth's triangles (particle indices; [`crate::mesh::ClothMesh::triangles`]), for
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
    /// Bytes [`Model::gradients`] may keep in recordings for the backward pass (two at a time:
    /// one pulled back while the next is recorded). A step whose recording would not fit half of
    /// it is recorded in blocks of iterations from checkpoints of a plain forward sweep (one more
    /// forward pass per step, memory ∝ one block). When the whole rollout's recording fits it,
    /// [`Model::evaluate`] records every step during the first forward instead
    /// ([`Model::simulate_recording`]).
    pub checkpoint_budget: usize,
    /// The method that solves each step (`physics.solver`).
    pub solver: Solver,
    /// Self-collision (`physics.self_collision`): contact sets found at the start of each step
    /// ([`Model::contact_sets`]); `None` when the scene does not ask for it.
    pub self_collision: Option<Arc<SelfCollision>>,
}

/// Default [`Model::checkpoint_budget`]: 32 MiB (`u_obstacle` steps fit whole up to a 20 × 20
/// mesh).
pub const DEFAULT_CHECKPOINT_BUDGET: usize = 32 << 20;

/// `½ k C²` of each constraint of a type.
struct Energy<C> {
    constraint: Arc<C>,
    stiffness: f64,
}

impl<C: Constraint> RowFn for Energy<C> {
    fn n_in(&self) -> usize {
        3 * C::ARITY
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, row: usize, x: &[R], out: &mut [R]) {
        let mut p = [Vector3::<R>::zeros(); MAX_ARITY];
        for (i, pi) in p.iter_mut().take(C::ARITY).enumerate() {
            *pi = Vector3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        }
        let c = self.constraint.c(row, &p[..C::ARITY]);
        out[0] = c * c * (0.5 * self.stiffness);
    }
}

/// Signed distance of each particle to the safety obstacles (`3 → 1`), exact wherever it is at
/// most `bound` and a lower bound above it elsewhere ([`SignedDistance::distance_within`];
/// `bound = ∞`: exact everywhere).
pub(crate) struct ParticleSdf {
    pub(crate) field: Arc<Union>,
    pub(crate) bound: f64,
}

impl RowFn for ParticleSdf {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        out[0] = (self.field).distance_within(&Vector3::new(x[0], x[1], x[2]), self.bound);
    }
}

/// Signed distance of each particle to each primitive of the safety obstacles
/// (`3 → components`), each bounded by `bound` as [`Union::components_within`].
pub(crate) struct ParticleSdfComponents {
    pub(crate) field: Arc<Union>,
    pub(crate) bound: f64,
}

impl RowFn for ParticleSdfComponents {
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        self.field.component_count()
    }
    fn eval<R: Real>(&self, _row: usize, x: &[R], out: &mut [R]) {
        (self.field).components_within(&Vector3::new(x[0], x[1], x[2]), self.bound, out);
    }
}

impl Model {
    /// Compiles a validated scene. A scene with `custom_constraints` needs their types:
    /// [`Model::from_scene_with`].
    pub fn from_scene(scene: &Scene) -> Result<Model, ClothError> {
        Model::from_scene_with(scene, &crate::registry::ConstraintRegistry::new())
    }

    /// Compiles a validated scene's built-in effects (everything but `custom_constraints`).
    pub(crate) fn from_scene_builtin(scene: &Scene) -> Result<Model, ClothError> {
        scene.validate()?;
        let mesh = scene.mesh();
        let rest_pos = scene.rest_positions();
        let n = rest_pos.len();
        let controls = scene.control_indices();
        let mut inv_mass = vec![1.0 / scene.cloth.particle_mass; n];
        for &c in &controls {
            inv_mass[c] = 0.0;
        }
        let g = scene.physics.gravity;
        let dt = scene.physics.dt;
        let gravity_step = (g != [0.0; 3]).then(|| g.map(|gi| 0.5 * gi * dt * dt));
        let task = &scene.task;
        let target_positions: Vec<f64> = scene.target_positions().into_iter().flatten().collect();
        let mut model = Model {
            rest: Tensor::new(n, 3, rest_pos.iter().flatten().copied().collect()),
            triangles: mesh.triangles().into(),
            inv_mass,
            controls: Arc::new(RowIndex::single(controls)),
            gravity_step,
            dt,
            iterations: scene.physics.iterations,
            groups: Vec::new(),
            safety: None,
            safety_components: None,
            safety_obstacles: Arc::new(Union::default()),
            colliders: Union::default(),
            task: TaskSpec {
                horizon: task.horizon,
                targets: Arc::new(RowIndex::single(scene.target_indices())),
                target_positions: Tensor::new(target_positions.len() / 3, 3, target_positions),
                alpha: task.alpha,
                beta: task.beta,
                delta: task.delta,
                limits: task.limits.clone(),
                tolerance: scene.tolerance(),
            },
            strain: None,
            checkpoint_budget: DEFAULT_CHECKPOINT_BUDGET,
            solver: scene.physics.solver(),
            self_collision: None,
        };

        let edges = mesh.stretch_edges();
        let rest: Vec<f64> = edges
            .iter()
            .map(|&[i, j]| model.rest_distance(i, j))
            .collect();
        let (strained, strain_rest): (Vec<[usize; 2]>, Vec<f64>) = edges
            .iter()
            .zip(&rest)
            .filter(|&(_, &l)| l > 0.0)
            .map(|(&e, &l)| (e, l))
            .unzip();
        if !strained.is_empty() {
            let f: Arc<dyn DynRowFn> = Arc::new(EdgeStrain { rest: strain_rest });
            model.strain = Some((f, Arc::new(RowIndex::new(2, flatten(&strained)))));
        }
        model.add_constraints(
            "stretch",
            Distance { rest },
            flatten(&edges),
            scene.material.stretch.value(),
        )?;
        if let Some(bending) = &scene.material.bending {
            let k = bending.stiffness.value();
            match bending.model {
                BendingModel::Distance => {
                    let pairs = mesh.bending_pairs();
                    let rest = pairs
                        .iter()
                        .map(|&[i, j]| model.rest_distance(i, j))
                        .collect();
                    model.add_constraints("bending", Distance { rest }, flatten(&pairs), k)?;
                }
                BendingModel::Dihedral => {
                    let quads = mesh.dihedral_quads();
                    let rest = quads
                        .iter()
                        .map(|q| DihedralBending::angle(&q.map(|p| model.rest_point(p))))
                        .collect();
                    model.add_constraints(
                        "bending",
                        DihedralBending { rest },
                        flatten(&quads),
                        k,
                    )?;
                }
            }
        }
        let (colliders, safety) = split_obstacles(&scene.obstacles);
        if !colliders.is_empty() {
            let free: Vec<usize> = (0..n).filter(|&p| model.inv_mass[p] > 0.0).collect();
            model.colliders = colliders.clone();
            model.add_constraints(
                "collider",
                Collision { sdf: colliders },
                free.clone(),
                f64::INFINITY,
            )?;
            if let Some(friction) = FrictionalContact::from_obstacles(&scene.obstacles) {
                let group = model.groups.last_mut().expect("the collider group");
                group.sets = vec![friction.projection_set(free)];
            }
        }
        if let Some(sc) = &scene.physics.self_collision {
            let triangles = model.triangles.clone();
            let contacts = SelfCollision::new(sc.thickness, triangles, n);
            model.self_collision = Some(Arc::new(contacts.with_edge_edge(sc.edge_edge)));
        }
        if !safety.is_empty() {
            let field = Arc::new(safety);
            let bound = f64::INFINITY;
            model.safety = Some(Arc::new(ParticleSdf {
                field: field.clone(),
                bound,
            }));
            model.safety_components = Some(Arc::new(ParticleSdfComponents {
                field: field.clone(),
                bound,
            }));
            model.safety_obstacles = field;
        }
        Ok(model)
    }

    /// Number of particles `N`.
    pub fn n_particles(&self) -> usize {
        self.rest.rows()
    }

    /// Number of control particles.
    pub fn n_controls(&self) -> usize {
        self.controls.rows()
    }

    fn rest_point(&self, p: usize) -> Vector3<f64> {
        let r = self.rest.row(p);
        Vector3::new(r[0], r[1], r[2])
    }

    fn rest_distance(&self, i: usize, j: usize) -> f64 {
        (self.rest_point(i) - self.rest_point(j)).norm()
    }

    /// Adds constraints of type `C` to the sweep, after the existing groups.
    ///
    /// `particles` lists each constraint's `C::ARITY` particles, row-major; constraint `k` is
    /// evaluated as instance `k` of `constraint`. The constraints are greedily coloured into
    /// independent sets in the given order. `stiffness` is `k` (`f64::INFINITY` for rigid).
    pub fn add_constraints<C: Constraint>(
        &mut self,
        name: &str,
        constraint: C,
        particles: Vec<usize>,
        stiffness: f64,
    ) -> Result<(), ClothError> {
        let invalid = |reason: String| ClothError::InvalidConstraint {
            name: name.to_string(),
            reason,
        };
        if !(1..=MAX_ARITY).contains(&C::ARITY) {
            return Err(invalid(format!(
                "arity {} is outside 1..={MAX_ARITY}",
                C::ARITY
            )));
        }
        if particles.len() % C::ARITY != 0 {
            return Err(invalid(format!(
                "{} particle indices do not form groups of {}",
                particles.len(),
                C::ARITY
            )));
        }
        if let Some(&p) = particles.iter().find(|&&p| p >= self.n_particles()) {
            return Err(invalid(format!(
                "particle {p} out of range ({} particles)",
                self.n_particles()
            )));
        }
        if stiffness.is_nan() || stiffness <= 0.0 {
            return Err(invalid(format!(
                "stiffness must be positive, got {stiffness}"
            )));
        }
        let rows: Vec<&[usize]> = particles.chunks_exact(C::ARITY).collect();
        if let Some(k) = rows
            .iter()
            .position(|r| (1..r.len()).any(|i| r[..i].contains(&r[i])))
        {
            return Err(invalid(format!("constraint {k} names a particle twice")));
        }
        let compliance = Stiffness::from_value(stiffness).compliance(self.dt);
        if !compliance.is_finite() {
            return Err(invalid(format!(
                "stiffness {stiffness} is too small: its compliance 1/(k·dt²) is not finite"
            )));
        }
        let constraint = Arc::new(constraint);
        let colors = greedy_coloring(&rows, self.n_particles());
        let sets = independent_sets(&colors)
            .into_iter()
            .map(|members| {
                let idx: Vec<usize> = members
                    .iter()
                    .flat_map(|&k| rows[k].iter().copied())
                    .collect();
                let w = idx.iter().map(|&p| self.inv_mass[p]).collect();
                let projection = Projection::new(constraint.clone(), members, w, compliance);
                ProjectionSet {
                    projection: Arc::new(projection),
                    index: Arc::new(RowIndex::new(C::ARITY, idx)),
                    carry: Carry::Multiplier,
                }
            })
            .collect();
        let energy = (!C::INEQUALITY && stiffness.is_finite()).then(|| {
            let f: Arc<dyn DynRowFn> = Arc::new(Energy {
                constraint: constraint.clone(),
                stiffness,
            });
            (f, Arc::new(RowIndex::new(C::ARITY, particles.clone())))
        });
        self.groups.push(ConstraintGroup {
            name: name.to_string(),
            count: rows.len(),
            sets,
            energy,
            terms: Arc::new(Terms::new(constraint, particles, compliance)),
        });
        Ok(())
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

fn flatten<const K: usize>(rows: &[[usize; K]]) -> Vec<usize> {
    rows.iter().flatten().copied().collect()
}

/// Splits a scene's obstacles into the physical colliders and the safety constraint's obstacles.
fn split_obstacles(obstacles: &[Obstacle]) -> (Union, Union) {
    let (mut colliders, mut safety) = (Union::default(), Union::default());
    for o in obstacles {
        let role = o.role();
        if role.is_collider() {
            colliders.extend(o.field());
        }
        if role.is_safety() {
            safety.extend(o.field());
        }
    }
    (colliders, safety)
}
