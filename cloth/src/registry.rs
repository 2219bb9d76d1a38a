//! Constraint types a user's crate registers by name, so that scene files can use them.
//!
//! A scene's `custom_constraints` lists constraints of registered types:
//!
//! ```json
//! "custom_constraints": [
//!   {"type": "triangle_area", "particles": [[0, 0], [0, 1], [1, 1], ...], "stiffness": 1e6,
//!    "params": {...}}
//! ]
//! ```
//!
//! `particles` holds the particles of every instance in order, `ARITY` of them each (instance `i` is
//! `particles[ARITY·i .. ARITY·(i+1)]`); `params` is any JSON the type's builder reads. Register a
//! [`Constraint`] type with a builder that makes it from a [`CustomInput`], then compile the scene with
//! [`Model::from_scene_with`]:
//!
//! ```
//! use cloth::constraint::{norm, Constraint};
//! use cloth::nalgebra::Vector3;
//! use cloth::ConstraintRegistry;
//! use cloth::{Model, Scene};
//!
//! /// Keeps each pair of particles at `params.length`.
//! struct Tether(f64);
//! impl Constraint for Tether {
//!     const ARITY: usize = 2;
//!     fn c<R: autodiff::Real>(&self, _: usize, p: &[Vector3<R>]) -> R {
//!         norm(&(p[1] - p[0])) - R::cst(self.0)
//!     }
//! }
//!
//! let mut registry = ConstraintRegistry::new();
//! registry.register("tether", |input| {
//!     let length = input.spec.params["length"].as_f64().ok_or("needs a number `length`")?;
//!     Ok(Tether(length))
//! });
//! let mut json: serde_json::Value = serde_json::from_str(&Scene::builtin("swing")?.to_json_pretty())?;
//! json["custom_constraints"] = serde_json::json!([
//!     {"type": "tether", "particles": [[0, 0], [9, 9]], "stiffness": 100.0, "params": {"length": 1.2}}
//! ]);
//! let scene = Scene::from_json_str(&json.to_string())?;
//! let model = Model::from_scene_with(&scene, &registry)?;
//! assert!(model.groups.iter().any(|g| g.name == "tether" && g.count == 1));
//! // Without the registry the type is unknown, and the error says where and what is known.
//! let err = Model::from_scene(&scene).err().unwrap().to_string();
//! assert!(err.starts_with("custom_constraints[0].type: unknown constraint type `tether`"), "{err}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::constraint::Constraint;
use crate::error::ClothError;
use crate::model::Model;
use crate::scene::{CustomConstraint, Scene, SceneError, Stiffness};
use std::collections::BTreeMap;

/// What a builder gets to make its constraint from one `custom_constraints` entry.
pub struct CustomInput<'a> {
    /// The whole scene.
    pub scene: &'a Scene,
    /// The entry.
    pub spec: &'a CustomConstraint,
    /// The entry's path in the scene, e.g. `custom_constraints[2]`, for error messages.
    pub field: String,
    /// Particle indices (`r·cols + c`) of the entry's particles, in order.
    pub particles: Vec<usize>,
    /// Rest positions of those particles, in the same order.
    pub rest: Vec<[f64; 3]>,
}

type Builder = Box<dyn Fn(&mut Model, &CustomInput) -> Result<(), ClothError> + Send + Sync>;

/// Named constraint types that scene files may reference in `custom_constraints`.
#[derive(Default)]
pub struct ConstraintRegistry {
    builders: BTreeMap<String, Builder>,
}

