//! Building a [`Model`] from a scene, the cloth placed where it starts: its rest shape, or
//! `cloth.initial_state` — positions given in the scene or an OBJ, or a recipe the simulator
//! runs first (hold some particles, move them, let go, let the cloth settle).
//!
//! A start is checked before it is used: no particle inside a collider, the cloth not passing
//! through itself (edge–triangle intersections), and under Newton's self-contact its layers
//! farther apart than the thickness. A start that is not at rest — one step of the scene's own
//! physics with the grippers held moves a particle by more than [`REST_TOLERANCE`] of the
//! cloth's longest side — is settled by such steps until it is (at most
//! `cloth.initial_state.settle_steps`; without cloth–cloth friction, [`settle`]), or refused with
//! `"settle": false`; what settling did is [`Model::start_report`], never silent.

use crate::contact::crossings::intersections;
use crate::error::ClothError;
use crate::model::{Model, StartReport};
use crate::registry::ConstraintRegistry;
use crate::scene::{InitialControls, InitialState, Limits, Recipe, Scene, SceneError};
use autodiff::Tensor;
use std::sync::Arc;

/// The largest move of any particle, as a fraction of the cloth's longest side, in one step of
/// a state at rest.
pub const REST_TOLERANCE: f64 = 1e-6;

impl Model {
    /// Compiles a validated scene, its cloth placed at its start (module docs). A scene with
    /// `custom_constraints` needs their types: [`Model::from_scene_with`].
    ///
    /// # Errors
    /// An invalid scene; a start inside a collider, through itself, that cannot rest, or that
    /// is not at rest with `"settle": false` (errors name `cloth.initial_state`); a recipe whose
    /// simulation fails.
    pub fn from_scene(scene: &Scene) -> Result<Model, ClothError> {
        Model::from_scene_with(scene, &ConstraintRegistry::new())
    }

    /// [`Model::from_scene`] for a scene whose `custom_constraints` use the types in `registry`.
    ///
    /// # Errors
    /// As [`Model::from_scene`].
    pub fn from_scene_with(
        scene: &Scene,
        registry: &ConstraintRegistry,
    ) -> Result<Model, ClothError> {
        let Some(state) = &scene.cloth.initial_state else {
            return compiled(scene, registry, None);
        };
        let (source, given, recipe_steps) = match (&state.recipe, state.given()) {
            (Some(phases), _) => {
                let (mut x, mut steps) = (scene.rest_positions(), 0);
                for (i, phase) in phases.iter().enumerate() {
                    let (end, taken) = run_phase(scene, registry, phase, &x, state)
                        .map_err(|e| invalid(format!("recipe[{i}]: {e}")))?;
                    (x, steps) = (end, steps + taken);
                }
                ("recipe", x, steps)
            }
            (None, Some(x)) => {
                let source = if state.positions.is_some() {
                    "positions"
                } else {
                    "obj"
                };
                (source, x.to_vec(), 0)
            }
            (None, None) => unreachable!("validation requires one source"),
        };
        check_start(scene, &given, source)?;
        if source == "recipe" {
            scene.check_grippers_at(&given)?;
        }
        let mut model = compiled(scene, registry, Some(&given))?;
        let placed = model.start.clone();
        let lifted = (0..model.n_particles())
            .filter(|&p| (0..3).any(|k| placed.get(p, k) != given[p][k]))
            .count();
        let tolerance = REST_TOLERANCE * scene.longest_side().max(f64::MIN_POSITIVE);
        let settled = settle(&model, placed, state.max_settle_steps(), tolerance)?;
        if settled.steps > 0 && !state.settle {
            return Err(invalid(format!(
                "not at rest: one step of the scene's physics with the grippers held moves \
                 particle {} by {:.3e} (more than {tolerance:.1e}); give a state at rest, or set \
                 cloth.initial_state.settle to true to settle it",
                settled.first_move.1, settled.first_move.0
            )));
        }
        model.start = settled.state;
        model.start_report = Some(StartReport {
            source,
            recipe_steps,
            settle_steps: settled.steps,
            lifted,
            moved: largest_move_from(&given, &model.start),
        });
        Ok(model)
    }
}

/// The scene's built-in effects compiled with the cloth at `start`, then its custom
/// constraints.
fn compiled(
    scene: &Scene,
    registry: &ConstraintRegistry,
    start: Option<&[[f64; 3]]>,
) -> Result<Model, ClothError> {
    let mut model = Model::compile(scene, start)?;
    registry.apply(&mut model, scene)?;
    Ok(model)
}

fn invalid(reason: String) -> ClothError {
    SceneError::Invalid {
        field: "cloth.initial_state".into(),
        reason,
    }
    .into()
}

