//! The scene file format (JSON via serde), its validation, and the built-in scenes.
//!
//! A [`Scene`] describes one cloth-manipulation task: the cloth grid and its placement, the material,
//! the time stepping, the control (gripped) particles, obstacles, and the task (targets, cost weights,
//! horizon and the initial control guess). Every struct rejects unknown fields, and
//! [`Scene::validate`] rejects every bad value with a [`SceneError::Invalid`] naming the field path, e.g.
//! `task.targets[3].particle: row 12 out of range (cloth.rows = 10)`.
//!
//! ```
//! use cloth::scene::Scene;
//! let scene = Scene::builtin("u_obstacle")?;
//! assert_eq!(scene.mesh().n_particles(), 100);
//! assert_eq!(scene.control_indices(), vec![0, 9]);
//! # Ok::<(), cloth::scene::SceneError>(())
//! ```
//!
//! The built-in scenes live in `examples/scenes/{u_obstacle,swing,drop}.json` and are embedded in the
//! library; [`Scene::builtin_names`] lists them.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::mesh::GridMesh;

/// Largest accepted number of particles (`cloth.rows × cloth.cols`); larger grids are rejected by
/// validation instead of exhausting memory.
pub const MAX_PARTICLES: usize = 1 << 24;

/// Largest accepted `task.horizon` (number of time steps).
pub const MAX_HORIZON: usize = 1 << 20;

/// Largest accepted magnitude of a length-like value: every coordinate and vector component
/// (positions, `right`, `down`, gravity, targets, sphere centres, plane points and normals, initial
/// controls), sphere radii and `task.delta`. Beyond it squared distances and energies approach the
/// range of `f64`, and a rollout overflows instead of failing validation.
pub const MAX_COORDINATE: f64 = 1e9;

/// Errors from reading, parsing or validating a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The text is not a scene: malformed JSON, unknown or missing field, wrong type. `message` is
    /// serde_json's (it names unknown/missing fields and gives line and column), followed by the offending
    /// source line.
    #[error("invalid scene JSON: {message}")]
    Parse {
        /// Human-readable parser message, including line and column.
        message: String,
    },
    /// A well-formed scene with a bad value; `field` is its path, e.g. `cloth.top_left[1]`.
    #[error("{field}: {reason}")]
    Invalid {
        /// Path of the offending field, e.g. `task.targets[3].particle`.
        field: String,
        /// Why the value is rejected.
        reason: String,
    },
    /// The scene file could not be read.
    #[error("cannot read scene file `{}`: {source}", path.display())]
    Io {
        /// The path that was read.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// [`Scene::builtin`] was asked for a name that is not built in.
    #[error(
        "unknown built-in scene `{}` (available: {})",
        one_line(name),
        builtin_list()
    )]
    UnknownBuiltin {
        /// The requested name.
        name: String,
    },
}

/// `text` with control characters (newlines, tabs, …) escaped, so an error quoting user input
/// (an unknown field name, a scene name) stays on one line.
fn one_line(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

fn builtin_list() -> String {
    BUILTIN_NAMES
        .iter()
        .map(|(n, _)| *n)
        .collect::<Vec<_>>()
        .join(", ")
}

fn invalid(field: impl Into<String>, reason: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        field: field.into(),
        reason: reason.into(),
    }
}

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
    /// `(row, col)` of each control (gripped) particle, in control order. May be empty.
    pub controls: Vec<[usize; 2]>,
    /// Obstacles (default none).
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// Targets, cost weights, horizon and initial control guess.
    pub task: Task,
    /// Constraints of user-registered types (default none); see [`crate::registry`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub custom_constraints: Vec<crate::registry::CustomConstraint>,
}

/// The cloth grid: `rows × cols` particles laid out on a parallelogram.
///
/// Particle `(r, c)` rests at `top_left + right·c/max(cols−1, 1) + down·r/max(rows−1, 1)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothSpec {
    /// Number of particle rows (≥ 1).
    pub rows: usize,
    /// Number of particle columns (≥ 1).
    pub cols: usize,
    /// Rest position of particle `(0, 0)`.
    pub top_left: [f64; 3],
    /// Vector from particle `(0, 0)` to `(0, cols−1)`.
    pub right: [f64; 3],
    /// Vector from particle `(0, 0)` to `(rows−1, 0)`.
    pub down: [f64; 3],
    /// Mass of every particle (default 1.0).
    #[serde(default = "default_particle_mass")]
    pub particle_mass: f64,
}

fn default_particle_mass() -> f64 {
    1.0
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
    /// ([`GridMesh::bending_pairs`]). JSON `"distance"`.
    #[default]
    Distance,
    /// Dihedral-angle constraint on each interior edge's two triangles ([`GridMesh::dihedral_quads`]).
    /// JSON `"dihedral"`.
    Dihedral,
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
    /// Gauss–Seidel iterations per time step (≥ 1; XPBD only).
    pub iterations: usize,
    /// The step solver: `"xpbd"` (default) or `"newton"` (converged physics, see
    /// [`crate::newton`]).
    #[serde(default, skip_serializing_if = "SolverKind::is_xpbd")]
    pub solver: SolverKind,
    /// Newton only: relative `‖∇Φ‖` at which a step has converged, in `(0, 1)`; default
    /// [`crate::newton::DEFAULT_TOLERANCE`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    /// Newton only: iterations per step (≥ 1); default
    /// [`crate::newton::DEFAULT_MAX_ITERATIONS`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_newton_iterations: Option<usize>,
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
    fn is_xpbd(&self) -> bool {
        *self == SolverKind::Xpbd
    }
}

impl Physics {
    /// The solver these settings describe, with Newton's defaults filled in.
    pub fn solver(&self) -> crate::newton::Solver {
        use crate::newton::{NewtonSettings, Solver};
        match self.solver {
            SolverKind::Xpbd => Solver::Xpbd,
            SolverKind::Newton => {
                let d = NewtonSettings::default();
                Solver::Newton(NewtonSettings {
                    tolerance: self.tolerance.unwrap_or(d.tolerance),
                    max_iterations: self.max_newton_iterations.unwrap_or(d.max_iterations),
                })
            }
        }
    }
}

/// An obstacle; JSON objects tagged by `"type"`: `"spheres"` or `"plane"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Obstacle {
    /// A union of spheres (`{"type": "spheres", "centers": [...], "radii": [...], "role": ...}`).
    Spheres(SphereSet),
    /// A half-space bounded by a plane (`{"type": "plane", "point": [...], "normal": [...], "role": ...}`).
    Plane(Plane),
}

impl Obstacle {
    /// How the obstacle is used.
    pub fn role(&self) -> ObstacleRole {
        match self {
            Obstacle::Spheres(s) => s.role,
            Obstacle::Plane(p) => p.role,
        }
    }
}

/// A union of spheres; its signed distance is `min_s (|x − c_s| − r_s)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSet {
    /// Sphere centres.
    pub centers: Vec<[f64; 3]>,
    /// Sphere radii (one per centre, each > 0).
    pub radii: Vec<f64>,
    /// How the obstacle is used.
    pub role: ObstacleRole,
}

/// A plane through `point`; the free side is the one `normal` points to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plane {
    /// A point on the plane.
    pub point: [f64; 3],
    /// Normal pointing to the free side, as written in the file (any nonzero length);
    /// use [`Plane::normalized`] for the unit normal.
    pub normal: [f64; 3],
    /// How the obstacle is used.
    pub role: ObstacleRole,
}

impl Plane {
    /// The unit normal `normal/|normal|`. Validation guarantees `normal` is finite and nonzero; for an
    /// unvalidated zero or non-finite normal the result is NaN.
    pub fn normalized(&self) -> [f64; 3] {
        unit(&self.normal).unwrap_or([f64::NAN; 3])
    }
}

/// How an obstacle takes part in the problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ObstacleRole {
    /// Only a safety constraint for the optimizer (not simulated). JSON `"safety"`.
    Safety,
    /// A physical collider projected by the simulator (not a safety constraint). JSON `"collider"`.
    Collider,
    /// Both a safety constraint and a physical collider. JSON `"both"`.
    Both,
}

impl ObstacleRole {
    /// True if the optimizer treats the obstacle as a safety constraint (`safety` or `both`).
    pub fn is_safety(&self) -> bool {
        matches!(self, ObstacleRole::Safety | ObstacleRole::Both)
    }

