//! The scene format's types: what a scene file may say (serde, unknown fields rejected).

use std::fmt;

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use super::initial_state::InitialState;
use super::obstacles::Obstacle;

/// A complete scene: cloth, material, physics, controls, obstacles and task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short identifier, e.g. `u_obstacle`.
    pub name: String,
    /// One-line human description (default empty).
    #[serde(default)]
    pub description: String,
    /// Grid size, placement and particle mass.
    pub cloth: ClothSpec,
    /// Constraint stiffnesses.
    pub material: Material,
    /// Time step, gravity and solver iterations.
    pub physics: Physics,
    /// Each control (gripped) particle, in control order: `[row, col]` on a grid cloth, a vertex
    /// index on a mesh cloth. May be empty.
    pub controls: Vec<ParticleRef>,
    /// Obstacles (default none).
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// Targets, cost weights, horizon and initial control guess.
    pub task: Task,
    /// Constraints of user-registered types (default none); see [`crate::ConstraintRegistry`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub custom_constraints: Vec<CustomConstraint>,
}

/// The cloth: a `rows × cols` grid laid out on a parallelogram, or a triangle mesh read from an
/// OBJ file (`mesh`).
///
/// Grid particle `(r, c)` rests at `top_left + right·c/max(cols−1, 1) + down·r/max(rows−1, 1)`.
/// A mesh cloth's particles are the file's vertices, resting where the file puts them; its grid
/// fields are 0 and are neither read nor written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ClothJson", into = "ClothJson")]
pub struct ClothSpec {
    /// Number of particle rows (≥ 1; 0 on a mesh cloth).
    pub rows: usize,
    /// Number of particle columns (≥ 1; 0 on a mesh cloth).
    pub cols: usize,
    /// Rest position of particle `(0, 0)`.
    pub top_left: [f64; 3],
    /// Vector from particle `(0, 0)` to `(0, cols−1)`.
    pub right: [f64; 3],
    /// Vector from particle `(0, 0)` to `(rows−1, 0)`.
    pub down: [f64; 3],
    /// Mass of every particle (default 1.0).
    pub particle_mass: f64,
    /// The OBJ file of a mesh cloth, relative to the scene file (or to the working directory for
    /// a scene given as text); `None` for a grid.
    pub mesh: Option<String>,
    /// The mesh read from `mesh` when the scene was loaded ([`crate::Scene::load_files`]); `None`
    /// until then and for a grid.
    pub mesh_data: Option<crate::obj::ObjMesh>,
    /// Where the cloth is at step 0 when not at its rest shape (`None`: at rest).
    pub initial_state: Option<InitialState>,
}

impl ClothSpec {
    /// True for a cloth read from a mesh file (`cloth.mesh`).
    pub fn is_mesh(&self) -> bool {
        self.mesh.is_some()
    }
}

/// The JSON form of [`ClothSpec`]: either the grid fields or `mesh`, with `particle_mass`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ClothJson {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rows: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cols: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    top_left: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    right: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    down: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mesh: Option<String>,
    #[serde(default = "default_particle_mass")]
    particle_mass: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    initial_state: Option<InitialState>,
}

impl TryFrom<ClothJson> for ClothSpec {
    type Error = String;
    fn try_from(j: ClothJson) -> Result<ClothSpec, String> {
        let grid_fields = [
            ("rows", j.rows.is_some()),
            ("cols", j.cols.is_some()),
            ("top_left", j.top_left.is_some()),
            ("right", j.right.is_some()),
            ("down", j.down.is_some()),
        ];
        if j.mesh.is_some() {
            if let Some((name, _)) = grid_fields.iter().find(|(_, given)| *given) {
                return Err(format!(
                    "cloth: `{name}` is a grid field, but the cloth is read from `mesh`; give one or the other"
                ));
            }
            return Ok(ClothSpec {
                rows: 0,
                cols: 0,
                top_left: [0.0; 3],
                right: [0.0; 3],
                down: [0.0; 3],
                particle_mass: j.particle_mass,
                mesh: j.mesh,
                mesh_data: None,
                initial_state: j.initial_state,
            });
        }
        if let Some((name, _)) = grid_fields.iter().find(|(_, given)| !*given) {
            return Err(format!(
                "missing field `{name}` (a grid cloth needs rows, cols, top_left, right and down; a mesh cloth gives `mesh`)"
            ));
        }
        Ok(ClothSpec {
            rows: j.rows.unwrap_or_default(),
            cols: j.cols.unwrap_or_default(),
            top_left: j.top_left.unwrap_or_default(),
            right: j.right.unwrap_or_default(),
            down: j.down.unwrap_or_default(),
            particle_mass: j.particle_mass,
            mesh: None,
            mesh_data: None,
            initial_state: j.initial_state,
        })
    }
}

