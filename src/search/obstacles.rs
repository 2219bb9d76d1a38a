//! The obstacles a route goes around: every safety obstacle, and every collider that the task
//! does not put the cloth on.
//!
//! A collider with a target within the task tolerance of its surface is where the cloth is meant
//! to end (the table a towel is laid on): the cloth has to reach it, not avoid it. Any other
//! collider (a rail the cloth must pass over, a pole beside the way) is in the way: a cloth that
//! catches on it stalls the planner as surely as a safety row does.

use cloth::sdf::{SignedDistance, Union};
use cloth::Model;
use nalgebra::Vector3;

/// The safety obstacles of `model` and its colliders that no target lies on (within the task
/// tolerance of the surface, or inside).
pub fn in_the_way(model: &Model) -> Union {
    let targets: Vec<Vector3<f64>> = (0..model.task.target_positions.rows())
        .map(|i| Vector3::from_fn(|j, _| model.task.target_positions.get(i, j)))
        .collect();
    let tolerance = model.task.tolerance;
    let free = |sdf: &dyn Fn(&Vector3<f64>) -> f64| targets.iter().all(|p| sdf(p) > tolerance);
    let c = &model.colliders;
    let mut out = (*model.safety_obstacles).clone();
    out.spheres.extend(
        c.spheres
            .iter()
            .filter(|s| free(&|p| s.distance(p)))
            .cloned(),
    );
    out.planes.extend(
        c.planes
            .iter()
            .filter(|s| free(&|p| s.distance(p)))
            .cloned(),
    );
    out.capsules.extend(
        c.capsules
            .iter()
            .filter(|s| free(&|p| s.distance(p)))
            .cloned(),
    );
    out.boxes
        .extend(c.boxes.iter().filter(|s| free(&|p| s.distance(p))).cloned());
    out.meshes.extend(
        c.meshes
            .iter()
            .filter(|s| free(&|p| s.distance(p)))
            .cloned(),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloth::Scene;

    #[test]
    fn a_collider_with_a_target_on_it_is_not_in_the_way() {
        // A rail the cloth must pass and a table its targets lie on; a mug for safety.
        let text = r#"{
          "name": "rail_and_table",
          "cloth": {"rows": 3, "cols": 3, "top_left": [-0.1, -0.7, 1.2], "right": [0.2, 0.0, 0.0],
                    "down": [0.0, 0.0, -0.2]},
          "physics": {"dt": 0.1, "gravity": [0.0, 0.0, -9.8], "iterations": 10},
          "material": {"stretch": 100.0},
          "controls": [[0, 0], [0, 2]],
          "obstacles": [
            {"type": "box", "center": [0.0, 0.0, 0.375], "half_extents": [0.6, 0.4, 0.375],
             "role": "collider"},
            {"type": "capsule", "a": [-0.5, -0.55, 1.0], "b": [0.5, -0.55, 1.0], "radius": 0.015,
             "role": "collider"},
            {"type": "spheres", "centers": [[1.0, 0.0, 0.8]], "radii": [0.05], "role": "safety"}
          ],
          "task": {"horizon": 4, "alpha": 0.1, "beta": 0.0001, "initial_controls": "zeros",
            "targets": [{"particle": [2, 0], "position": [-0.1, 0.0, 0.752]}]}
        }"#;
        let model = Model::from_scene(&Scene::from_json_str(text).unwrap()).unwrap();
        let way = in_the_way(&model);
        assert_eq!(way.capsules.len(), 1, "the rail is in the way");
        assert!(way.boxes.is_empty(), "the table holds the target");
        assert_eq!(way.spheres.len(), 1, "safety obstacles always are");
    }
}