    /// True if the simulator projects particles out of the obstacle (`collider` or `both`).
    pub fn is_collider(&self) -> bool {
        matches!(self, ObstacleRole::Collider | ObstacleRole::Both)
    }
}

/// The optimisation task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Task {
    /// Number of time steps `T` (≥ 1); there are `T` control vectors per control particle.
    pub horizon: usize,
    /// Target positions of some particles at the final step (at least one, no particle twice).
    pub targets: Vec<Target>,
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
    /// `(row, col)` of the particle.
    pub particle: [usize; 2],
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

const BUILTIN_NAMES: &[(&str, &str)] = &[
    (
        "u_obstacle",
        "Safety experiment: swing the cloth through a U-shaped opening of 18 spheres (safety constraint only)",
    ),
    (
        "swing",
        "Ablation: swing the hanging cloth so its bottom row reaches y = 1.0, z = 1.5 (no obstacle)",
    ),
    (
        "drop",
        "Ablation: lay the cloth flat on the ground plane z = 0 (a physical collider) by its four corners",
    ),
];

const BUILTIN_SOURCES: [&str; 3] = [
    include_str!("../../examples/scenes/u_obstacle.json"),
    include_str!("../../examples/scenes/swing.json"),
    include_str!("../../examples/scenes/drop.json"),
];

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// `v/|v|`, computed after scaling by the largest component so that neither tiny nor huge finite vectors
/// underflow or overflow; `None` for a zero or non-finite vector.
fn unit(v: &[f64; 3]) -> Option<[f64; 3]> {
    let m = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(m.is_finite() && m > 0.0) {
        return None;
    }
    let s = v.map(|x| x / m);
    let n = norm(&s);
    Some(s.map(|x| x / n))
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `n` followed by the noun in agreement with it: "1 vector", "2 vectors".
fn counted(n: usize, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

fn check_finite(field: &str, x: f64) -> Result<(), SceneError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(invalid(field, format!("must be finite, got {x}")))
    }
}

/// Finite, with magnitude at most [`MAX_COORDINATE`].
fn check_coordinate(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x.abs() <= MAX_COORDINATE {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("magnitude {x:e} exceeds the limit of {MAX_COORDINATE:e}"),
        ))
    }
}

fn check_vec3(field: &str, v: &[f64; 3]) -> Result<(), SceneError> {
    for (k, &x) in v.iter().enumerate() {
        check_coordinate(&format!("{field}[{k}]"), x)?;
    }
    Ok(())
}

fn check_positive(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x > 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be positive, got {x}")))
    }
}

fn check_non_negative(field: &str, x: f64) -> Result<(), SceneError> {
    check_finite(field, x)?;
    if x >= 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("must be non-negative, got {x}")))
    }
}

fn check_stiffness(field: &str, k: &Stiffness) -> Result<(), SceneError> {
    match *k {
        Stiffness::Infinite => Ok(()),
        Stiffness::Finite(x) if x.is_finite() && x > 0.0 => Ok(()),
        Stiffness::Finite(x) => Err(invalid(
            field,
            format!("must be a positive finite number or \"inf\", got {x}"),
        )),
    }
}

/// Pretty-prints `value` as JSON with arrays of scalars on one line. With serde_json's
/// `float_roundtrip` feature (enabled in this workspace) every `f64` reads back bit-identically.
pub fn to_json_pretty_compact<T: Serialize + ?Sized>(
    value: &T,
) -> Result<String, serde_json::Error> {
    Ok(inline_scalar_arrays(&serde_json::to_string_pretty(value)?))
}

/// Puts every JSON array that contains no strings, objects or arrays on a single line: `[1.0, 2.0, 3.0]`.
fn inline_scalar_arrays(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let (mut i, mut start) = (0, 0);
    let mut in_string = false;
    while i < bytes.len() {
        let b = bytes[i];
        if in_string {
            match b {
                b'\\' => i += 1,
                b'"' => in_string = false,
                _ => {}
            }
        } else if b == b'"' {
            in_string = true;
        } else if b == b'[' {
            let close = bytes[i + 1..]
                .iter()
                .position(|&c| matches!(c, b'[' | b']' | b'{' | b'"'))
                .map(|p| i + 1 + p);
            if let Some(j) = close.filter(|&j| bytes[j] == b']') {
                let items: Vec<&str> = text[i + 1..j]
                    .split(',')
                    .map(str::trim)
                    .filter(|t| !t.is_empty())
                    .collect();
                out.push_str(&text[start..i]);
                out.push('[');
                out.push_str(&items.join(", "));
                out.push(']');
                i = j + 1;
                start = i;
                continue;
            }
        }
        i += 1;
    }
    out.push_str(&text[start..]);
    out
}

/// Appends the offending source line to a serde_json error message.
fn parse_error(text: &str, err: &serde_json::Error) -> SceneError {
    let mut message = err.to_string();
    if err.line() > 0 {
        if let Some(line) = text.lines().nth(err.line() - 1) {
            let line = line.trim();
            if !line.is_empty() {
                let shown: String = line.chars().take(120).collect();
                let ellipsis = if line.chars().count() > 120 {
                    "…"
                } else {
                    ""
                };
                message.push_str(&format!(": `{shown}{ellipsis}`"));
            }
        }
    }
    SceneError::Parse {
        message: one_line(&message),
    }
}

impl Scene {
    /// Parses a scene from JSON text and validates it.
    pub fn from_json_str(text: &str) -> Result<Scene, SceneError> {
        let scene: Scene = serde_json::from_str(text).map_err(|e| parse_error(text, &e))?;
        scene.validate()?;
        Ok(scene)
    }