impl From<ClothSpec> for ClothJson {
    fn from(c: ClothSpec) -> ClothJson {
        let grid = !c.is_mesh();
        ClothJson {
            rows: grid.then_some(c.rows),
            cols: grid.then_some(c.cols),
            top_left: grid.then_some(c.top_left),
            right: grid.then_some(c.right),
            down: grid.then_some(c.down),
            mesh: c.mesh,
            particle_mass: c.particle_mass,
            initial_state: c.initial_state,
        }
    }
}

/// A particle named in a scene: `[row, col]` on a grid cloth, a vertex index on a mesh cloth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ParticleRef {
    /// `[row, col]` of a grid cloth.
    Grid([usize; 2]),
    /// Vertex index of a mesh cloth (0-based: the file's first `v` line is 0).
    Vertex(usize),
}

impl From<[usize; 2]> for ParticleRef {
    fn from(rc: [usize; 2]) -> ParticleRef {
        ParticleRef::Grid(rc)
    }
}

impl From<usize> for ParticleRef {
    fn from(v: usize) -> ParticleRef {
        ParticleRef::Vertex(v)
    }
}

impl PartialEq<[usize; 2]> for ParticleRef {
    fn eq(&self, rc: &[usize; 2]) -> bool {
        *self == ParticleRef::Grid(*rc)
    }
}

impl fmt::Display for ParticleRef {
    /// `(r, c)` for a grid particle, `vertex v` for a mesh vertex.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            ParticleRef::Grid([r, c]) => write!(f, "({r}, {c})"),
            ParticleRef::Vertex(v) => write!(f, "vertex {v}"),
        }
    }
}

fn default_particle_mass() -> f64 {
    1.0
}

/// Default of `physics.iterations`: the paper's 100 Gauss–Seidel sweeps per step.
pub const DEFAULT_XPBD_ITERATIONS: usize = 100;

fn default_iterations() -> usize {
    DEFAULT_XPBD_ITERATIONS
}

/// Constraint stiffnesses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Stiffness of the stretch (edge distance) constraints.
    pub stretch: Stiffness,
    /// Bending model and stiffness; `None` (the default) means no bending constraints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bending: Option<Bending>,
}

/// Bending constraints: which model and how stiff.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bending {
    /// The bending model (default [`BendingModel::Distance`]).
    #[serde(default)]
    pub model: BendingModel,
    /// Bending stiffness.
    pub stiffness: Stiffness,
}

/// Bending model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BendingModel {
    /// The paper's: a distance constraint between the two vertices opposite each interior edge
    /// ([`crate::ClothMesh::bending_pairs`]). JSON `"distance"`.
    #[default]
    Distance,
    /// Dihedral-angle constraint on each interior edge's two triangles
    /// ([`crate::ClothMesh::dihedral_quads`]). JSON `"dihedral"`.
    Dihedral,
    /// Quadratic bending on each interior edge's two triangles
    /// ([`crate::constraint::IsometricBending`], Bergou et al. 2006): linear in the positions, so
    /// smooth through creases folded flat; needs a flat rest shape. JSON `"isometric"`.
    Isometric,
}

/// A constraint stiffness `k`: a positive finite number, or rigid (JSON string `"inf"`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stiffness {
    /// A finite stiffness (validation requires it to be positive).
    Finite(f64),
    /// Infinitely stiff (rigid): compliance 0. JSON `"inf"`.
    Infinite,
}

