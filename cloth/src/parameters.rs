//! The physical parameters a fit varies, each a scale factor on a scene's values.
//!
//! A parameter multiplies every value of its kind in the scene: `stretch` the stretch
//! stiffness, `bending` the bending stiffness, a custom constraint type's name the stiffness of
//! every entry of that type, `mass` the particle mass, `gravity` gravity's vector and `friction`
//! every collider's coefficient and the cloth's own (`physics.self_collision.friction`).
//! Derivatives are taken with respect to the logarithm of that factor
//! ([`Model::parameter_tangents`]): positive values stay positive, and scenes whose entries
//! differ (two colliders with different `μ`) scale together.
//!
//! Two things are held fixed when a parameter changes, so that the derivative is the model's
//! and a fitted scene reproduces the fitted model: the cloth's start (step 0, [`Model::start`]),
//! and smooth contact's barrier stiffness `κ`, whose default depends on the mass and gravity
//! ([`Parameter::pin_contact`] writes the compiled value into the scene).

use crate::controls::Controls;
use crate::error::ClothError;
use crate::model::Model;
use crate::scene::{ContactModel, ContactSpec, Scene, SceneError, Stiffness};
use crate::xpbd::set::Carry;
use autodiff::Tensor;
use std::fmt;

/// A physical parameter of a scene, as a scale factor on its values.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Parameter {
    /// The stiffness of every constraint group of this name: `stretch`, `bending`, or a custom
    /// constraint type's.
    Stiffness(String),
    /// The mass of every particle (the cloth's area density).
    Mass,
    /// Gravity's magnitude.
    Gravity,
    /// The friction coefficient of every collider and of the cloth on itself.
    Friction,
}

impl fmt::Display for Parameter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Parameter::Stiffness(name) => f.write_str(name),
            Parameter::Mass => f.write_str("mass"),
            Parameter::Gravity => f.write_str("gravity"),
            Parameter::Friction => f.write_str("friction"),
        }
    }
}

impl Parameter {
    /// The parameter called `name`: `mass`, `gravity`, `friction`, or a constraint group's name.
    pub fn parse(name: &str) -> Parameter {
        match name {
            "mass" => Parameter::Mass,
            "gravity" => Parameter::Gravity,
            "friction" => Parameter::Friction,
            other => Parameter::Stiffness(other.to_string()),
        }
    }

    /// The scene field this parameter's value is read from (its first, when it scales several).
    pub fn field(&self, scene: &Scene) -> String {
        match self {
            Parameter::Stiffness(name) if name == "stretch" => "material.stretch".into(),
            Parameter::Stiffness(name) if name == "bending" => "material.bending.stiffness".into(),
            Parameter::Stiffness(name) => match custom_entries(scene, name).first() {
                Some(i) => format!("custom_constraints[{i}].stiffness"),
                None => format!("custom_constraints (type `{name}`)"),
            },
            Parameter::Mass => "cloth.particle_mass".into(),
            Parameter::Gravity => "physics.gravity".into(),
            Parameter::Friction => match frictional(scene).first() {
                Some(i) => format!("obstacles[{i}].friction"),
                None if self_friction(scene).is_some() => "physics.self_collision.friction".into(),
                None => "obstacles[].friction".into(),
            },
        }
    }