    /// Reads, parses and validates a scene file.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Scene::from_json_str(&text)
    }

    /// One of the built-in scenes (see [`Scene::builtin_names`]), embedded from `examples/scenes/`.
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        BUILTIN_NAMES
            .iter()
            .position(|(n, _)| *n == name)
            .map(|i| Scene::from_json_str(BUILTIN_SOURCES[i]))
            .unwrap_or_else(|| {
                Err(SceneError::UnknownBuiltin {
                    name: name.to_string(),
                })
            })
    }

    /// Names and one-line descriptions of the built-in scenes: `u_obstacle`, `swing`, `drop`.
    pub fn builtin_names() -> &'static [(&'static str, &'static str)] {
        BUILTIN_NAMES
    }

    /// The scene as pretty-printed JSON; [`Scene::from_json_str`] reads it back to an equal scene
    /// (bit-identical floats).
    pub fn to_json_pretty(&self) -> String {
        // Serializing these plain data types cannot fail whatever their values (no maps, no fallible
        // custom serializers; non-finite floats are written as `null`), so this never panics.
        to_json_pretty_compact(self).expect("serializing a Scene is infallible")
    }

    /// Checks every value; the first problem found is returned as [`SceneError::Invalid`] naming the field.
    ///
    /// Rejects: non-finite numbers anywhere; length-like values (coordinates, vector components,
    /// radii, `delta`) beyond [`MAX_COORDINATE`] in magnitude; `rows`/`cols` of 0 or more than
    /// [`MAX_PARTICLES`] particles; a zero `right` (when `cols > 1`) or `down` (when `rows > 1`), or
    /// parallel `right` and `down`; `particle_mass ≤ 0` or so small that its inverse overflows;
    /// non-positive stiffness, or one so small that the compliance `1/(k·dt²)` overflows; `dt ≤ 0`, or
    /// `dt²` not a normal number up to [`MAX_COORDINATE`]; `iterations = 0`; control particles
    /// out of range or repeated; sphere sets that are empty, whose radii and centres differ in number, or
    /// with a radius `≤ 0`; a zero plane normal; `horizon` of 0 or above [`MAX_HORIZON`]; no targets, a
    /// target out of range or repeated; negative `alpha`, `beta`, `delta`; initial controls of the wrong
    /// shape. No control particles at all is allowed.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.validate_cloth()?;
        self.validate_material()?;
        self.validate_physics()?;
        self.validate_controls()?;
        self.validate_obstacles()?;
        self.validate_task()?;
        self.validate_custom_constraints()
    }

    fn validate_cloth(&self) -> Result<(), SceneError> {
        let c = &self.cloth;
        if c.rows == 0 {
            return Err(invalid("cloth.rows", "must be at least 1, got 0"));
        }
        if c.cols == 0 {
            return Err(invalid("cloth.cols", "must be at least 1, got 0"));
        }
        match c.rows.checked_mul(c.cols) {
            Some(n) if n <= MAX_PARTICLES => {}
            _ => {
                return Err(invalid(
                    "cloth",
                    format!(
                        "{} × {} particles exceed the limit of {MAX_PARTICLES}",
                        c.rows, c.cols
                    ),
                ))
            }
        }
        check_vec3("cloth.top_left", &c.top_left)?;
        check_vec3("cloth.right", &c.right)?;
        check_vec3("cloth.down", &c.down)?;
        let (ur, ud) = (unit(&c.right), unit(&c.down));
        if c.cols > 1 && ur.is_none() {
            return Err(invalid(
                "cloth.right",
                format!("zero-length vector, but cloth.cols = {} > 1", c.cols),
            ));
        }
        if c.rows > 1 && ud.is_none() {
            return Err(invalid(
                "cloth.down",
                format!("zero-length vector, but cloth.rows = {} > 1", c.rows),
            ));
        }
        if let (true, true, Some(ur), Some(ud)) = (c.rows > 1, c.cols > 1, ur, ud) {
            // sine of the angle between right and down
            if norm(&cross(&ur, &ud)) <= 1e-9 {
                return Err(invalid(
                    "cloth.down",
                    "parallel to cloth.right (the cloth would be degenerate)",
                ));
            }
        }
        check_positive("cloth.particle_mass", c.particle_mass)?;
        if !(1.0 / c.particle_mass).is_finite() {
            return Err(invalid(
                "cloth.particle_mass",
                format!("{:e} is too small: its inverse overflows", c.particle_mass),
            ));
        }
        Ok(())
    }

    fn validate_material(&self) -> Result<(), SceneError> {
        check_stiffness("material.stretch", &self.material.stretch)?;
        if let Some(b) = &self.material.bending {
            check_stiffness("material.bending.stiffness", &b.stiffness)?;
        }
        Ok(())
    }

    fn validate_physics(&self) -> Result<(), SceneError> {
        let p = &self.physics;
        check_positive("physics.dt", p.dt)?;
        let dt2 = p.dt * p.dt;
        if !(dt2.is_normal() && dt2 <= MAX_COORDINATE) {
            return Err(invalid(
                "physics.dt",
                format!(
                    "{:e} is out of range: dt² must be a normal number at most {MAX_COORDINATE:e}",
                    p.dt
                ),
            ));
        }
        check_vec3("physics.gravity", &p.gravity)?;
        if p.iterations == 0 {
            return Err(invalid("physics.iterations", "must be at least 1, got 0"));
        }
        if let Some(tol) = p.tolerance {
            check_finite("physics.tolerance", tol)?;
            if !(tol > 0.0 && tol < 1.0) {
                return Err(invalid(
                    "physics.tolerance",
                    format!("must be in (0, 1), got {tol}"),
                ));
            }
        }
        if p.max_newton_iterations == Some(0) {
            return Err(invalid(
                "physics.max_newton_iterations",
                "must be at least 1, got 0",
            ));
        }
        if p.solver == SolverKind::Newton {
            self.validate_newton()?;
        }
        // The XPBD compliance α̃ = 1/(k·dt²) must be a finite number (a projection divides by it).
        let mut stiffnesses = vec![("material.stretch", self.material.stretch)];
        if let Some(b) = &self.material.bending {
            stiffnesses.push(("material.bending.stiffness", b.stiffness));
        }
        for (field, k) in stiffnesses {
            let compliance = k.compliance(p.dt);
            if !compliance.is_finite() {
                return Err(invalid(
                    field,
                    format!(
                        "{:e} is too small for physics.dt = {:e}: the compliance 1/(k·dt²) overflows",
                        k.value(),
                        p.dt
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Newton's method needs a finite energy: no rigid material or collider obstacle.
    fn validate_newton(&self) -> Result<(), SceneError> {
        let rigid = "is rigid (infinite stiffness), which physics.solver \"newton\" does not \
                     support; give it a finite stiffness or use \"xpbd\"";
        if self.material.stretch == Stiffness::Infinite {
            return Err(invalid("material.stretch", rigid));
        }
        if let Some(b) = &self.material.bending {
            if b.stiffness == Stiffness::Infinite {
                return Err(invalid("material.bending.stiffness", rigid));
            }
        }
        if let Some(i) = self.obstacles.iter().position(|o| o.role().is_collider()) {
            return Err(invalid(
                format!("obstacles[{i}].role"),
                "a collider is a rigid contact, which physics.solver \"newton\" does not \
                 support; use role \"safety\" or physics.solver \"xpbd\"",
            ));
        }
        Ok(())
    }

    /// Checks that `(row, col)` lies on the cloth.
    fn check_particle(&self, field: &str, rc: [usize; 2]) -> Result<(), SceneError> {
        let [r, c] = rc;
        if r >= self.cloth.rows {
            return Err(invalid(
                field,
                format!("row {r} out of range (cloth.rows = {})", self.cloth.rows),
            ));
        }
        if c >= self.cloth.cols {
            return Err(invalid(
                field,
                format!("col {c} out of range (cloth.cols = {})", self.cloth.cols),
            ));
        }
        Ok(())
    }

    fn validate_controls(&self) -> Result<(), SceneError> {
        for (i, &rc) in self.controls.iter().enumerate() {
            let field = format!("controls[{i}]");
            self.check_particle(&field, rc)?;
            if let Some(j) = self.controls[..i].iter().position(|&o| o == rc) {
                return Err(invalid(
                    field,
                    format!("particle ({}, {}) duplicates controls[{j}]", rc[0], rc[1]),
                ));
            }
        }
        Ok(())
    }

    fn validate_obstacles(&self) -> Result<(), SceneError> {
        for (i, obstacle) in self.obstacles.iter().enumerate() {
            let base = format!("obstacles[{i}]");
            match obstacle {
                Obstacle::Spheres(s) => {
                    if s.centers.is_empty() {
                        return Err(invalid(
                            format!("{base}.centers"),
                            "a sphere set needs at least one sphere",
                        ));
                    }
                    if s.radii.len() != s.centers.len() {
                        return Err(invalid(
                            format!("{base}.radii"),
                            format!(
                                "{} radii for {} centers (need one radius per center)",
                                s.radii.len(),
                                s.centers.len()
                            ),
                        ));
                    }
                    for (j, c) in s.centers.iter().enumerate() {
                        check_vec3(&format!("{base}.centers[{j}]"), c)?;
                    }
                    for (j, &r) in s.radii.iter().enumerate() {
                        check_positive(&format!("{base}.radii[{j}]"), r)?;
                        check_coordinate(&format!("{base}.radii[{j}]"), r)?;
                    }
                }
                Obstacle::Plane(p) => {
                    check_vec3(&format!("{base}.point"), &p.point)?;
                    check_vec3(&format!("{base}.normal"), &p.normal)?;
                    if unit(&p.normal).is_none() {
                        return Err(invalid(
                            format!("{base}.normal"),
                            "zero vector; a plane needs a nonzero normal",
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    fn validate_task(&self) -> Result<(), SceneError> {
        let t = &self.task;
        if t.horizon == 0 {
            return Err(invalid("task.horizon", "must be at least 1, got 0"));
        }
        if t.horizon > MAX_HORIZON {
            return Err(invalid(
                "task.horizon",
                format!("{} exceeds the limit of {MAX_HORIZON}", t.horizon),
            ));
        }
        if t.targets.is_empty() {
            return Err(invalid("task.targets", "at least one target is required"));
        }
        for (i, target) in t.targets.iter().enumerate() {
            let field = format!("task.targets[{i}].particle");
            self.check_particle(&field, target.particle)?;
            if let Some(j) = t.targets[..i]
                .iter()
                .position(|o| o.particle == target.particle)
            {
                let [r, c] = target.particle;
                return Err(invalid(
                    field,
                    format!("particle ({r}, {c}) duplicates task.targets[{j}]"),
                ));
            }
            check_vec3(&format!("task.targets[{i}].position"), &target.position)?;
        }
        check_non_negative("task.alpha", t.alpha)?;
        check_non_negative("task.beta", t.beta)?;
        check_non_negative("task.delta", t.delta)?;
        check_coordinate("task.delta", t.delta)?;
        if let Some(tol) = t.tolerance {
            if !(tol.is_finite() && tol > 0.0) {
                return Err(invalid(
                    "task.tolerance",
                    format!("must be a finite number > 0, got {tol}"),
                ));
            }
            check_coordinate("task.tolerance", tol)?;
        }
        let m = self.controls.len();
        match &t.initial_controls {
            InitialControls::Zeros => {}
            InitialControls::Constant(v) => {
                let field = "task.initial_controls.constant";
                if v.len() != m {
                    return Err(invalid(
                        field,
                        format!(
                            "{} given, need one per control particle ({m})",
                            counted(v.len(), "vector", "vectors")
                        ),
                    ));
                }
                for (k, u) in v.iter().enumerate() {
                    check_vec3(&format!("{field}[{k}]"), u)?;
                }
            }
            InitialControls::Explicit(steps) => {
                let field = "task.initial_controls.explicit";
                if steps.len() != t.horizon {
                    return Err(invalid(
                        field,
                        format!(
                            "{} given, need task.horizon = {}",
                            counted(steps.len(), "step", "steps"),
                            t.horizon
                        ),
                    ));
                }
                for (s, step) in steps.iter().enumerate() {
                    if step.len() != m {
                        return Err(invalid(
                            format!("{field}[{s}]"),
                            format!(
                                "{} given, need one per control particle ({m})",
                                counted(step.len(), "vector", "vectors")
                            ),
                        ));
                    }
                    for (k, u) in step.iter().enumerate() {
                        check_vec3(&format!("{field}[{s}][{k}]"), u)?;
                    }
                }
            }
        }
        self.validate_limits()
    }

    fn validate_limits(&self) -> Result<(), SceneError> {
        let limits = &self.task.limits;
        if let Some(step) = limits.max_step {
            check_positive("task.limits.max_step", step)?;
            check_coordinate("task.limits.max_step", step)?;
        }
        if let Some(strain) = limits.max_strain {
            check_positive("task.limits.max_strain", strain)?;
            check_coordinate("task.limits.max_strain", strain)?;
        }
        let rest = self.rest_positions();
        let grippers: Vec<([usize; 2], [f64; 3])> = self
            .controls
            .iter()
            .zip(self.control_indices())
            .map(|(&rc, p)| (rc, rest[p]))
            .collect();
        if let Some(w) = &limits.workspace {
            check_vec3("task.limits.workspace.min", &w.min)?;
            check_vec3("task.limits.workspace.max", &w.max)?;
            for j in 0..3 {
                if w.min[j] > w.max[j] {
                    return Err(invalid(
                        format!("task.limits.workspace.min[{j}]"),
                        format!("{} exceeds max[{j}] = {}", w.min[j], w.max[j]),
                    ));
                }
            }
            for ([r, c], p) in &grippers {
                if (0..3).any(|j| p[j] < w.min[j] || p[j] > w.max[j]) {
                    return Err(invalid(
                        "task.limits.workspace",
                        format!("control point ({r}, {c}) starts outside it, at {p:?}"),
                    ));
                }
            }
        }
        if let Some([lo, hi]) = limits.gripper_separation {
            let field = "task.limits.gripper_separation";
            check_non_negative(&format!("{field}[0]"), lo)?;
            check_coordinate(&format!("{field}[0]"), lo)?;
            check_positive(&format!("{field}[1]"), hi)?;
            check_coordinate(&format!("{field}[1]"), hi)?;
            if lo > hi {
                return Err(invalid(
                    field,
                    format!("min {lo} exceeds max {hi} (expected [min, max])"),
                ));
            }
            for (a, (ra, pa)) in grippers.iter().enumerate() {
                for (rb, pb) in &grippers[a + 1..] {
                    let d = norm(&[pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]]);
                    if d < lo || d > hi {
                        return Err(invalid(
                            field,
                            format!(
                                "control points ({}, {}) and ({}, {}) start {d} apart, outside [{lo}, {hi}]",
                                ra[0], ra[1], rb[0], rb[1]
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The cloth's grid mesh (`cloth.rows × cloth.cols`).
    pub fn mesh(&self) -> GridMesh {
        GridMesh::new(self.cloth.rows, self.cloth.cols)
    }

    /// Number of particles, `cloth.rows × cloth.cols`.
    pub fn n_particles(&self) -> usize {
        self.cloth.rows * self.cloth.cols
    }

    /// Rest positions in particle-index order (`p = r·cols + c`):
    /// `top_left + right·(c/max(cols−1,1)) + down·(r/max(rows−1,1))`, summed left to right.
    pub fn rest_positions(&self) -> Vec<[f64; 3]> {
        let c = &self.cloth;
        let col_den = c.cols.saturating_sub(1).max(1) as f64;
        let row_den = c.rows.saturating_sub(1).max(1) as f64;
        let mut out = Vec::with_capacity(self.n_particles());
        for r in 0..c.rows {
            let s = r as f64 / row_den;
            for col in 0..c.cols {
                let t = col as f64 / col_den;
                out.push(std::array::from_fn(|k| {
                    c.top_left[k] + c.right[k] * t + c.down[k] * s
                }));
            }
        }
        out
    }

    /// Length of the cloth's longest side: the larger of `|right|` (when `cols > 1`) and
    /// `|down|` (when `rows > 1`); 0 for a single particle.
    pub fn longest_side(&self) -> f64 {
        let c = &self.cloth;
        let len = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let right = if c.cols > 1 { len(&c.right) } else { 0.0 };
        let down = if c.rows > 1 { len(&c.down) } else { 0.0 };
        right.max(down)
    }

    /// Default of `task.tolerance`: 10% of [`Scene::longest_side`] (1e-3 for a cloth of one
    /// particle, which has no side to measure).
    pub fn default_tolerance(&self) -> f64 {
        let side = self.longest_side();
        if side > 0.0 {
            0.1 * side
        } else {
            1e-3
        }
    }

    /// The task's target tolerance: `task.tolerance`, or [`Scene::default_tolerance`].
    pub fn tolerance(&self) -> f64 {
        self.task
            .tolerance
            .unwrap_or_else(|| self.default_tolerance())
    }

    /// Particle indices of the control particles, in control order.
    pub fn control_indices(&self) -> Vec<usize> {
        self.controls
            .iter()
            .map(|&[r, c]| r * self.cloth.cols + c)
            .collect()
    }

    /// Particle indices of the targets, in target order.
    pub fn target_indices(&self) -> Vec<usize> {
        self.task
            .targets
            .iter()
            .map(|t| t.particle[0] * self.cloth.cols + t.particle[1])
            .collect()
    }

    /// Target positions, in target order.
    pub fn target_positions(&self) -> Vec<[f64; 3]> {
        self.task.targets.iter().map(|t| t.position).collect()
    }

    /// The initial control guess as a `horizon × controls` array (`[t][k]` = displacement of control `k`
    /// during step `t + 1`). The shape is exact for a validated scene.
    pub fn initial_controls_array(&self) -> Vec<Vec<[f64; 3]>> {
        let (h, m) = (self.task.horizon, self.controls.len());
        match &self.task.initial_controls {
            InitialControls::Zeros => vec![vec![[0.0; 3]; m]; h],
            InitialControls::Constant(v) => vec![v.clone(); h],
            InitialControls::Explicit(steps) => steps.clone(),
        }
    }

    /// The initial control guess as a controls tensor (`horizon × 3·controls`, see
    /// [`crate::Controls`]).
    pub fn initial_controls(&self) -> autodiff::Tensor {
        let u = self.initial_controls_array();
        let values = u.iter().flatten().flatten().copied().collect();
        autodiff::Tensor::new(u.len(), 3 * self.controls.len(), values)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    fn base_value() -> Value {
        serde_json::from_str(BUILTIN_SOURCES[0]).expect("u_obstacle parses")
    }

    /// Applies `edit` to the u_obstacle JSON, parses it and returns the validation error.
    fn invalid_after(edit: impl FnOnce(&mut Value)) -> (String, String) {
        let mut v = base_value();
        edit(&mut v);
        match Scene::from_json_str(&v.to_string()) {
            Err(e @ SceneError::Invalid { .. }) => {
                let display = e.to_string();
                let SceneError::Invalid { field, .. } = e else {
                    unreachable!()
                };
                (field, display)
            }
            other => panic!("expected SceneError::Invalid, got {other:?}"),
        }
    }

    /// Applies `edit` to the built-in u_obstacle scene struct and returns the validation error.
    fn invalid_struct(edit: impl FnOnce(&mut Scene)) -> (String, String) {
        let mut s = Scene::builtin("u_obstacle").expect("builtin");
        edit(&mut s);
        match s.validate() {
            Err(e @ SceneError::Invalid { .. }) => {
                let display = e.to_string();
                let SceneError::Invalid { field, .. } = e else {
                    unreachable!()
                };
                (field, display)
            }
            other => panic!("expected SceneError::Invalid, got {other:?}"),
        }
    }

    fn parse_error_after(edit: impl FnOnce(&mut Value)) -> String {
        let mut v = base_value();
        edit(&mut v);
        let text = serde_json::to_string_pretty(&v).expect("to json");
        match Scene::from_json_str(&text) {
            Err(e @ SceneError::Parse { .. }) => e.to_string(),
            other => panic!("expected SceneError::Parse, got {other:?}"),
        }
    }

    fn set(v: &mut Value, pointer: &str, x: Value) {
        *v.pointer_mut(pointer)
            .unwrap_or_else(|| panic!("{pointer}")) = x;
    }

    /// One test per rejection case (JSON edit): asserts the exact field path and that the one-line
    /// message starts with it.
    macro_rules! rejects {
        ($name:ident, $field:expr, $reason:expr, |$v:ident| $edit:expr) => {
            #[test]
            fn $name() {
                let (field, msg) = invalid_after(|$v: &mut Value| {
                    $edit;
                });
                assert_eq!(field, $field, "message: {msg}");
                assert!(msg.starts_with(&format!("{}: ", $field)), "{msg}");
                assert!(msg.contains($reason), "{msg}");
                assert!(!msg.contains('\n'), "{msg}");
            }
        };
    }

    /// One test per rejection case that JSON cannot express (non-finite numbers): edits the struct.
    macro_rules! rejects_struct {
        ($name:ident, $field:expr, $reason:expr, |$s:ident| $edit:expr) => {
            #[test]
            fn $name() {
                let (field, msg) = invalid_struct(|$s: &mut Scene| {
                    $edit;
                });
                assert_eq!(field, $field, "message: {msg}");
                assert!(msg.starts_with(&format!("{}: ", $field)), "{msg}");
                assert!(msg.contains($reason), "{msg}");
            }
        };
    }

    // --- cloth ---
    rejects!(rows_zero, "cloth.rows", "at least 1", |v| set(
        v,
        "/cloth/rows",
        json!(0)
    ));
    rejects!(cols_zero, "cloth.cols", "at least 1", |v| set(
        v,
        "/cloth/cols",
        json!(0)
    ));
    rejects!(too_many_particles, "cloth", "exceed the limit", |v| {
        set(v, "/cloth/rows", json!(100_000));
        set(v, "/cloth/cols", json!(100_000));
    });
    rejects!(rows_times_cols_overflow, "cloth", "exceed the limit", |v| {
        set(v, "/cloth/rows", json!(u64::MAX));
        set(v, "/cloth/cols", json!(3));
    });
    rejects!(right_zero, "cloth.right", "zero-length", |v| set(
        v,
        "/cloth/right",
        json!([0.0, 0.0, 0.0])
    ));
    rejects!(down_zero, "cloth.down", "zero-length", |v| set(
        v,
        "/cloth/down",
        json!([0.0, 0.0, 0.0])
    ));
    rejects!(right_down_parallel, "cloth.down", "parallel", |v| set(
        v,
        "/cloth/down",
        json!([-2.0, 0.0, 0.0])
    ));
    rejects!(mass_zero, "cloth.particle_mass", "positive", |v| set(
        v,
        "/cloth/particle_mass",
        json!(0.0)
    ));
    rejects!(mass_negative, "cloth.particle_mass", "-1", |v| set(
        v,
        "/cloth/particle_mass",
        json!(-1.0)
    ));
    rejects_struct!(top_left_nan, "cloth.top_left[1]", "finite", |s| s
        .cloth
        .top_left[1] =
        f64::NAN);
    rejects_struct!(right_inf, "cloth.right[0]", "finite", |s| s.cloth.right
        [0] =
        f64::INFINITY);
    rejects_struct!(down_nan, "cloth.down[2]", "finite", |s| s.cloth.down[2] =
        f64::NAN);
    rejects_struct!(mass_nan, "cloth.particle_mass", "finite", |s| s
        .cloth
        .particle_mass =
        f64::NAN);

    // --- material ---
    rejects!(stretch_negative, "material.stretch", "positive", |v| set(
        v,
        "/material/stretch",
        json!(-5.0)
    ));
    rejects!(stretch_zero, "material.stretch", "positive", |v| set(
        v,
        "/material/stretch",
        json!(0)
    ));
    rejects!(
        bending_stiffness_zero,
        "material.bending.stiffness",
        "positive",
        |v| set(v, "/material/bending/stiffness", json!(0.0))
    );
    rejects_struct!(stretch_nan, "material.stretch", "finite", |s| s
        .material
        .stretch =
        Stiffness::Finite(f64::NAN));
    rejects_struct!(stretch_finite_inf, "material.stretch", "finite", |s| s
        .material
        .stretch =
        Stiffness::Finite(f64::INFINITY));

    // --- physics ---
    rejects!(dt_zero, "physics.dt", "positive", |v| set(
        v,
        "/physics/dt",
        json!(0.0)
    ));
    rejects!(dt_negative, "physics.dt", "positive", |v| set(
        v,
        "/physics/dt",
        json!(-0.1)
    ));
    rejects!(
        iterations_zero,
        "physics.iterations",
        "at least 1",
        |v| set(v, "/physics/iterations", json!(0))
    );
    rejects_struct!(gravity_nan, "physics.gravity[2]", "finite", |s| s
        .physics
        .gravity[2] =
        f64::NAN);
    rejects_struct!(dt_nan, "physics.dt", "finite", |s| s.physics.dt = f64::NAN);

    // --- controls ---
    rejects!(
        control_row_out_of_range,
        "controls[1]",
        "row 10 out of range (cloth.rows = 10)",
        |v| set(v, "/controls/1", json!([10, 0]))
    );
    rejects!(
        control_col_out_of_range,
        "controls[0]",
        "col 11 out of range (cloth.cols = 10)",
        |v| set(v, "/controls/0", json!([0, 11]))
    );
    rejects!(
        control_duplicated,
        "controls[2]",
        "particle (0, 9) duplicates controls[1]",
        |v| {
            set(v, "/controls", json!([[0, 0], [0, 9], [0, 9]]));
            set(v, "/task/initial_controls", json!("zeros"));
        }
    );

    // --- obstacles ---
    rejects!(
        spheres_length_mismatch,
        "obstacles[0].radii",
        "17 radii for 18 centers",
        |v| {
            let radii = v
                .pointer_mut("/obstacles/0/radii")
                .and_then(Value::as_array_mut)
                .expect("radii");
            radii.pop();
        }
    );
    rejects!(
        spheres_empty,
        "obstacles[0].centers",
        "at least one sphere",
        |v| {
            set(v, "/obstacles/0/centers", json!([]));
            set(v, "/obstacles/0/radii", json!([]));
        }
    );
    rejects!(
        sphere_radius_zero,
        "obstacles[0].radii[3]",
        "positive",
        |v| { set(v, "/obstacles/0/radii/3", json!(0.0)) }
    );
    rejects!(
        sphere_radius_negative,
        "obstacles[0].radii[17]",
        "-0.25",
        |v| set(v, "/obstacles/0/radii/17", json!(-0.25))
    );
    rejects_struct!(
        sphere_center_nan,
        "obstacles[0].centers[2][0]",
        "finite",
        |s| {
            if let Obstacle::Spheres(sp) = &mut s.obstacles[0] {
                sp.centers[2][0] = f64::NAN;
            }
        }
    );
    rejects!(
        plane_normal_zero,
        "obstacles[1].normal",
        "nonzero normal",
        |v| {
            let obs = v
                .pointer_mut("/obstacles")
                .and_then(Value::as_array_mut)
                .expect("obstacles");
            obs.push(
                json!({"type": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 0.0],
                            "role": "collider"}),
            );
        }
    );
    rejects_struct!(plane_point_nan, "obstacles[1].point[2]", "finite", |s| {
        s.obstacles.push(Obstacle::Plane(Plane {
            point: [0.0, 0.0, f64::NAN],
            normal: [0.0, 0.0, 1.0],
            role: ObstacleRole::Both,
        }))
    });

    // --- task ---
    rejects!(horizon_zero, "task.horizon", "at least 1", |v| set(
        v,
        "/task/horizon",
        json!(0)
    ));
    rejects!(horizon_huge, "task.horizon", "limit", |v| set(
        v,
        "/task/horizon",
        json!(u64::MAX)
    ));
    rejects!(targets_empty, "task.targets", "at least one target", |v| {
        set(v, "/task/targets", json!([]))
    });
    rejects!(
        target_row_out_of_range,
        "task.targets[3].particle",
        "task.targets[3].particle: row 12 out of range (cloth.rows = 10)",
        |v| set(v, "/task/targets/3/particle", json!([12, 3]))
    );
    rejects!(
        target_col_out_of_range,
        "task.targets[9].particle",
        "col 10 out of range (cloth.cols = 10)",
        |v| set(v, "/task/targets/9/particle", json!([9, 10]))
    );
    rejects!(
        target_duplicated,
        "task.targets[4].particle",
        "particle (9, 0) duplicates task.targets[0]",
        |v| set(v, "/task/targets/4/particle", json!([9, 0]))
    );
    rejects_struct!(
        target_position_nan,
        "task.targets[0].position[1]",
        "finite",
        |s| s.task.targets[0].position[1] = f64::NAN
    );
    rejects!(alpha_negative, "task.alpha", "non-negative", |v| set(
        v,
        "/task/alpha",
        json!(-1.0)
    ));
    rejects!(beta_negative, "task.beta", "non-negative", |v| set(
        v,
        "/task/beta",
        json!(-1e-4)
    ));
    rejects!(delta_negative, "task.delta", "non-negative", |v| set(
        v,
        "/task/delta",
        json!(-0.2)
    ));
    rejects_struct!(alpha_inf, "task.alpha", "finite", |s| s.task.alpha =
        f64::INFINITY);
    rejects!(
        constant_controls_wrong_count,
        "task.initial_controls.constant",
        "1 vector given, need one per control particle (2)",
        |v| set(
            v,
            "/task/initial_controls",
            json!({"constant": [[0.0, 0.3, 0.0]]})
        )
    );
    rejects_struct!(
        constant_controls_nan,
        "task.initial_controls.constant[1][2]",
        "finite",
        |s| s.task.initial_controls =
            InitialControls::Constant(vec![[0.0; 3], [0.0, 0.0, f64::NAN]])
    );
    rejects!(
        explicit_controls_wrong_horizon,
        "task.initial_controls.explicit",
        "3 steps given, need task.horizon = 10",
        |v| set(
            v,
            "/task/initial_controls",
            json!({"explicit": vec![vec![[0.0, 0.0, 0.0]; 2]; 3]})
        )
    );
    rejects!(
        explicit_controls_wrong_count,
        "task.initial_controls.explicit[4]",
        "1 vector given, need one per control particle (2)",
        |v| {
            let mut steps = vec![vec![[0.0, 0.0, 0.0]; 2]; 10];
            steps[4].pop();
            set(v, "/task/initial_controls", json!({ "explicit": steps }));
        }
    );
    rejects_struct!(
        explicit_controls_nan,
        "task.initial_controls.explicit[9][0][0]",
        "finite",
        |s| {
            let mut steps = vec![vec![[0.0; 3]; 2]; 10];
            steps[9][0][0] = f64::NEG_INFINITY;
            s.task.initial_controls = InitialControls::Explicit(steps);
        }
    );

    // --- parse errors (serde names the field) ---
    // --- task.limits ---
    rejects!(
        max_step_zero,
        "task.limits.max_step",
        "must be positive",
        |v| v["task"]["limits"] = json!({"max_step": 0.0})
    );
    rejects!(
        max_strain_negative,
        "task.limits.max_strain",
        "must be positive",
        |v| v["task"]["limits"] = json!({"max_strain": -0.1})
    );
    rejects!(
        workspace_inverted,
        "task.limits.workspace.min[2]",
        "exceeds max[2]",
        |v| v["task"]["limits"] = json!({"workspace": {"min": [-5, -5, 3], "max": [5, 5, 1]}})
    );
    rejects!(
        workspace_excludes_start,
        "task.limits.workspace",
        "control point (0, 0) starts outside it",
        |v| v["task"]["limits"] = json!({"workspace": {"min": [-5, -5, 2.5], "max": [5, 5, 5]}})
    );
    rejects!(
        separation_inverted,
        "task.limits.gripper_separation",
        "min 2 exceeds max 1",
        |v| v["task"]["limits"] = json!({"gripper_separation": [2.0, 1.0]})
    );
    rejects!(
        separation_max_zero,
        "task.limits.gripper_separation[1]",
        "must be positive",
        |v| v["task"]["limits"] = json!({"gripper_separation": [0.0, 0.0]})
    );
    rejects!(
        separation_excludes_start,
        "task.limits.gripper_separation",
        "start 1 apart",
        |v| v["task"]["limits"] = json!({"gripper_separation": [0.2, 0.5]})
    );
    rejects_struct!(max_step_nan, "task.limits.max_step", "finite", |s| s
        .task
        .limits
        .max_step =
        Some(f64::NAN));

    #[test]
    fn limits_round_trip_and_reject_unknown_fields() {
        let mut v = base_value();
        v["task"]["limits"] = json!({"max_step": 0.5, "max_strain": 0.5});
        let scene = Scene::from_json_str(&v.to_string()).expect("valid");
        assert_eq!(scene.task.limits.max_step, Some(0.5));
        assert_eq!(scene.task.limits.workspace, None);
        let back = Scene::from_json_str(&scene.to_json_pretty()).expect("round trip");
        assert_eq!(back, scene);
        // No limits: the field is left out, so limit-free scenes print as before.
        let plain = Scene::builtin("u_obstacle").expect("builtin");
        assert!(!plain.to_json_pretty().contains("limits"));
        let msg = parse_error_after(|v| v["task"]["limits"] = json!({"max_speed": 1.0}));
        assert!(msg.contains("max_speed"), "{msg}");
    }

    #[test]
    fn unknown_top_level_field() {
        let msg = parse_error_after(|v| {
            v["colour"] = json!("red");
        });
        assert!(msg.contains("unknown field `colour`"), "{msg}");
        assert!(msg.contains("line"), "{msg}");
    }

    #[test]
    fn unknown_nested_fields() {
        let msg = parse_error_after(|v| v["cloth"]["side"] = json!(1.0));
        assert!(msg.contains("unknown field `side`"), "{msg}");
        let msg = parse_error_after(|v| v["material"]["bending"]["kind"] = json!(1.0));
        assert!(msg.contains("unknown field `kind`"), "{msg}");
        let msg = parse_error_after(|v| v["physics"]["substeps"] = json!(2));
        assert!(msg.contains("unknown field `substeps`"), "{msg}");
        let msg = parse_error_after(|v| v["task"]["targets"][0]["weight"] = json!(2));
        assert!(msg.contains("unknown field `weight`"), "{msg}");
        let msg = parse_error_after(|v| v["task"]["gamma"] = json!(2));
        assert!(msg.contains("unknown field `gamma`"), "{msg}");
    }

    #[test]
    fn unknown_obstacle_field_and_type() {
        let msg = parse_error_after(|v| v["obstacles"][0]["color"] = json!("red"));
        assert!(msg.contains("unknown field `color`"), "{msg}");
        let msg = parse_error_after(|v| v["obstacles"][0]["type"] = json!("cube"));
        assert!(msg.contains("unknown variant `cube`"), "{msg}");
        let msg = parse_error_after(|v| {
            v["obstacles"] = json!([{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                                     "role": "collider", "radii": [1.0]}]);
        });
        assert!(msg.contains("unknown field `radii`"), "{msg}");
    }

    #[test]
    fn missing_fields() {
        let msg = parse_error_after(|v| {
            v.as_object_mut().expect("object").remove("task");
        });
        assert!(msg.contains("missing field `task`"), "{msg}");
        let msg = parse_error_after(|v| {
            v["physics"].as_object_mut().expect("object").remove("dt");
        });
        assert!(msg.contains("missing field `dt`"), "{msg}");
        let msg = parse_error_after(|v| {
            v["obstacles"][0]
                .as_object_mut()
                .expect("object")
                .remove("role");
        });
        assert!(msg.contains("missing field `role`"), "{msg}");
    }

    #[test]
    fn wrong_types_show_the_line() {
        let msg = parse_error_after(|v| v["physics"]["dt"] = json!("fast"));
        assert!(msg.contains("invalid type: string \"fast\""), "{msg}");
        assert!(msg.contains("\"dt\": \"fast\""), "source line shown: {msg}");
        let msg = parse_error_after(|v| v["cloth"]["rows"] = json!(-3));
        assert!(msg.contains("\"rows\": -3"), "{msg}");
        let msg = parse_error_after(|v| v["cloth"]["top_left"] = json!([0.0, 1.0]));
        assert!(msg.contains("expected an array of length 3"), "{msg}");
        let msg = parse_error_after(|v| v["material"]["stretch"] = json!("infinite"));
        assert!(msg.contains("\"inf\""), "{msg}");
        let msg = parse_error_after(|v| v["material"]["bending"]["model"] = json!("cubic"));
        assert!(msg.contains("unknown variant `cubic`"), "{msg}");
        let msg = parse_error_after(|v| v["obstacles"][0]["role"] = json!("wall"));
        assert!(msg.contains("unknown variant `wall`"), "{msg}");
        let msg = parse_error_after(|v| v["task"]["initial_controls"] = json!("ones"));
        assert!(msg.contains("unknown variant `ones`"), "{msg}");
    }

    #[test]
    fn malformed_json() {
        let err = Scene::from_json_str("{ \"name\": \"x\", ").expect_err("malformed");
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
        assert!(err.to_string().contains("line 1"), "{err}");
        let err = Scene::from_json_str("").expect_err("empty");
        assert!(matches!(err, SceneError::Parse { .. }), "{err:?}");
        // numbers too large for f64 are refused by the parser, never turned into infinity
        let text = BUILTIN_SOURCES[0].replace("\"dt\": 0.1", "\"dt\": 1e400");
        let err = Scene::from_json_str(&text).expect_err("overflow");
        assert!(err.to_string().contains("out of range"), "{err}");
    }

    #[test]
    fn io_error_and_unknown_builtin() {
        let err = Scene::load("/nonexistent/dir/scene.json").expect_err("missing file");
        assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
        assert!(
            err.to_string().contains("/nonexistent/dir/scene.json"),
            "{err}"
        );
        let err = Scene::builtin("U").expect_err("unknown");
        assert!(matches!(err, SceneError::UnknownBuiltin { ref name } if name == "U"));
        assert!(err.to_string().contains("u_obstacle, swing, drop"), "{err}");
    }

    // --- accepted edge cases and defaults ---
    #[test]
    fn minimal_scene_gets_defaults() {
        let text = r#"{
            "name": "rope",
            "cloth": {"rows": 1, "cols": 4, "top_left": [0, 0, 1], "right": [3, 0, 0], "down": [0, 0, 0]},
            "material": {"stretch": "inf"},
            "physics": {"dt": 0.05, "gravity": [0, 0, 0], "iterations": 5},
            "controls": [],
            "task": {"horizon": 2, "targets": [{"particle": [0, 3], "position": [1, 1, 1]}],
                     "alpha": 0, "beta": 0, "initial_controls": "zeros"}
        }"#;
        let s = Scene::from_json_str(text).expect("valid");
        assert_eq!(s.description, "");
        assert_eq!(s.cloth.particle_mass, 1.0);
        assert_eq!(s.material.bending, None);
        assert!(s.obstacles.is_empty());
        assert_eq!(s.task.delta, 0.0);
        assert_eq!(s.material.stretch, Stiffness::Infinite);
        assert_eq!(s.material.stretch.compliance(0.05), 0.0);
        assert_eq!(s.material.stretch.value(), f64::INFINITY);
        assert!(s.control_indices().is_empty());
        assert_eq!(s.initial_controls_array(), vec![Vec::<[f64; 3]>::new(); 2]);
        assert_eq!(
            s.rest_positions(),
            vec![
                [0.0, 0.0, 1.0],
                [1.0, 0.0, 1.0],
                [2.0, 0.0, 1.0],
                [3.0, 0.0, 1.0]
            ]
        );
        assert_eq!(s.target_indices(), vec![3]);
        // round trip (bending absent, stiffness "inf")
        let back = Scene::from_json_str(&s.to_json_pretty()).expect("round trip");
        assert_eq!(back, s);
        assert!(s.to_json_pretty().contains("\"stretch\": \"inf\""));
        assert!(!s.to_json_pretty().contains("bending"));
    }

    #[test]
    fn single_particle_and_default_bending_model() {
        let text = r#"{
            "name": "dot",
            "cloth": {"rows": 1, "cols": 1, "top_left": [0, 0, 0], "right": [0, 0, 0], "down": [0, 0, 0],
                      "particle_mass": 0.5},
            "material": {"stretch": 10, "bending": {"stiffness": 2}},
            "physics": {"dt": 1, "gravity": [0, 0, -1], "iterations": 1},
            "controls": [[0, 0]],
            "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 3, 4], "role": "both"}],
            "task": {"horizon": 1, "targets": [{"particle": [0, 0], "position": [0, 0, 0]}],
                     "alpha": 1, "beta": 1, "delta": 0.1, "initial_controls": {"explicit": [[[1, 2, 3]]]}}
        }"#;
        let s = Scene::from_json_str(text).expect("valid");
        let b = s.material.bending.as_ref().expect("bending");
        assert_eq!(b.model, BendingModel::Distance);
        assert_eq!(b.stiffness, Stiffness::Finite(2.0));
        assert_eq!(s.rest_positions(), vec![[0.0, 0.0, 0.0]]);
        assert_eq!(s.initial_controls_array(), vec![vec![[1.0, 2.0, 3.0]]]);
        let Obstacle::Plane(p) = &s.obstacles[0] else {
            panic!("plane expected")
        };
        assert_eq!(p.normal, [0.0, 3.0, 4.0], "stored as written");
        assert_eq!(p.normalized(), [0.0, 0.6, 0.8]);
        assert!(p.role.is_safety() && p.role.is_collider());
        assert_eq!(Scene::from_json_str(&s.to_json_pretty()).expect("rt"), s);
    }

    #[test]
    fn zero_right_allowed_for_single_column() {
        let mut v = base_value();
        set(&mut v, "/cloth/cols", json!(1));
        set(&mut v, "/cloth/right", json!([0.0, 0.0, 0.0]));
        set(&mut v, "/controls", json!([[0, 0]]));
        set(
            &mut v,
            "/task/targets",
            json!([{"particle": [9, 0], "position": [0, 0, 0]}]),
        );
        set(&mut v, "/task/initial_controls", json!("zeros"));
        let s = Scene::from_json_str(&v.to_string()).expect("valid");
        let x = s.rest_positions();
        assert_eq!(x.len(), 10);
        assert_eq!(x[9], [-0.5, -1.5, 1.0]);
        assert_eq!(s.mesh().stretch_edges().len(), 9);
    }

    #[test]
    fn no_controls_is_allowed() {
        let mut v = base_value();
        set(&mut v, "/controls", json!([]));
        set(&mut v, "/task/initial_controls", json!({"constant": []}));
        let s = Scene::from_json_str(&v.to_string()).expect("valid");
        assert_eq!(s.initial_controls_array().len(), 10);
        assert!(s.initial_controls_array().iter().all(Vec::is_empty));
    }

    #[test]
    fn stiffness_compliance_and_value() {
        let k = Stiffness::Finite(1e4);
        assert_eq!(k.value(), 1e4);
        assert_eq!(k.compliance(0.1), (1.0 / 1e4) / (0.1 * 0.1));
        assert!((k.compliance(0.1) - 0.01).abs() < 1e-17);
        assert_eq!(Stiffness::Finite(1e2).compliance(0.1), 0.9999999999999998);
        assert!(!k.is_infinite() && Stiffness::Infinite.is_infinite());
        assert_eq!(Stiffness::Infinite.compliance(0.1), 0.0);
        assert_eq!(Stiffness::Infinite.value(), f64::INFINITY);
        let parsed: Stiffness = serde_json::from_str("25").expect("int");
        assert_eq!(parsed, Stiffness::Finite(25.0));
        let parsed: Stiffness = serde_json::from_str("\"inf\"").expect("inf");
        assert_eq!(parsed, Stiffness::Infinite);
        assert!(serde_json::from_str::<Stiffness>("\"Infinity\"").is_err());
        assert!(serde_json::from_str::<Stiffness>("null").is_err());
    }

    #[test]
    fn json_floats_read_back_bit_identically() {
        // Values serde_json misreads by one ulp without `float_roundtrip`.
        let xs: [f64; 5] = [
            1.0833333333333335,
            0.6666666666666667,
            0.1 + 0.2,
            1e-300,
            -2.5e17,
        ];
        let text = to_json_pretty_compact(&xs.to_vec()).unwrap();
        let back: Vec<f64> = serde_json::from_str(&text).unwrap();
        for (x, y) in xs.iter().zip(&back) {
            assert_eq!(x.to_bits(), y.to_bits(), "{x} read back as {y}");
        }
    }

    #[test]
    fn inline_arrays_only_when_scalar() {
        let text = to_json_pretty_compact(
            &json!({"a": [1.5, 2, 3], "b": [[1, 2], [3, 4]], "c": ["x", "[y]"],
                                                "d": []}),
        )
        .expect("json");
        assert!(text.contains("\"a\": [1.5, 2, 3]"), "{text}");
        assert!(text.contains("[1, 2]") && text.contains("[3, 4]"), "{text}");
        assert!(text.contains("\"[y]\""), "{text}");
        let back: Value = serde_json::from_str(&text).expect("valid");
        assert_eq!(back["c"][1], "[y]");
        assert_eq!(back["d"], json!([]));
    }

    #[test]
    fn roles() {
        assert!(ObstacleRole::Safety.is_safety() && !ObstacleRole::Safety.is_collider());
        assert!(!ObstacleRole::Collider.is_safety() && ObstacleRole::Collider.is_collider());
        assert!(ObstacleRole::Both.is_safety() && ObstacleRole::Both.is_collider());
    }

    // --- built-in scenes ---
    #[test]
    fn builtins_round_trip() {
        for &(name, description) in Scene::builtin_names() {
            let s = Scene::builtin(name).expect("builtin valid");
            assert_eq!(s.name, name);
            assert_eq!(s.description, description);
            let text = s.to_json_pretty();
            let back = Scene::from_json_str(&text).expect("round trip parses");
            assert_eq!(back, s, "{name}");
            assert_eq!(back.to_json_pretty(), text);
        }
        assert_eq!(
            Scene::builtin_names()
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>(),
            ["u_obstacle", "swing", "drop"]
        );
    }

    fn check_common(s: &Scene, y0: f64, z_top: f64) {
        assert_eq!((s.cloth.rows, s.cloth.cols), (10, 10));
        assert_eq!(s.cloth.particle_mass, 1.0);
        assert_eq!(s.material.stretch, Stiffness::Finite(1e4));
        assert_eq!(
            s.material.bending,
            Some(Bending {
                model: BendingModel::Distance,
                stiffness: Stiffness::Finite(1e2)
            })
        );
        assert_eq!(s.physics.dt, 0.1);
        assert_eq!(s.physics.gravity, [0.0, 0.0, -9.8]);
        assert_eq!(s.physics.iterations, 100);
        assert_eq!(s.task.horizon, 10);
        assert_eq!(s.controls, vec![[0, 0], [0, 9]]);
        assert_eq!(s.control_indices(), vec![0, 9]);
        // rest positions bit-exact against the spec formula
        let x = s.rest_positions();
        assert_eq!(x.len(), 100);
        for r in 0..10 {
            for c in 0..10 {
                let expect = [-0.5 + c as f64 / 9.0, y0, z_top - r as f64 / 9.0];
                assert_eq!(x[r * 10 + c], expect, "particle ({r}, {c})");
            }
        }
    }

    #[test]
    fn builtin_u_obstacle_matches_spec() {
        let s = Scene::builtin("u_obstacle").expect("builtin");
        check_common(&s, -1.5, 2.0);
        assert_eq!(s.obstacles.len(), 1);
        let Obstacle::Spheres(sp) = &s.obstacles[0] else {
            panic!("spheres expected")
        };
        assert_eq!(sp.role, ObstacleRole::Safety);
        // recompute the 18 centres from the formula (exact comparison)
        let mut centers = Vec::new();
        for x in [-0.75, 0.75] {
            for k in 0..7 {
                centers.push([x, 0.0, 0.25 + k as f64 * (2.5 / 6.0)]);
            }
        }
        for x in [-0.45, -0.15, 0.15, 0.45] {
            centers.push([x, 0.0, 0.25]);
        }
        assert_eq!(sp.centers, centers);
        assert_eq!(sp.radii, vec![0.25; 18]);
        // targets: bottom row to (-0.5 + c/9, 1.5, 1.0)
        assert_eq!(s.target_indices(), (90..100).collect::<Vec<_>>());
        let expect: Vec<[f64; 3]> = (0..10).map(|c| [-0.5 + c as f64 / 9.0, 1.5, 1.0]).collect();
        assert_eq!(s.target_positions(), expect);
        assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (1.0, 1e-4, 0.2));
        assert_eq!(
            s.initial_controls_array(),
            vec![vec![[0.0, 0.3, 0.0]; 2]; 10]
        );
    }

    #[test]
    fn builtin_swing_matches_spec() {
        let s = Scene::builtin("swing").expect("builtin");
        check_common(&s, -1.5, 2.0);
        assert!(s.obstacles.is_empty());
        assert_eq!(s.target_indices(), (90..100).collect::<Vec<_>>());
        let expect: Vec<[f64; 3]> = (0..10).map(|c| [-0.5 + c as f64 / 9.0, 1.0, 1.5]).collect();
        assert_eq!(s.target_positions(), expect);
        assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (1.0, 1e-5, 0.0));
        assert_eq!(s.task.initial_controls, InitialControls::Zeros);
        assert_eq!(s.initial_controls_array(), vec![vec![[0.0; 3]; 2]; 10]);
    }

    #[test]
    fn builtin_drop_matches_spec() {
        let s = Scene::builtin("drop").expect("builtin");
        check_common(&s, 0.0, 1.5);
        assert_eq!(
            s.obstacles,
            vec![Obstacle::Plane(Plane {
                point: [0.0, 0.0, 0.0],
                normal: [0.0, 0.0, 1.0],
                role: ObstacleRole::Collider
            })]
        );
        assert_eq!(s.target_indices(), vec![0, 9, 90, 99]);
        assert_eq!(
            s.target_positions(),
            vec![
                [-0.5, 0.5, 0.0],
                [0.5, 0.5, 0.0],
                [-0.5, -0.5, 0.0],
                [0.5, -0.5, 0.0]
            ]
        );
        assert_eq!((s.task.alpha, s.task.beta, s.task.delta), (0.1, 1e-5, 0.0));
        assert_eq!(s.task.initial_controls, InitialControls::Zeros);
    }

    #[test]
    fn builtin_meshes_have_canonical_counts() {
        for &(name, _) in Scene::builtin_names() {
            let m = Scene::builtin(name).expect("builtin").mesh();
            assert_eq!(m.n_particles(), 100);
            assert_eq!(m.stretch_edges().len(), 261);
            assert_eq!(m.bending_pairs().len(), 225);
        }
    }

    #[test]
    fn non_square_rest_positions() {
        let mut s = Scene::builtin("swing").expect("builtin");
        s.cloth.rows = 3;
        s.cloth.cols = 5;
        s.cloth.top_left = [1.0, 2.0, 3.0];
        s.cloth.right = [4.0, 0.0, 0.0];
        s.cloth.down = [0.0, -2.0, 0.0];
        s.controls = vec![[0, 0], [0, 4]];
        s.task.targets = vec![Target {
            particle: [2, 4],
            position: [0.0; 3],
        }];
        s.validate().expect("valid");
        let x = s.rest_positions();
        assert_eq!(x.len(), 15);
        assert_eq!(x[0], [1.0, 2.0, 3.0]);
        assert_eq!(x[4], [5.0, 2.0, 3.0]);
        assert_eq!(x[10], [1.0, 0.0, 3.0]);
        assert_eq!(x[14], [5.0, 0.0, 3.0]);
        assert_eq!(x[7], [3.0, 1.0, 3.0]);
        assert_eq!(s.target_indices(), vec![14]);
    }
}
