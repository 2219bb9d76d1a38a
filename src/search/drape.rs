//! Drape routes: a held cloth lifted over a collider it is to hang on, and lowered on the far
//! side.
//!
//! A task may put particles of the cloth on a collider that lies above where the grippers end: a
//! towel hung over a rail, its middle row on the rail and its held edge below the rail on the far
//! side. The straight path leaves the cloth hanging under the collider, and no gradient takes it
//! over: the grippers' rows keep them out of the collider, so their path cannot pass through it,
//! and the path over it is another route altogether. A *drape route* lifts the grippers straight
//! up until the particles meant for the collider clear it, carries them across at that height to
//! above their ends, and lowers them onto their ends, so that those particles come down on the
//! collider with the held edge on the far side:
//!
//! * **support**: the targets within the task tolerance of a collider's surface that lie higher
//!   (along world up) than the grippers' highest end by more than the tolerance;
//! * **depth**: how far the supported particles reach below the grippers' centroid, the largest
//!   over the rollout of the initial guess (the cloth hanging from its grippers);
//! * **height** of the centroid across: the highest supported target, plus the depth, plus the
//!   margin `δ + tolerance`;
//! * each gripper keeps its offset from the centroid along up, and its path (up, across, down) is
//!   cut into `T` steps of equal length. A route whose steps would exceed the scene's
//!   `task.limits.max_step` or leave its workspace is not offered.

use super::lay::depth_below;
use super::limits::{within_max_step, within_workspace};
use autodiff::Tensor;
use cloth::sdf::SignedDistance;
use cloth::Model;
use nalgebra::Vector3;

type V = Vector3<f64>;

/// Gripper positions of a route: `paths[t][k]`, steps `0..=T`.
type Paths = Vec<Vec<[f64; 3]>>;

/// The drape route of `model`'s task (module docs) from the grippers' `starts` to their `ends`,
/// at margin `delta`, with the depth measured on `states` (the initial guess's rollout). `None`
/// when no target on a collider lies above the grippers' ends, or the route breaks the limits.
pub fn drape_paths(
    model: &Model,
    (starts, ends): (&[[f64; 3]], &[[f64; 3]]),
    states: &[Tensor],
    delta: f64,
) -> Option<Paths> {
    let tolerance = model.task.tolerance;
    let gravity = model.gravity_step.unwrap_or([0.0, 0.0, -1.0]);
    let up = (-V::from(gravity)).try_normalize(1e-12)?;
    let held = model.controls.as_slice();
    if starts.is_empty() || starts.len() != ends.len() || held.len() != starts.len() {
        return None;
    }
    let (starts, ends): (Vec<V>, Vec<V>) = (
        starts.iter().map(|&p| V::from(p)).collect(),
        ends.iter().map(|&p| V::from(p)).collect(),
    );
    let highest_end = ends.iter().map(|p| p.dot(&up)).fold(f64::MIN, f64::max);
    let supported: Vec<(usize, V)> = (0..model.task.targets.as_slice().len())
        .map(|i| {
            let q = V::from_fn(|j, _| model.task.target_positions.get(i, j));
            (model.task.targets.as_slice()[i], q)
        })
        .filter(|(p, q)| {
            !held.contains(p)
                && q.dot(&up) > highest_end + tolerance
                && model.colliders.distance(q).abs() <= tolerance
        })
        .collect();
    let top = supported
        .iter()
        .map(|(_, q)| q.dot(&up))
        .fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return None;
    }
    let ids: Vec<usize> = supported.iter().map(|&(p, _)| p).collect();
    let depth = depth_below(states, held, &ids, up);
    let height = top + depth + delta + tolerance;
    let mean = |ps: &[V]| ps.iter().sum::<V>() / ps.len() as f64;
    let (cs, ce) = (mean(&starts), mean(&ends));
    // Each gripper at the centroid's height across, keeping its offset along up.
    let lift = |p: V, c: V| p + up * (height - c.dot(&up));
    let horizon = model.task.horizon;
    let per_gripper: Vec<Vec<V>> = starts
        .iter()
        .zip(&ends)
        .map(|(&s, &e)| {
            let corners = [s, lift(s, cs), lift(e, ce), e];
            (0..=horizon)
                .map(|t| along(&corners, t as f64 / horizon as f64))
                .collect()
        })
        .collect();
    let paths: Paths = (0..=horizon)
        .map(|t| {
            per_gripper
                .iter()
                .map(|g| [g[t].x, g[t].y, g[t].z])
                .collect()
        })
        .collect();
    let limits = &model.task.limits;
    let within = within_max_step(&paths, limits.max_step)
        && within_workspace(&paths, limits.workspace.as_ref());
    // A lift that stays below the ends and starts adds nothing the straight path lacks.
    let lifted = height
        > starts
            .iter()
            .chain(&ends)
            .map(|p| p.dot(&up))
            .fold(f64::MIN, f64::max);
    (within && lifted).then_some(paths)
}