    /// The parameter's value in `scene`: the stiffness, the particle mass, `|g|`, or `μ` (the
    /// first entry's where it scales several).
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field when the scene has nothing this parameter
    /// scales, or only rigid (`"inf"`) or zero values of it: a factor cannot move them.
    pub fn value(&self, scene: &Scene) -> Result<f64, ClothError> {
        let missing = |reason: String| -> ClothError {
            SceneError::Invalid {
                field: self.field(scene),
                reason,
            }
            .into()
        };
        let finite = |k: &Stiffness, what: &str| -> Result<f64, ClothError> {
            match k {
                Stiffness::Finite(v) => Ok(*v),
                Stiffness::Infinite => Err(missing(format!(
                    "the {what} stiffness is rigid (\"inf\"): it has no finite value to fit"
                ))),
            }
        };
        match self {
            Parameter::Stiffness(name) if name == "stretch" => {
                finite(&scene.material.stretch, "stretch")
            }
            Parameter::Stiffness(name) if name == "bending" => match &scene.material.bending {
                Some(b) => finite(&b.stiffness, "bending"),
                None => Err(missing("the scene has no bending to fit".into())),
            },
            Parameter::Stiffness(name) => match custom_entries(scene, name).first() {
                Some(&i) => finite(&scene.custom_constraints[i].stiffness, name),
                None => Err(missing(format!(
                    "no parameter `{name}`: it is none of stretch, bending, mass, gravity, \
                     friction, and no custom constraint has that type"
                ))),
            },
            Parameter::Mass => Ok(scene.cloth.particle_mass),
            Parameter::Gravity => {
                let g = norm(scene.physics.gravity);
                if g > 0.0 {
                    Ok(g)
                } else {
                    Err(missing("the scene has no gravity to scale".into()))
                }
            }
            Parameter::Friction => match (frictional(scene).first(), self_friction(scene)) {
                (Some(&i), _) => Ok(scene.obstacles[i].friction().unwrap_or(0.0)),
                (None, Some(mu)) => Ok(mu),
                (None, None) => Err(missing(
                    "neither a collider nor the cloth itself has friction > 0: give the \
                     colliders or physics.self_collision a friction coefficient to start the fit \
                     from"
                        .into(),
                )),
            },
        }
    }

    /// Multiplies every value this parameter scales in `scene` by `factor` (> 0).
    ///
    /// # Errors
    /// As [`Parameter::value`].
    pub fn scale(&self, scene: &mut Scene, factor: f64) -> Result<(), ClothError> {
        self.value(scene)?;
        let times = |k: &mut Stiffness| {
            if let Stiffness::Finite(v) = k {
                *v *= factor;
            }
        };
        match self {
            Parameter::Stiffness(name) if name == "stretch" => times(&mut scene.material.stretch),
            Parameter::Stiffness(name) if name == "bending" => {
                if let Some(b) = scene.material.bending.as_mut() {
                    times(&mut b.stiffness);
                }
            }
            Parameter::Stiffness(name) => {
                for i in custom_entries(scene, name) {
                    times(&mut scene.custom_constraints[i].stiffness);
                }
            }
            Parameter::Mass => scene.cloth.particle_mass *= factor,
            Parameter::Gravity => scene.physics.gravity = scene.physics.gravity.map(|g| g * factor),
            Parameter::Friction => {
                for i in frictional(scene) {
                    scene.obstacles[i].scale_friction(factor);
                }
                if let Some(sc) = scene.physics.self_collision.as_mut() {
                    sc.friction = sc.friction.map(|mu| mu * factor);
                }
            }
        }
        Ok(())
    }

    /// `scene` with each of `params` scaled by its factor in `factors`, in order
    /// ([`Parameter::scale`]).
    ///
    /// # Errors
    /// As [`Parameter::scale`].
    pub fn scaled(
        scene: &Scene,
        params: &[Parameter],
        factors: impl IntoIterator<Item = f64>,
    ) -> Result<Scene, ClothError> {
        let mut scaled = scene.clone();
        for (p, factor) in params.iter().zip(factors) {
            p.scale(&mut scaled, factor)?;
        }
        Ok(scaled)
    }

    /// Writes the compiled barrier's `d̂` and stiffness `κ` of `model` (compiled from `scene`;
    /// smooth contact's, or else self-contact's under Newton without colliders) into `scene`'s
    /// `physics.contact`, so that scaling the mass or gravity leaves them where they are; returns
    /// whether the barrier's stiffness is now the scene's own. Nothing without a barrier (true);
    /// values the scene sets itself stay. False for self-contact beside rigid colliders, whose
    /// scene cannot hold the barrier's settings: its `κ` follows the mass and gravity.
    pub fn pin_contact(scene: &mut Scene, model: &Model) -> bool {
        let barrier = match (&model.contact_barrier, &model.self_barrier) {
            (Some(b), _) => b.barrier,
            // Self-contact alone: the smooth model's settings carry its barrier too, but turning
            // a scene's rigid colliders smooth would change its physics.
            (None, Some(b)) if model.colliders.is_empty() => b.barrier,
            (None, None) => return true,
            (None, Some(_)) => return false,
        };
        let spec = scene.physics.contact.get_or_insert(ContactSpec {
            model: ContactModel::Smooth,
            d_hat: None,
            stiffness: None,
            friction_epsilon: None,
        });
        spec.model = ContactModel::Smooth;
        spec.d_hat.get_or_insert(barrier.d_hat);
        spec.stiffness.get_or_insert(barrier.kappa);
        true
    }
}