impl ConstraintRegistry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers (or replaces) the type `name`: `build` makes the constraint from an entry, or
    /// says what is wrong with it (reported under the entry's `params`).
    pub fn register<C, F>(&mut self, name: &str, build: F) -> &mut Self
    where
        C: Constraint,
        F: Fn(&CustomInput) -> Result<C, String> + Send + Sync + 'static,
    {
        let builder = move |model: &mut Model, input: &CustomInput| -> Result<(), ClothError> {
            let count = input.particles.len();
            if count == 0 || count % C::ARITY != 0 {
                return Err(invalid(
                    format!("{}.particles", input.field),
                    format!(
                        "{count} particles do not form groups of {} (the arity of `{}`)",
                        C::ARITY,
                        input.spec.kind
                    ),
                ));
            }
            let constraint = build(input)
                .map_err(|reason| invalid(format!("{}.params", input.field), reason))?;
            model.add_constraints(
                &input.spec.kind,
                constraint,
                input.particles.clone(),
                input.spec.stiffness.value(),
            )
        };
        self.builders.insert(name.to_string(), Box::new(builder));
        self
    }

    /// The registered names, sorted.
    pub fn names(&self) -> Vec<&str> {
        self.builders.keys().map(String::as_str).collect()
    }

    /// Adds the scene's `custom_constraints` to `model`, in order, after its built-in groups.
    ///
    /// # Errors
    /// An unknown type (naming `custom_constraints[i].type` and the registered names), a
    /// particle count that is not a multiple of the type's arity, a builder's rejection, or
    /// [`Model::add_constraints`]'s.
    pub fn apply(&self, model: &mut Model, scene: &Scene) -> Result<(), ClothError> {
        let rest = scene.rest_positions();
        for (i, spec) in scene.custom_constraints.iter().enumerate() {
            let field = format!("custom_constraints[{i}]");
            let Some(builder) = self.builders.get(&spec.kind) else {
                let known = if self.builders.is_empty() {
                    "none: compile the scene with Model::from_scene_with and a ConstraintRegistry"
                        .to_string()
                } else {
                    self.names().join(", ")
                };
                return Err(invalid(
                    format!("{field}.type"),
                    format!(
                        "unknown constraint type `{}` (registered: {known})",
                        spec.kind.escape_debug()
                    ),
                ));
            };
            let particles: Vec<usize> = spec
                .particles
                .iter()
                .map(|&[r, c]| r * scene.cloth.cols + c)
                .collect();
            let input = CustomInput {
                scene,
                spec,
                field,
                rest: particles.iter().map(|&p| rest[p]).collect(),
                particles,
            };
            builder(model, &input)?;
        }
        Ok(())
    }
}

fn invalid(field: String, reason: String) -> ClothError {
    ClothError::Scene(SceneError::Invalid { field, reason })
}

impl Scene {
    /// Checks `custom_constraints`: every particle on the grid, every stiffness valid with a
    /// finite compliance. The types are checked when a model is built ([`ConstraintRegistry::apply`]).
    pub(crate) fn validate_custom_constraints(&self) -> Result<(), SceneError> {
        if self.cloth.is_mesh() && !self.custom_constraints.is_empty() {
            return Err(SceneError::Invalid {
                field: "custom_constraints".into(),
                reason: "name particles as [row, col] of a grid cloth; a mesh cloth (cloth.mesh) \
                         does not support them yet"
                    .into(),
            });
        }
        for (i, spec) in self.custom_constraints.iter().enumerate() {
            let base = format!("custom_constraints[{i}]");
            for (j, &[r, c]) in spec.particles.iter().enumerate() {
                let (rows, cols) = (self.cloth.rows, self.cloth.cols);
                if r >= rows || c >= cols {
                    return Err(SceneError::Invalid {
                        field: format!("{base}.particles[{j}]"),
                        reason: format!(
                            "[{r}, {c}] is not on the {rows} × {cols} grid (cloth.rows × cloth.cols)"
                        ),
                    });
                }
            }
            let k = spec.stiffness;
            let ok = match k {
                Stiffness::Infinite => true,
                Stiffness::Finite(x) => {
                    x.is_finite() && x > 0.0 && k.compliance(self.physics.dt).is_finite()
                }
            };
            if !ok {
                return Err(SceneError::Invalid {
                    field: format!("{base}.stiffness"),
                    reason: format!(
                        "must be a positive number (or \"inf\") whose compliance 1/(k·dt²) is finite, got {}",
                        k.value()
                    ),
                });
            }
        }
        Ok(())
    }
}
