//! Figures of cloth rollouts: builds [`crate::plot`] figures from a model and its states — still
//! views ([`RolloutFigure`]), an animated GIF ([`draw_rollout_gif`]) and the HTML viewer
//! ([`write_rollout_html`]).

use crate::plot::{self, Closest, PlotError, Rollout, Solid, SolidRole, Sphere, TrajectoryFigure};
use autodiff::Tensor;
use cloth::nalgebra::Vector3;
use cloth::sdf::{SignedDistance, Surface, Union};
use cloth::Model;
use std::path::Path;

/// The data of a trajectory figure, owned, so that a [`TrajectoryFigure`] can borrow it.
pub struct RolloutFigure {
    title: String,
    grid: (usize, usize),
    cloth_triangles: Vec<[usize; 3]>,
    frames: Vec<(Vec<[f64; 3]>, String)>,
    control_paths: Vec<Vec<[f64; 3]>>,
    spheres: Vec<Sphere>,
    solids: Vec<Solid>,
    targets: Vec<[f64; 3]>,
    target_particles: Vec<usize>,
    ground_z: Option<f64>,
    safety_margin: Option<f64>,
}

impl RolloutFigure {
    /// The rollout `states` (`T + 1` frames) of `model` on a `grid` cloth (`(rows, cols)`; a mesh
    /// cloth passes `(0, 0)` and is drawn from [`Model::triangles`]): the initial, a middle and
    /// the final frame (labelled with their largest edge strain), the control paths, the safety spheres grown by `delta` (if any), the
    /// targets and a horizontal collider plane (if any).
    pub fn new(
        model: &Model,
        grid: (usize, usize),
        states: &[Tensor],
        title: &str,
        delta: Option<f64>,
    ) -> Self {
        let last = states.len().saturating_sub(1);
        let mut picks = vec![0, last / 2, last];
        picks.dedup();
        Self::with_frames(model, grid, states, title, delta, &picks)
    }

    /// The same figure showing the frames `picks` (indices into `states`).
    pub fn with_frames(
        model: &Model,
        grid: (usize, usize),
        states: &[Tensor],
        title: &str,
        delta: Option<f64>,
        picks: &[usize],
    ) -> Self {
        let points = crate::result::state_points;
        // Each frame's label gives its largest edge strain (|x_i − x_j|/L₀ − 1), so a figure shows
        // how far a plan stretches the cloth.
        let strain = model.max_strain_per_step(states);
        let frames = picks
            .iter()
            .map(|&t| {
                let label = match strain.get(t) {
                    Some(s) if model.groups.iter().any(|g| g.name == "stretch") => {
                        format!("step {t}, max strain {:.0}%", 100.0 * s)
                    }
                    _ => format!("step {t}"),
                };
                (points(&states[t]), label)
            })
            .collect();
        let control_paths = model
            .controls
            .as_slice()
            .iter()
            .map(|&p| {
                states
                    .iter()
                    .map(|x| [x.get(p, 0), x.get(p, 1), x.get(p, 2)])
                    .collect()
            })
            .collect();
        // A grid is drawn as quads and rows/columns; any other cloth from its triangles.
        let cloth_triangles = if grid.0 * grid.1 == model.n_particles() {
            Vec::new()
        } else {
            model.triangles.to_vec()
        };
        RolloutFigure {
            title: title.to_string(),
            grid,
            cloth_triangles,
            frames,
            control_paths,
            spheres: obstacle_spheres(model),
            solids: obstacle_solids(model),
            targets: points(&model.task.target_positions),
            target_particles: model.task.targets.as_slice().to_vec(),
            ground_z: ground_z(model),
            safety_margin: safety_margin(model, delta),
        }
    }

    /// The figure, borrowing this data.
    pub fn figure(&self) -> TrajectoryFigure<'_> {
        TrajectoryFigure {
            title: self.title.clone(),
            grid: self.grid,
            cloth_triangles: &self.cloth_triangles,
            frames: self
                .frames
                .iter()
                .map(|(f, l)| (f.as_slice(), l.clone()))
                .collect(),
            control_paths: self.control_paths.clone(),
            spheres: &self.spheres,
            solids: &self.solids,
            targets: &self.targets,
            target_particles: &self.target_particles,
            ground_z: self.ground_z,
            safety_margin: self.safety_margin,
            ..TrajectoryFigure::default()
        }
    }

    /// Draws the 3-D view to `path`.
    pub fn draw_3d(&self, path: &Path) -> Result<(), PlotError> {
        plot::draw_trajectory_3d(&self.figure(), path)
    }

    /// Draws the top view to `path`.
    pub fn draw_top(&self, path: &Path) -> Result<(), PlotError> {
        plot::draw_trajectory_top(&self.figure(), path)
    }
}