/// The point a fraction `f` of the way along the polyline `corners` (by length).
fn along(corners: &[V], f: f64) -> V {
    let lengths: Vec<f64> = corners.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
    let mut left = f.clamp(0.0, 1.0) * lengths.iter().sum::<f64>();
    for (w, &l) in corners.windows(2).zip(&lengths) {
        if left <= l && l > 0.0 {
            return w[0] + (w[1] - w[0]) * (left / l);
        }
        left -= l;
    }
    corners[corners.len() - 1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloth::Scene;

    /// A 5 × 5 cloth of side 0.4 held by its top corners in front of a rail (r 1.5 cm at 1.1 m),
    /// to be hung over it: the middle row on the rail, the held edge below it behind.
    fn rail_scene(held_end_z: f64, workspace_top: f64) -> Model {
        let text = format!(
            r#"{{
          "name": "rail",
          "cloth": {{"rows": 5, "cols": 5, "top_left": [-0.2, -0.25, 1.0],
                    "right": [0.4, 0.0, 0.0], "down": [0.0, 0.0, -0.4]}},
          "physics": {{"dt": 0.1, "gravity": [0.0, 0.0, -9.8]}},
          "material": {{"stretch": 100.0}},
          "controls": [[0, 0], [0, 4]],
          "obstacles": [
            {{"type": "capsule", "a": [-0.5, 0.0, 1.1], "b": [0.5, 0.0, 1.1], "radius": 0.015,
             "role": "collider"}}
          ],
          "task": {{"horizon": 10, "alpha": 0.1, "beta": 0.0001, "initial_controls": "zeros",
            "limits": {{"max_step": 0.2,
                        "workspace": {{"min": [-1, -1, 0], "max": [1, 1, {workspace_top}]}}}},
            "targets": [
              {{"particle": [0, 0], "position": [-0.2, 0.06, {held_end_z}]}},
              {{"particle": [0, 4], "position": [0.2, 0.06, {held_end_z}]}},
              {{"particle": [2, 0], "position": [-0.2, 0.0, 1.125]}},
              {{"particle": [2, 4], "position": [0.2, 0.0, 1.125]}}]}}
        }}"#
        );
        Model::from_scene(&Scene::from_json_str(&text).unwrap()).unwrap()
    }

    fn route(model: &Model) -> Option<Paths> {
        let starts: Vec<[f64; 3]> = model
            .controls
            .as_slice()
            .iter()
            .map(|&p| std::array::from_fn(|j| model.start.get(p, j)))
            .collect();
        // The held particles' targets are the first two.
        let ends: Vec<[f64; 3]> = (0..2)
            .map(|i| std::array::from_fn(|j| model.task.target_positions.get(i, j)))
            .collect();
        let states = model.simulate(&model.zero_controls()).unwrap();
        drape_paths(model, (&starts, &ends), &states, 0.0)
    }

    #[test]
    fn a_cloth_to_hang_over_a_rail_is_lifted_over_it_and_lowered_behind() {
        let model = rail_scene(0.92, 2.0);
        let paths = route(&model).expect("a drape route");
        let (first, last) = (&paths[0], &paths[paths.len() - 1]);
        assert_eq!(first[0], [-0.2, -0.25, 1.0]);
        assert!((last[1][1] - 0.06).abs() < 1e-12 && (last[1][2] - 0.92).abs() < 1e-12);
        // Across the rail (y = 0) the grippers are above the rail by at least the middle row's
        // depth below them (0.2 at rest) plus the tolerance.
        let over: Vec<f64> = paths
            .windows(2)
            .filter(|w| w[0][0][1] <= 0.0 && w[1][0][1] >= 0.0)
            .map(|w| w[0][0][2].min(w[1][0][2]))
            .collect();
        assert!(!over.is_empty(), "the route crosses the rail's plane");
        let tolerance = model.task.tolerance;
        assert!(
            over.iter().all(|&z| z >= 1.125 + 0.2 + tolerance - 1e-9),
            "{over:?}"
        );
        // Steps of equal length along the path (a chord across a corner is shorter), within
        // max_step.
        let step = |t: usize| (V::from(paths[t + 1][0]) - V::from(paths[t][0])).norm();
        let steps: Vec<f64> = (0..paths.len() - 1).map(step).collect();
        let longest = steps.iter().copied().fold(0.0, f64::max);
        assert!(longest <= 0.2, "{steps:?}");
        assert!(
            steps
                .iter()
                .filter(|&&s| (s - longest).abs() < 1e-9)
                .count()
                >= 6,
            "{steps:?}"
        );
    }

    #[test]
    fn none_where_the_ends_are_as_high_or_the_limits_forbid_it() {
        // The held edge ends above the rail's targets: nothing to hang over.
        assert!(route(&rail_scene(1.2, 2.0)).is_none());
        // The lift would leave the workspace.
        assert!(route(&rail_scene(0.92, 1.2)).is_none());
    }
}