impl Stiffness {
    /// The inverse of [`Stiffness::value`]: `f64::INFINITY` is [`Stiffness::Infinite`].
    pub fn from_value(k: f64) -> Self {
        if k == f64::INFINITY {
            Stiffness::Infinite
        } else {
            Stiffness::Finite(k)
        }
    }

    /// The stiffness as a number: `k`, or `f64::INFINITY` for [`Stiffness::Infinite`].
    pub fn value(&self) -> f64 {
        match *self {
            Stiffness::Finite(k) => k,
            Stiffness::Infinite => f64::INFINITY,
        }
    }

    /// XPBD time-step compliance `α̃ = 1/(k·dt²)`, evaluated as `(1/k)/(dt·dt)` (the same rounding as the
    /// reference implementation); 0 for [`Stiffness::Infinite`].
    pub fn compliance(&self, dt: f64) -> f64 {
        match *self {
            Stiffness::Finite(k) => (1.0 / k) / (dt * dt),
            Stiffness::Infinite => 0.0,
        }
    }

    /// True for [`Stiffness::Infinite`].
    pub fn is_infinite(&self) -> bool {
        matches!(self, Stiffness::Infinite)
    }
}

impl Serialize for Stiffness {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match *self {
            Stiffness::Finite(k) => serializer.serialize_f64(k),
            Stiffness::Infinite => serializer.serialize_str("inf"),
        }
    }
}

impl<'de> Deserialize<'de> for Stiffness {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct StiffnessVisitor;
        impl Visitor<'_> for StiffnessVisitor {
            type Value = Stiffness;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a positive number or the string \"inf\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Stiffness, E> {
                Ok(Stiffness::Finite(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Stiffness, E> {
                Ok(Stiffness::Finite(v as f64))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Stiffness, E> {
                Ok(Stiffness::Finite(v as f64))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Stiffness, E> {
                if v == "inf" {
                    Ok(Stiffness::Infinite)
                } else {
                    Err(E::invalid_value(de::Unexpected::Str(v), &self))
                }
            }
        }
        deserializer.deserialize_any(StiffnessVisitor)
    }
}

/// Time stepping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Physics {
    /// Time step `Δt` (> 0).
    pub dt: f64,
    /// Gravitational acceleration.
    pub gravity: [f64; 3],
    /// Gauss–Seidel iterations per time step (≥ 1; XPBD only; default
    /// [`DEFAULT_XPBD_ITERATIONS`]).
    #[serde(default = "default_iterations")]
    pub iterations: usize,
    /// The step solver: `"xpbd"` or `"newton"` (converged physics, see
    /// [`crate::Solver::Newton`]); absent, the one the scene calls for
    /// ([`Scene::physics_choice`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solver: Option<SolverKind>,
    /// Newton only: relative `‖∇Φ‖` at which a step has converged, in `(0, 1)`; default
    /// [`crate::DEFAULT_TOLERANCE`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// Newton only: iterations per step (≥ 1); default
    /// [`crate::DEFAULT_MAX_ITERATIONS`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_newton_iterations: Option<usize>,
    /// Newton only: load steps per time step (≥ 1; default 1), see
    /// [`crate::NewtonSettings::load_steps`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_steps: Option<usize>,
    /// Newton only: most halvings of a load increment whose solve leaves the convex
    /// neighbourhood of a minimizer (0 to [`crate::scene::MAX_LOAD_HALVINGS`]), see
    /// [`crate::NewtonSettings::load_halvings`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_halvings: Option<usize>,
    /// Newton only: how its linear systems are solved, `"direct"` (default) or `"pcg"`, see
    /// [`crate::LinearSolver`].
    #[serde(default, skip_serializing_if = "LinearSolverKind::is_direct")]
    pub linear_solver: LinearSolverKind,
    /// Newton only: shift the exact Hessian where the projected one stalls (default true), see
    /// [`crate::NewtonSettings::shift_stalled`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shift_stalled: Option<bool>,
    /// Newton with smooth contact only: start each solve from the Newton predictor (default
    /// true), see [`crate::NewtonSettings::predictor`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predictor: Option<bool>,
    /// Self-collision of the cloth (absent: none), see `cloth/src/contact/self_collision.rs`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub self_collision: Option<SelfCollisionSpec>,
    /// How the cloth touches the colliders (absent: the rigid model), see [`ContactSpec`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactSpec>,
}

/// `physics.contact`: the contact model between the cloth and the colliders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// `"rigid"` (a particle is projected onto the surface: XPBD's projection, Newton's active
    /// set) or `"smooth"` (a log-barrier potential in the signed distance keeps every particle
    /// strictly outside, and the step is a smooth function of the controls; Newton only).
    pub model: ContactModel,
    /// Smooth model: the distance `d̂ > 0` below which the barrier acts (metres; default a tenth
    /// of the cloth's mean rest edge length).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub d_hat: Option<f64>,
    /// Smooth model: the barrier's stiffness `κ > 0` (N/m; default `m·|g|/d̂` with `m` the particle
    /// mass, which holds a resting particle at about 0.65 `d̂`; `m/Δt²` without gravity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// Smooth model with friction: the tangential displacement `ε > 0` below which friction is
    /// smoothed (metres; default a tenth of `d̂`): a particle held by static friction creeps by a
    /// fraction of it per step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction_epsilon: Option<f64>,
}

