//! Targets the cloth cannot reach: a target inside a collider lies where no particle goes, so it
//! is said when the scene is loaded (a warning naming the target and the obstacle) instead of
//! after a planner has searched for it, and the verdict of a plan that misses it says why
//! ([`unreachable_targets`]). Targets for every particle that the cloth, put there with its
//! grippers held, does not rest in ask for a state no plan can end in ([`targets_rest`]).

use crate::result::target_errors;
use autodiff::Tensor;
use cloth::scene::Scene;
use cloth::sdf::SignedDistance;
use cloth::Model;
use nalgebra::Vector3;

/// A target inside a collider.
#[derive(Clone, Debug, PartialEq)]
pub struct BuriedTarget {
    /// Its index in target order.
    pub target: usize,
    /// Its particle.
    pub particle: usize,
    /// The collider it is deepest in: its index in `obstacles`.
    pub obstacle: usize,
    /// How deep (positive).
    pub depth: f64,
}

/// Every target inside a collider, with the collider it is deepest in.
pub fn buried_targets(scene: &Scene) -> Vec<BuriedTarget> {
    let particles = scene.target_indices();
    let positions = scene.target_positions();
    let mut buried = Vec::new();
    for (target, (&particle, &at)) in particles.iter().zip(&positions).enumerate() {
        let deepest = (scene.obstacles.iter().enumerate())
            .filter(|(_, o)| o.role().is_collider())
            .map(|(i, o)| (i, -o.signed_distance(at)))
            .filter(|&(_, depth)| depth > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((obstacle, depth)) = deepest {
            buried.push(BuriedTarget {
                target,
                particle,
                obstacle,
                depth,
            });
        }
    }
    buried
}

/// One warning per collider that holds targets: how many, the deepest (named as the scene names
/// it), and whether a particle can still meet it within the task's tolerance at the surface.
pub fn buried_target_warnings(scene: &Scene) -> Vec<String> {
    let buried = buried_targets(scene);
    let tolerance = scene.tolerance();
    let mut warnings = Vec::new();
    for (i, obstacle) in scene.obstacles.iter().enumerate() {
        let inside: Vec<&BuriedTarget> = buried.iter().filter(|b| b.obstacle == i).collect();
        // The first of the deepest, so that ties name the first target.
        let deepest = inside
            .iter()
            .fold(None, |best: Option<&&BuriedTarget>, b| match best {
                Some(d) if d.depth >= b.depth => best,
                _ => Some(b),
            });
        let Some(deepest) = deepest else {
            continue;
        };
        let name = match scene.task.target_mesh {
            Some(_) => format!("task.target_mesh vertex {}", deepest.target),
            None => format!(
                "task.targets[{}] (particle {})",
                deepest.target, scene.task.targets[deepest.target].particle
            ),
        };
        let which = if inside.len() == 1 {
            format!("{name} lies {:.4}", deepest.depth)
        } else {
            format!(
                "{} targets lie up to {:.4} (the deepest {name})",
                inside.len(),
                deepest.depth
            )
        };
        let consequence = if deepest.depth > tolerance {
            format!(
                "no particle goes there, so the task cannot be achieved: the nearest a particle \
                 comes is {:.4} away, beyond the tolerance {tolerance:.4}",
                deepest.depth
            )
        } else {
            format!(
                "no particle goes there, but one resting on the surface is within the tolerance \
                 {tolerance:.4}"
            )
        };
        warnings.push(format!(
            "{which} inside obstacles[{i}] ({}), a collider: {consequence}",
            obstacle.kind()
        ));
    }
    warnings
}

/// The targets (in target order) inside the model's colliders deeper than the task tolerance,
/// with their depth: no plan brings their particles within the tolerance.
pub fn unreachable_targets(model: &Model) -> Vec<(usize, f64)> {
    let positions = &model.task.target_positions;
    if model.colliders.is_empty() {
        return Vec::new();
    }
    (0..positions.rows())
        .filter_map(|i| {
            let p = positions.row(i);
            let depth = -model.colliders.distance(&Vector3::new(p[0], p[1], p[2]));
            (depth > model.task.tolerance).then_some((i, depth))
        })
        .collect()
}

/// Steps [`targets_rest`] simulates: the fold's crease rises within five (docs/experiments.md,
/// "Whether a task's targets can rest").
pub const REST_STEPS: usize = 8;

/// Where the cloth goes from its targets ([`targets_rest`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TargetRest {
    /// The largest distance of a particle from its target (after [`REST_STEPS`] steps in
    /// [`targets_rest`]).
    pub largest_error: f64,
    /// How many targets are then within the task's tolerance.
    pub reached: usize,
    /// How many targets there are (one per particle).
    pub targets: usize,
    /// The factor the targets' heights above the lowest were spread by to start the cloth with
    /// its layers apart (1: the targets as given).
    pub spread: f64,
    /// The largest height of a particle above its target (against gravity, else along `z`): a
    /// fold or crease that opens lifts parts of the cloth, a cloth that cannot hold itself up
    /// sinks (≤ 0).
    pub largest_rise: f64,
}