/// Draws the rollout `states` of `model` on a `grid` cloth as an animated GIF to `path`: one 3-D view
/// per step (a quarter of a second each) on fixed axes, titled with the step.
pub fn draw_rollout_gif(
    model: &Model,
    grid: (usize, usize),
    states: &[Tensor],
    title: &str,
    delta: Option<f64>,
    path: &Path,
) -> Result<(), PlotError> {
    let last = states.len().saturating_sub(1);
    let steps: Vec<RolloutFigure> = (0..states.len())
        .map(|t| {
            let title = format!("{title}  (step {t} of {last})");
            RolloutFigure::with_frames(model, grid, states, &title, delta, &[t])
        })
        .collect();
    let figures: Vec<TrajectoryFigure> = steps.iter().map(RolloutFigure::figure).collect();
    plot::draw_trajectory_gif(&figures, 25, path)
}

/// The rollout `states` of `model` for the HTML viewer: every state, the cloth's triangles
/// ([`Model::triangles`]), the obstacles, targets, control particles, and per step the particle
/// closest to the safety obstacles (none when the scene has none).
pub fn rollout_view(model: &Model, states: &[Tensor], title: &str, delta: Option<f64>) -> Rollout {
    let states: Vec<Vec<[f64; 3]>> = states.iter().map(crate::result::state_points).collect();
    let closest = if model.safety_obstacles.is_empty() {
        Vec::new()
    } else {
        states.iter().map(|s| closest_particle(model, s)).collect()
    };
    Rollout {
        title: title.to_string(),
        triangles: model.triangles.to_vec(),
        control_particles: model.controls.as_slice().to_vec(),
        spheres: obstacle_spheres(model),
        solids: obstacle_solids(model),
        ground_z: ground_z(model),
        targets: crate::result::state_points(&model.task.target_positions),
        target_particles: model.task.targets.as_slice().to_vec(),
        safety_margin: safety_margin(model, delta),
        closest,
        states,
    }
}

/// Writes the HTML viewer of a rollout (see [`rollout_view`]) to `path`.
pub fn write_rollout_html(
    model: &Model,
    states: &[Tensor],
    title: &str,
    delta: Option<f64>,
    path: &Path,
) -> Result<(), PlotError> {
    plot::write_rollout_html(&rollout_view(model, states, title, delta), path)
}

/// The particle of `state` with the smallest signed distance to the safety obstacles (the first
/// of equals).
fn closest_particle(model: &Model, state: &[[f64; 3]]) -> Closest {
    let mut best = Closest {
        particle: 0,
        distance: f64::INFINITY,
    };
    for (i, p) in state.iter().enumerate() {
        let d = model
            .safety_obstacles
            .distance(&Vector3::new(p[0], p[1], p[2]));
        if d < best.distance {
            best = Closest {
                particle: i,
                distance: d,
            };
        }
    }
    best
}

/// The height of a horizontal collider or safety plane, if the model has one.
fn ground_z(model: &Model) -> Option<f64> {
    model
        .colliders
        .planes
        .iter()
        .chain(&model.safety_obstacles.planes)
        .find(|p| p.normal[2] > 0.999)
        .map(|p| p.point[2])
}

/// δ, when the model has safety obstacles to keep it from.
fn safety_margin(model: &Model, delta: Option<f64>) -> Option<f64> {
    delta.filter(|_| !model.safety_obstacles.is_empty())
}

/// Every sphere of the safety obstacles and the colliders, once: a sphere set with role `both` is in
/// both lists of the model, but it is one obstacle.
fn obstacle_spheres(model: &Model) -> Vec<Sphere> {
    let mut spheres: Vec<Sphere> = Vec::new();
    for set in model
        .safety_obstacles
        .spheres
        .iter()
        .chain(&model.colliders.spheres)
    {
        for (c, &r) in set.centers.iter().zip(&set.radii) {
            let sphere = Sphere {
                center: *c,
                radius: r,
            };
            if !spheres.contains(&sphere) {
                spheres.push(sphere);
            }
        }
    }
    spheres
}