impl Model {
    /// `∂x_t/∂ log θ_p` for every step `t` (0 at step 0: the start is held fixed) and parameter
    /// `p`, of the rollout `states` of `controls` (simulated by this model): `result[t][p]`,
    /// `N × 3`. Under Newton by the implicit function theorem at each step's minimizer
    /// (`newton/sensitivity.rs`), under XPBD through the unrolled sweeps
    /// (`xpbd/sensitivity.rs`); the controls are held fixed.
    ///
    /// # Errors
    /// [`ClothError::ParameterDerivative`] for a parameter the model has nothing of;
    /// [`ClothError::NewtonSaddle`] where a Newton step's exact Hessian is not positive definite.
    pub fn parameter_tangents(
        &self,
        states: &[Tensor],
        controls: &Controls,
        params: &[Parameter],
    ) -> Result<Vec<Vec<Tensor>>, ClothError> {
        self.check_controls(controls)?;
        if states.len() != self.task.horizon + 1 {
            return Err(ClothError::ParameterDerivative(format!(
                "{} states for a horizon of {} steps",
                states.len(),
                self.task.horizon
            )));
        }
        for p in params {
            self.check_parameter(p)?;
        }
        match self.solver {
            crate::Solver::Newton(_) => self.newton_parameter_tangents(states, controls, params),
            crate::Solver::Xpbd => Ok(self.xpbd_parameter_tangents(states, controls, params)),
        }
    }

    /// Whether the model has something `p` scales: a group of that name with a finite
    /// stiffness, gravity, or friction (smooth contact's or the cloth's on itself under Newton,
    /// the friction rows under XPBD).
    fn check_parameter(&self, p: &Parameter) -> Result<(), ClothError> {
        let has = match p {
            Parameter::Stiffness(name) => {
                (self.groups.iter()).any(|g| &g.name == name && g.terms.compliance() > 0.0)
            }
            Parameter::Mass => true,
            Parameter::Gravity => self.gravity_step.is_some(),
            Parameter::Friction => match self.solver {
                crate::Solver::Newton(_) => {
                    (self.contact_barrier.as_ref()).is_some_and(|b| b.friction.is_some())
                        || (self.self_barrier.as_ref()).is_some_and(|b| b.friction.is_some())
                }
                crate::Solver::Xpbd => self.sets().any(|s| s.carry != Carry::Multiplier),
            },
        };
        if has {
            Ok(())
        } else {
            Err(ClothError::ParameterDerivative(format!(
                "the model has no `{p}` to vary (a group of that name with a finite stiffness, \
                 gravity, or a collider or the cloth itself with friction > 0)"
            )))
        }
    }
}

/// The indices of the custom constraint entries of type `name` with a finite stiffness.
fn custom_entries(scene: &Scene, name: &str) -> Vec<usize> {
    (scene.custom_constraints.iter().enumerate())
        .filter(|(_, c)| c.kind == name && !c.stiffness.is_infinite())
        .map(|(i, _)| i)
        .collect()
}

/// The indices of the colliders with friction > 0.
fn frictional(scene: &Scene) -> Vec<usize> {
    (scene.obstacles.iter().enumerate())
        .filter(|(_, o)| o.role().is_collider() && o.friction().unwrap_or(0.0) > 0.0)
        .map(|(i, _)| i)
        .collect()
}

/// The cloth–cloth friction coefficient `physics.self_collision.friction`, when it is > 0.
fn self_friction(scene: &Scene) -> Option<f64> {
    (scene.physics.self_collision.as_ref())
        .and_then(|sc| sc.friction)
        .filter(|&mu| mu > 0.0)
}

fn norm(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