/// Where the cloth, put at its targets (one for every particle) with its grippers held there,
/// is after [`REST_STEPS`] steps of the scene's physics with zero moves; `None` when not every
/// particle has a target, or no start could be simulated. Layers that targets put at the
/// self-contact thickness are no valid start (the barrier is infinite there): the targets'
/// heights above the lowest are then spread by 2, else 3 ([`start_at_targets`]), and the spread is
/// reported.
pub fn targets_rest(model: &Model) -> Option<TargetRest> {
    [1.0, 2.0, 3.0].into_iter().find_map(|spread| {
        let start = start_at_targets(model, spread)?;
        let placed = model.placed_at(&start, REST_STEPS).ok()?;
        let states = placed.simulate(&placed.zero_controls()).ok()?;
        Some(TargetRest::of(model, states.last()?, spread))
    })
}

impl TargetRest {
    /// How far the cloth at `state` is from `model`'s targets, started with `spread`.
    pub fn of(model: &Model, state: &Tensor, spread: f64) -> TargetRest {
        let errors = target_errors(model, state);
        let (up, at) = (up(model), &model.task.target_positions);
        let largest_rise = (model.task.targets.as_slice().iter().enumerate())
            .map(|(i, &p)| {
                (0..3)
                    .map(|k| (state.get(p, k) - at.get(i, k)) * up[k])
                    .sum()
            })
            .fold(f64::NEG_INFINITY, f64::max);
        TargetRest {
            largest_rise,
            largest_error: errors.iter().copied().fold(0.0, f64::max),
            reached: errors
                .iter()
                .filter(|&&e| e <= model.task.tolerance)
                .count(),
            targets: errors.len(),
            spread,
        }
    }
}

/// The cloth at its targets, in particle order, with the targets' heights above the lowest
/// (along gravity, else `z`) multiplied by `spread` (1: as given); `None` unless every particle has
/// exactly one target.
pub fn start_at_targets(model: &Model, spread: f64) -> Option<Vec<[f64; 3]>> {
    let (targets, at) = (model.task.targets.as_slice(), &model.task.target_positions);
    let n = model.n_particles();
    let mut start = vec![None; n];
    let up = up(model);
    let target = |i: usize| Vector3::new(at.get(i, 0), at.get(i, 1), at.get(i, 2));
    let lowest = (0..targets.len())
        .map(|i| target(i).dot(&up))
        .fold(f64::INFINITY, f64::min);
    for (i, &p) in targets.iter().enumerate() {
        let q = target(i);
        let lifted = q + up * ((spread - 1.0) * (q.dot(&up) - lowest));
        if start[p].replace([lifted.x, lifted.y, lifted.z]).is_some() {
            return None;
        }
    }
    start.into_iter().collect()
}

/// The unit vector against gravity, else `z`.
fn up(model: &Model) -> Vector3<f64> {
    match model.gravity_step {
        Some(g) if g.iter().any(|&v| v != 0.0) => -Vector3::from(g).normalize(),
        _ => Vector3::z(),
    }
}