/// The surfaces of the obstacles that are neither spheres nor planes (capsules, boxes, meshes),
/// of `union`.
fn surfaces(union: &Union) -> impl Iterator<Item = (Surface, &'static str)> + '_ {
    let capsules = union
        .capsules
        .iter()
        .map(|c| (c.surface_triangles(), "capsule"));
    let boxes = union.boxes.iter().map(|b| (b.surface_triangles(), "box"));
    let meshes = union.meshes.iter().map(|m| (m.surface_triangles(), "mesh"));
    capsules.chain(boxes).chain(meshes)
}

/// Every capsule, box and mesh obstacle, once, as a closed triangle mesh coloured by its role (an
/// obstacle with role `both` is in both of the model's lists: it becomes one solid).
fn obstacle_solids(model: &Model) -> Vec<Solid> {
    let mut solids: Vec<Solid> = surfaces(&model.safety_obstacles)
        .map(|((vertices, triangles), kind)| Solid {
            vertices,
            triangles,
            role: SolidRole::Safety,
            kind: kind.to_string(),
        })
        .collect();
    let safety = solids.len();
    for ((vertices, triangles), kind) in surfaces(&model.colliders) {
        let same = |s: &Solid| s.vertices == vertices && s.triangles == triangles;
        match solids[..safety].iter_mut().find(|s| same(s)) {
            Some(solid) => solid.role = SolidRole::Both,
            None => solids.push(Solid {
                vertices,
                triangles,
                role: SolidRole::Collider,
                kind: kind.to_string(),
            }),
        }
    }
    solids
}

/// The top-view path for a 3-D view path: `name.png` → `name_top.png`.
pub fn top_view_path(path: &Path) -> std::path::PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!("{stem}_top.png"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use cloth::scene::{Obstacle, ObstacleRole, Scene};

    /// The spheres of u_obstacle with the given role.
    fn spheres_with_role(role: ObstacleRole) -> Vec<Sphere> {
        let mut scene = Scene::builtin("u_obstacle").unwrap();
        for o in &mut scene.obstacles {
            if let Obstacle::Spheres(s) = o {
                s.role = role;
            }
        }
        obstacle_spheres(&Model::from_scene(&scene).unwrap())
    }

    #[test]
    fn a_sphere_set_with_role_both_is_drawn_and_counted_once() {
        let safety = spheres_with_role(ObstacleRole::Safety);
        assert_eq!(safety.len(), 18);
        assert_eq!(spheres_with_role(ObstacleRole::Both), safety);
        assert_eq!(spheres_with_role(ObstacleRole::Collider), safety);
    }

    /// Capsules, boxes and meshes reach the figures and the viewer as solids, one per obstacle,
    /// coloured by role.
    #[test]
    fn capsules_and_boxes_are_drawn_as_solids_once_with_their_role() {
        let mut json: serde_json::Value =
            serde_json::from_str(&Scene::builtin("drop").unwrap().to_json_pretty()).unwrap();
        json["obstacles"] = serde_json::json!([
            {"type": "capsule", "a": [0.2, 0.2, 0.3], "b": [0.8, 0.8, 0.3], "radius": 0.1,
             "role": "both"},
            {"type": "box", "center": [0.5, 0.5, -0.5], "half_extents": [1.0, 1.0, 0.2],
             "role": "collider"},
            {"type": "capsule", "a": [2.0, 0.0, 0.0], "b": [2.0, 1.0, 0.0], "radius": 0.2,
             "role": "safety"}
        ]);
        let scene = Scene::from_json_str(&json.to_string()).unwrap();
        let model = Model::from_scene(&scene).unwrap();
        let solids = obstacle_solids(&model);
        let roles: Vec<SolidRole> = solids.iter().map(|s| s.role).collect();
        assert_eq!(
            roles,
            [SolidRole::Both, SolidRole::Safety, SolidRole::Collider]
        );
        // The box: 8 corners, 12 triangles.
        assert_eq!(
            (solids[2].vertices.len(), solids[2].triangles.len()),
            (8, 12)
        );
        let u = crate::plan::initial_controls(&scene, &model).unwrap();
        let states = model.simulate(&u).unwrap();
        let grid = (scene.cloth.rows, scene.cloth.cols);
        let figure = RolloutFigure::new(&model, grid, &states, "t", Some(0.05));
        assert_eq!(figure.figure().solids.len(), 3);
        assert_eq!(rollout_view(&model, &states, "t", None).solids.len(), 3);
    }

    #[test]
    fn frame_labels_give_the_largest_edge_strain_of_their_step() {
        let scene = Scene::builtin("u_obstacle").unwrap();
        let model = Model::from_scene(&scene).unwrap();
        let u = crate::plan::initial_controls(&scene, &model).unwrap();
        let states = model.simulate(&u).unwrap();
        let figure = RolloutFigure::new(&model, (10, 10), &states, "t", None);
        let strain = model.max_strain_per_step(&states);
        let labels: Vec<&str> = figure.frames.iter().map(|(_, l)| l.as_str()).collect();
        assert_eq!(labels[0], "step 0, max strain 0%");
        let last = format!("step 10, max strain {:.0}%", 100.0 * strain[10]);
        assert_eq!(labels[2], last);
        assert!(strain[10] > 0.0);
    }

    #[test]
    fn the_viewer_marks_the_particle_nearest_the_obstacles_at_every_step() {
        let scene = Scene::builtin("u_obstacle").unwrap();
        let model = Model::from_scene(&scene).unwrap();
        let u = crate::plan::initial_controls(&scene, &model).unwrap();
        let states = model.simulate(&u).unwrap();
        let view = rollout_view(&model, &states, "t", Some(scene.task.delta));
        assert_eq!(view.closest.len(), states.len());
        assert_eq!(view.safety_margin, Some(scene.task.delta));
        let metrics = model.metrics(&states, &u, scene.task.delta);
        // Metrics count the steps after the fixed step 0.
        let min = view.closest[1..]
            .iter()
            .map(|c| c.distance)
            .fold(f64::INFINITY, f64::min);
        // The smallest per-step distance is the rollout's min SDF (same SDF, same particles).
        assert!(
            (min - metrics.min_sdf).abs() < 1e-12,
            "{min} vs {}",
            metrics.min_sdf
        );
        for (c, s) in view.closest.iter().zip(&view.states) {
            let p = s[c.particle];
            let d = model
                .safety_obstacles
                .distance(&Vector3::new(p[0], p[1], p[2]));
            assert_eq!(d, c.distance);
        }
    }
}