/// The contact model named by `physics.contact.model`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactModel {
    /// Projection onto the surface (the paper's collision constraint).
    #[default]
    Rigid,
    /// A C² log-barrier potential in the signed distance to each collider primitive.
    Smooth,
}

impl Scene {
    /// The contact model between the cloth and the colliders: the one `physics.contact.model`
    /// names; when it names none, the smooth model under Newton's method
    /// ([`Scene::solver_kind`]) for a scene with colliders (it achieves more of the table set,
    /// docs/experiments.md "The table set"), else the rigid one (XPBD's only model, and moot
    /// without colliders).
    pub fn contact_model(&self) -> ContactModel {
        match &self.physics.contact {
            Some(c) => c.model,
            None if self.solver_kind() == SolverKind::Newton && self.has_colliders() => {
                ContactModel::Smooth
            }
            None => ContactModel::Rigid,
        }
    }
}

/// `physics.self_collision`: vertex–triangle contacts between parts of the cloth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelfCollisionSpec {
    /// The distance `h ≥ 0` every vertex keeps from the plane of a nearby triangle it faces.
    pub thickness: f64,
    /// Whether crossing edges are held apart too (edge–edge contacts, see
    /// `cloth/src/contact/edge_edge.rs`); default `false` (vertex–triangle contacts only).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub edge_edge: bool,
    /// Coulomb friction `μ ≥ 0` between parts of the cloth, Newton's method only (absent or 0:
    /// frictionless; see `cloth/src/contact/self_friction.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// One entry of a scene's `custom_constraints`: constraints of a registered type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CustomConstraint {
    /// The registered type's name (JSON `"type"`).
    #[serde(rename = "type")]
    pub kind: String,
    /// `[r, c]` of the particles of every instance in order, the type's arity per instance.
    pub particles: Vec<[usize; 2]>,
    /// Stiffness of every instance: a positive number or `"inf"`.
    pub stiffness: Stiffness,
    /// Parameters for the type's builder, any JSON (default `null`).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub params: serde_json::Value,
}

/// Largest `physics.load_halvings` (2^20 increments per Newton step).
pub const MAX_LOAD_HALVINGS: usize = 20;

/// The linear solver named by `physics.linear_solver` (Newton only).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LinearSolverKind {
    /// A sparse Cholesky factorization of every Newton matrix ([`crate::LinearSolver::Direct`]).
    #[default]
    Direct,
    /// Conjugate gradients preconditioned with a reused factorization, with the default
    /// tolerance and iteration limit ([`crate::LinearSolver::PCG`]).
    Pcg,
}

impl LinearSolverKind {
    /// The default, `"direct"` (left out when a scene is written).
    pub fn is_direct(&self) -> bool {
        *self == LinearSolverKind::Direct
    }

    /// The Newton setting it names.
    pub fn setting(self) -> crate::LinearSolver {
        match self {
            LinearSolverKind::Direct => crate::LinearSolver::Direct,
            LinearSolverKind::Pcg => crate::LinearSolver::PCG,
        }
    }
}

