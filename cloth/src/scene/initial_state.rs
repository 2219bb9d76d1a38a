//! `cloth.initial_state`: where the cloth is at step 0, apart from its rest shape — positions
//! given in the scene, read from an OBJ file in the cloth's vertex order, or made by a recipe the
//! simulator runs from the rest shape (`crate::start` places, checks and settles it).

use serde::{Deserialize, Serialize};

use super::format::{InitialControls, ParticleRef};
use super::validate::check_vec3;
use super::{invalid, Scene, SceneError, MAX_HORIZON};

/// Default of `cloth.initial_state.settle_steps`.
pub const DEFAULT_SETTLE_STEPS: usize = 500;

/// `cloth.initial_state`: exactly one of `obj`, `positions` and `recipe`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialState {
    /// An OBJ file (relative to the scene file) whose `v` lines are the particles' positions in
    /// particle order (a grid's `r·cols + c`, a mesh cloth's vertex order); its faces are not
    /// read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj: Option<String>,
    /// The particles' positions in particle order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub positions: Option<Vec<[f64; 3]>>,
    /// A recipe the simulator runs from the rest shape, phase after phase, whose settled end is
    /// the start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recipe: Option<Vec<Recipe>>,
    /// What to do with a start that is not at rest (a step of the scene's physics moves it):
    /// settle it by quasi-static steps with the grippers held (true, the default), or refuse it.
    #[serde(default = "settle_default", skip_serializing_if = "is_true")]
    pub settle: bool,
    /// The most quasi-static steps settling may take before the start counts as one that cannot
    /// rest (default [`DEFAULT_SETTLE_STEPS`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_steps: Option<usize>,
    /// The positions read from `obj` when the scene was loaded ([`Scene::load_files`]).
    #[serde(skip)]
    pub obj_data: Option<Vec<[f64; 3]>>,
}

fn settle_default() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

/// One phase of `cloth.initial_state.recipe`: hold some particles, move them step by step under
/// the scene's physics, then let go and let the cloth settle (a towel's corner lifted and laid
/// over it folds it; phase after phase, the folds pile up).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// The particles held while moving (`[r, c]` or vertex indices), none twice.
    pub hold: Vec<ParticleRef>,
    /// How many steps they move.
    pub steps: usize,
    /// Their displacement per step, in the form of `task.initial_controls` (`"zeros"`,
    /// `{"constant": …}`, `{"explicit": …}` with `steps` entries), one vector per held particle.
    pub moves: InitialControls,
}

impl InitialState {
    /// Positions given with the scene (`positions`, or `obj` once read); `None` for a recipe,
    /// whose positions the simulator makes.
    pub fn given(&self) -> Option<&[[f64; 3]]> {
        self.positions.as_deref().or(self.obj_data.as_deref())
    }

    /// The most settling steps ([`InitialState::settle_steps`] or its default).
    pub fn max_settle_steps(&self) -> usize {
        self.settle_steps.unwrap_or(DEFAULT_SETTLE_STEPS)
    }
}

impl Recipe {
    /// The held particles' displacements per step (`steps × hold`), as `task.initial_controls`
    /// spells them for a horizon of `steps`.
    pub fn moves_array(&self) -> Vec<Vec<[f64; 3]>> {
        match &self.moves {
            InitialControls::Zeros => vec![vec![[0.0; 3]; self.hold.len()]; self.steps],
            InitialControls::Constant(v) => vec![v.clone(); self.steps],
            InitialControls::Explicit(steps) => steps.clone(),
        }
    }
}

impl Scene {
    /// `cloth.initial_state`: one source, as many positions as particles (finite, bounded), a
    /// recipe's held particles on the cloth and its moves of the right shape.
    pub(super) fn validate_initial_state(&self) -> Result<(), SceneError> {
        let Some(s) = &self.cloth.initial_state else {
            return Ok(());
        };
        let field = "cloth.initial_state";
        let sources = [s.obj.is_some(), s.positions.is_some(), s.recipe.is_some()];
        if sources.iter().filter(|&&g| g).count() != 1 {
            return Err(invalid(
                field,
                "give exactly one of `obj`, `positions` and `recipe`",
            ));
        }
        if s.settle_steps == Some(0) {
            return Err(invalid(
                "cloth.initial_state.settle_steps",
                "must be at least 1, got 0",
            ));
        }
        let n = self.n_particles();
        if let Some((name, positions)) = (s.positions.as_deref().map(|p| ("positions", p)))
            .or_else(|| s.obj_data.as_deref().map(|p| ("obj", p)))
        {
            let what = match name {
                "obj" => format!(
                    "`{}` has {} vertices",
                    s.obj.as_deref().unwrap_or_default(),
                    positions.len()
                ),
                _ => format!("{} positions are given", positions.len()),
            };
            if positions.len() != n {
                return Err(invalid(
                    format!("{field}.{name}"),
                    format!("{what}, the cloth has {n} particles"),
                ));
            }
            for (p, x) in positions.iter().enumerate() {
                check_vec3(&format!("{field}.{name}[{p}]"), x)?;
            }
        } else if s.obj.is_some() {
            return Err(invalid(
                format!("{field}.obj"),
                "the file has not been read (Scene::load and Scene::from_json_str read it; a \
                 scene built in code calls Scene::load_files)",
            ));
        }
        if let Some(phases) = &s.recipe {
            if phases.is_empty() {
                return Err(invalid(
                    "cloth.initial_state.recipe",
                    "give at least one phase",
                ));
            }
            for (i, r) in phases.iter().enumerate() {
                self.validate_recipe(r, &format!("cloth.initial_state.recipe[{i}]"))?;
            }
        }
        Ok(())
    }

    fn validate_recipe(&self, r: &Recipe, field: &str) -> Result<(), SceneError> {
        for (i, &p) in r.hold.iter().enumerate() {
            let at = format!("{field}.hold[{i}]");
            self.check_particle(&at, p)?;
            if r.hold[..i].contains(&p) {
                return Err(invalid(at, format!("particle {p} is held twice")));
            }
        }
        if !(1..=MAX_HORIZON).contains(&r.steps) {
            return Err(invalid(
                format!("{field}.steps"),
                format!("must be in 1..={MAX_HORIZON}, got {}", r.steps),
            ));
        }
        let per_step = |v: &[[f64; 3]], at: &str| -> Result<(), SceneError> {
            if v.len() != r.hold.len() {
                return Err(invalid(
                    at,
                    format!("{} vectors for {} held particles", v.len(), r.hold.len()),
                ));
            }
            for (k, x) in v.iter().enumerate() {
                check_vec3(&format!("{at}[{k}]"), x)?;
            }
            Ok(())
        };
        match &r.moves {
            InitialControls::Zeros => Ok(()),
            InitialControls::Constant(v) => per_step(v, &format!("{field}.moves.constant")),
            InitialControls::Explicit(steps) => {
                if steps.len() != r.steps {
                    return Err(invalid(
                        format!("{field}.moves.explicit"),
                        format!("{} steps given, {field}.steps is {}", steps.len(), r.steps),
                    ));
                }
                for (t, v) in steps.iter().enumerate() {
                    per_step(v, &format!("{field}.moves.explicit[{t}]"))?;
                }
                Ok(())
            }
        }
    }
}
