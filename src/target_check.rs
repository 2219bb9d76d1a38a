//! Targets the cloth cannot reach: a target inside a collider lies where no particle goes, so it
//! is said when the scene is loaded (a warning naming the target and the obstacle) instead of
//! after a planner has searched for it, and the verdict of a plan that misses it says why
//! ([`unreachable_targets`]).

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
