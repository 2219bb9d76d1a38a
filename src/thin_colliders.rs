//! Colliders the cloth can pass through between its particles.
//!
//! Rigid contact keeps every *particle* outside the colliders, not the edges between them. A
//! collider narrower than the cloth's longest edge can therefore slip between two neighbouring
//! particles: measured on the task suite's `hang_rail` (a rail 3 cm across, a 12 × 12 towel with
//! edges up to 5.1 cm), a drape route carries the towel over the rail and, as it is lowered, an
//! edge passes through the rail between steps while every particle stays outside it. Smooth
//! contact keeps the edges out too (`cloth::contact::edge_points`); under rigid contact a plan
//! says so up front instead of promising a hang the physics cannot hold.

use cloth::scene::{Obstacle, ObstacleRole, Scene};
use cloth::Model;

/// Under rigid contact, the warning for the colliders of `scene` narrower than `model`'s longest
/// rest edge, when there are any: a sphere set by its smallest sphere, a capsule, a box by its smallest side.
/// Planes are unbounded; meshes are not measured.
pub fn thin_collider_warning(scene: &Scene, model: &Model) -> Option<String> {
    if model.contact_barrier.is_some() {
        // Smooth contact: edge points hold the edges outside every collider this names.
        return None;
    }
    let edge = longest_rest_edge(model);
    let thin: Vec<String> = scene
        .obstacles
        .iter()
        .enumerate()
        .filter(|(_, o)| o.role() == ObstacleRole::Collider)
        .filter_map(|(i, o)| {
            let smallest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
            let width = match o {
                Obstacle::Spheres(s) => 2.0 * smallest(&s.radii),
                Obstacle::Capsule(c) => 2.0 * c.radius,
                Obstacle::Box(b) => 2.0 * smallest(&b.half_extents),
                Obstacle::Plane(_) | Obstacle::Mesh(_) => return None,
            };
            (width < edge).then(|| format!("obstacles[{i}] ({}, {width:.4} across)", o.kind()))
        })
        .collect();
    (!thin.is_empty()).then(|| {
        format!(
            "colliders narrower than the cloth's longest edge ({edge:.4}): {}; rigid contact keeps the particles outside colliders, not the edges between them, so the cloth can pass through {} between particles (smooth contact, a finer cloth or a wider collider keeps it out)",
            thin.join(", "),
            if thin.len() == 1 { "it" } else { "them" }
        )
    })
}

/// The longest edge of `model`'s triangles in its rest shape.
fn longest_rest_edge(model: &Model) -> f64 {
    let x = &model.rest_shape;
    let length = |a: usize, b: usize| {
        (0..3)
            .map(|j| (x.get(a, j) - x.get(b, j)).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    model
        .triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| length(a, b))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Under rigid contact (XPBD), or `smooth` (Newton's default with colliders).
    fn scene(rows: usize, radius: f64, role: &str) -> Scene {
        scene_with(rows, radius, role, "xpbd")
    }

    fn scene_with(rows: usize, radius: f64, role: &str, solver: &str) -> Scene {
        let text = format!(
            r#"{{
          "name": "rail",
          "cloth": {{"rows": {rows}, "cols": {rows}, "top_left": [-0.2, -0.25, 1.0],
                    "right": [0.4, 0.0, 0.0], "down": [0.0, 0.0, -0.4]}},
          "physics": {{"dt": 0.1, "gravity": [0.0, 0.0, -9.8], "solver": "{solver}"}},
          "material": {{"stretch": 100.0}},
          "controls": [[0, 0]],
          "obstacles": [
            {{"type": "capsule", "a": [-0.5, 0.0, 1.1], "b": [0.5, 0.0, 1.1], "radius": {radius},
             "role": "{role}"}},
            {{"type": "box", "center": [0.0, 0.0, 0.3], "half_extents": [0.6, 0.4, 0.3],
             "role": "collider"}},
            {{"type": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0],
             "role": "collider"}}
          ],
          "task": {{"horizon": 2, "alpha": 0.1, "beta": 0.0001, "initial_controls": "zeros",
            "targets": [{{"particle": [0, 0], "position": [-0.2, 0.0, 1.2]}}]}}
        }}"#
        );
        Scene::from_json_str(&text).unwrap()
    }

    fn warning(s: &Scene) -> Option<String> {
        thin_collider_warning(s, &Model::from_scene(s).unwrap())
    }

    #[test]
    fn a_rail_narrower_than_the_cloths_edges_is_named() {
        // 12 × 12 over 0.4 m: sides 0.0364, diagonals 0.0514; the rail is 0.03 across.
        let w = warning(&scene(12, 0.015, "collider")).expect("a warning");
        assert!(
            w.starts_with(
                "colliders narrower than the cloth's longest edge (0.0514): obstacles[0] (capsule, 0.0300 across); "
            ),
            "{w}"
        );
    }

    #[test]
    fn a_finer_cloth_a_wider_rail_or_a_safety_obstacle_is_not() {
        assert_eq!(warning(&scene(31, 0.015, "collider")), None);
        assert_eq!(warning(&scene(12, 0.03, "collider")), None);
        assert_eq!(warning(&scene(12, 0.015, "safety")), None);
    }

    #[test]
    fn smooth_contact_keeps_the_edges_out_and_is_not_warned() {
        let s = scene_with(12, 0.015, "collider", "newton");
        let model = Model::from_scene(&s).unwrap();
        assert!(model.edge_barrier.is_some(), "edge points on the rail");
        assert_eq!(thin_collider_warning(&s, &model), None);
    }
}