/// The step solver named by `physics.solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SolverKind {
    /// XPBD Gauss–Seidel sweeps, `physics.iterations` per step.
    #[default]
    Xpbd,
    /// Newton's method to `physics.tolerance`.
    Newton,
}

impl SolverKind {
    /// Every solver, in the order their names are listed.
    pub const ALL: [SolverKind; 2] = [SolverKind::Xpbd, SolverKind::Newton];

    /// The name the scene format and the CLI give it (`"xpbd"`, `"newton"`).
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Xpbd => "xpbd",
            SolverKind::Newton => "newton",
        }
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SolverKind {
    type Err = String;

    /// Parses a solver's name (as [`SolverKind::name`] spells it).
    fn from_str(s: &str) -> Result<Self, String> {
        SolverKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown physics solver {s:?}: expected \"xpbd\" or \"newton\""))
    }
}

/// The optimisation task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Task {
    /// Number of time steps `T` (≥ 1); there are `T` control vectors per control particle.
    pub horizon: usize,
    /// Target positions of some particles at the final step (at least one, no particle twice);
    /// empty or left out when `target_mesh` gives the targets.
    #[serde(default)]
    pub targets: Vec<Target>,
    /// A mesh cloth only: an OBJ file with the cloth's vertices in their target places (the
    /// cloth's topology); every vertex becomes a target, in vertex order, in place of `targets`.
    /// Relative to the scene file, like `cloth.mesh`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_mesh: Option<String>,
    /// The vertex positions read from `target_mesh` ([`crate::Scene::load_files`]).
    #[serde(skip)]
    pub target_mesh_data: Option<Vec<[f64; 3]>>,
    /// Weight `α` of the trajectory irregularity term (≥ 0).
    pub alpha: f64,
    /// Weight `β` of the elastic energy term (≥ 0).
    pub beta: f64,
    /// Safety margin `δ` of the signed-distance constraint (≥ 0, default 0).
    #[serde(default)]
    pub delta: f64,
    /// Distance (length units) within which a target particle counts as reached at the final
    /// step (> 0). Default: 10% of the cloth's longest side ([`Scene::default_tolerance`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// Initial guess for the controls.
    pub initial_controls: InitialControls,
    /// Robot limits every plan must respect (default: none). Left out of the JSON when empty.
    #[serde(default, skip_serializing_if = "Limits::is_empty")]
    pub limits: Limits,
}

/// Robot limits on a plan (`task.limits`); every field is optional.
///
/// Grippers are the control particles; their absolute position at step `t` is the rest position
/// plus the sum of the controls (per-step displacements) of steps `0..t`. Steps `1..=T` are
/// constrained; step 0 (the rest state) must already satisfy the workspace and separation limits.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Largest Euclidean gripper displacement per step (length units, > 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_step: Option<f64>,
    /// Axis-aligned box every gripper stays in at every step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub workspace: Option<Workspace>,
    /// `[min, max]` distance between every pair of grippers at every step (`0 ≤ min ≤ max`,
    /// `max > 0`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gripper_separation: Option<[f64; 2]>,
    /// Largest relative stretch `|x_i − x_j|/L₀ − 1` of any stretch edge at any step (> 0,
    /// dimensionless: 0.1 is 10%).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_strain: Option<f64>,
}

impl Limits {
    /// True when no limit is set.
    pub fn is_empty(&self) -> bool {
        *self == Limits::default()
    }
}

/// An axis-aligned box `min ≤ p ≤ max` (per coordinate, length units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Workspace {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

/// Target position of one particle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Target {
    /// The particle: `[row, col]` on a grid cloth, a vertex index on a mesh cloth.
    pub particle: ParticleRef,
    /// Its desired position at the final step.
    pub position: [f64; 3],
}

/// Initial guess for the control displacements.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InitialControls {
    /// All displacements zero. JSON `"zeros"`.
    Zeros,
    /// Every step uses the same displacement per control particle (one vector per control).
    /// JSON `{"constant": [[x, y, z], ...]}`.
    Constant(Vec<[f64; 3]>),
    /// One vector per control particle per step (`horizon × controls`).
    /// JSON `{"explicit": [[[x, y, z], ...], ...]}`.
    Explicit(Vec<Vec<[f64; 3]>>),
}