/// A recipe phase's end: the cloth from `from` with `recipe.hold` held and moved by
/// `recipe.moves` for `recipe.steps` steps, then let go (nothing held) and settled. Returns the
/// state and the steps taken (held and settling); an error says what failed.
fn run_phase(
    scene: &Scene,
    registry: &ConstraintRegistry,
    recipe: &Recipe,
    from: &[[f64; 3]],
    state: &InitialState,
) -> Result<(Vec<[f64; 3]>, usize), String> {
    let failed = |what: &str, e: ClothError| match e {
        ClothError::Scene(SceneError::Invalid { reason, .. }) => format!("while {what}: {reason}"),
        e => format!("the simulation failed while {what}: {e}"),
    };
    let mut held = scene.clone();
    held.cloth.initial_state = None;
    held.controls = recipe.hold.clone();
    held.task.horizon = recipe.steps;
    held.task.initial_controls = InitialControls::Explicit(recipe.moves_array());
    held.task.limits = Limits::default();
    let model = compiled(&held, registry, Some(from)).map_err(|e| failed("compiling it", e))?;
    let states = model
        .simulate(&held.initial_controls())
        .map_err(|e| failed("moving the held particles", e))?;
    let end = states
        .last()
        .cloned()
        .unwrap_or_else(|| model.start.clone());
    let mut free = held;
    free.controls = Vec::new();
    free.task.horizon = 1;
    free.task.initial_controls = InitialControls::Zeros;
    let points = rows(&end);
    let model = compiled(&free, registry, Some(&points)).map_err(|e| failed("letting go", e))?;
    let tolerance = REST_TOLERANCE * scene.longest_side().max(f64::MIN_POSITIVE);
    let settled = settle(
        &model,
        model.start.clone(),
        state.max_settle_steps(),
        tolerance,
    )
    .map_err(|e| failed("settling after letting go", e))?;
    Ok((rows(&settled.state), recipe.steps + settled.steps))
}

/// Step 0 at `x` (in particle order, from `source`) keeps out of the colliders and does not pass
/// through itself.
fn check_start(scene: &Scene, x: &[[f64; 3]], source: &str) -> Result<(), ClothError> {
    let name = |p: usize| match scene.cloth.is_mesh() {
        true => format!("vertex {p}"),
        false => {
            let cols = scene.cloth.cols.max(1);
            format!("particle ({}, {})", p / cols, p % cols)
        }
    };
    for (i, obstacle) in scene.obstacles.iter().enumerate() {
        if !obstacle.role().is_collider() {
            continue;
        }
        let deepest = x
            .iter()
            .enumerate()
            .map(|(p, &q)| (p, obstacle.signed_distance(q)))
            .fold(None, |best: Option<(usize, f64)>, (p, d)| match best {
                Some((_, b)) if b <= d => best,
                _ => Some((p, d)),
            });
        if let Some((p, d)) = deepest.filter(|&(_, d)| d < 0.0) {
            return Err(invalid(format!(
                "{} starts {:.4e} inside obstacles[{i}] ({}), a collider ({source})",
                name(p),
                -d,
                obstacle.kind()
            )));
        }
    }
    let triangles = scene.mesh().triangles().to_vec();
    let crossing = intersections(&triangles, &Tensor::new(x.len(), 3, x.concat()));
    if let Some(&([a, b], t)) = crossing.first() {
        return Err(invalid(format!(
            "the cloth passes through itself ({source}): edge ({a}, {b}) crosses triangle {t} \
             {:?}, {} edge–triangle intersections in all",
            triangles[t],
            crossing.len()
        )));
    }
    Ok(())
}

/// A state settled by [`settle`].
struct Settled {
    /// The first state whose step moves no particle by more than the tolerance.
    state: Tensor,
    /// Steps taken to reach it (0: the start was at rest).
    steps: usize,
    /// The first step's largest move and its particle.
    first_move: (f64, usize),
}

/// Steps `model` (its grippers held) from `x` until a step moves no particle by more than
/// `tolerance`, at most `max_steps` times; an error names the particle still moving.
///
/// Without cloth–cloth friction: its lagged potential lets a loaded layer creep by a fraction of
/// its smoothing slip at every step, so a frictional cloth never meets the tolerance, while a
/// frictionless rest is a rest with friction too (no slip, no friction force).
fn settle(
    model: &Model,
    x: Tensor,
    max_steps: usize,
    tolerance: f64,
) -> Result<Settled, ClothError> {
    let mut one = model.clone();
    if let Some(b) = one.self_barrier.as_mut().filter(|b| b.friction.is_some()) {
        Arc::make_mut(b).friction = None;
    }
    one.task.horizon = 1;
    let zeros = one.zero_controls();
    let mut x = x;
    let mut first_move = (0.0, 0);
    for steps in 0..=max_steps {
        one.start = x.clone();
        let next = one.simulate(&zeros)?.pop().expect("a one-step rollout");
        let moved = largest_move_from(&rows(&x), &next);
        if steps == 0 {
            first_move = moved;
        }
        if moved.0 <= tolerance {
            return Ok(Settled {
                state: x,
                steps,
                first_move,
            });
        }
        if steps == max_steps {
            return Err(invalid(format!(
                "it cannot rest where it is: after {max_steps} settling steps (the grippers \
                 held) a step still moves particle {} by {:.3e} (tolerance {tolerance:.1e}); \
                 nothing holds the cloth up, or raise cloth.initial_state.settle_steps",
                moved.1, moved.0
            )));
        }
        x = next;
    }
    unreachable!("the loop returns by its last step")
}

/// The largest distance between `from` and `to`'s rows, and its particle.
fn largest_move_from(from: &[[f64; 3]], to: &Tensor) -> (f64, usize) {
    from.iter()
        .enumerate()
        .map(|(p, a)| {
            let d = (0..3).map(|k| (to.get(p, k) - a[k]).powi(2)).sum::<f64>();
            (d.sqrt(), p)
        })
        .fold((0.0, 0), |best, m| if m.0 > best.0 { m } else { best })
}

/// A state's rows as points.
fn rows(x: &Tensor) -> Vec<[f64; 3]> {
    x.data()
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect()
}
