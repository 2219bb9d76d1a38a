//! Figures of cloth rollouts: builds [`crate::plot`] figures from a model and its states.

use crate::plot::{self, PlotError, Sphere, TrajectoryFigure};
use autodiff::Tensor;
use cloth::Model;
use std::path::Path;

/// The data of a trajectory figure, owned, so that a [`TrajectoryFigure`] can borrow it.
pub struct RolloutFigure {
    title: String,
    grid: (usize, usize),
    frames: Vec<(Vec<[f64; 3]>, String)>,
    control_paths: Vec<Vec<[f64; 3]>>,
    spheres: Vec<Sphere>,
    targets: Vec<[f64; 3]>,
    target_particles: Vec<usize>,
    ground_z: Option<f64>,
    safety_margin: Option<f64>,
}

impl RolloutFigure {
    /// The rollout `states` (`T + 1` frames) of `model` on a `grid` cloth: the initial, a middle and
    /// the final frame (labelled with their largest edge strain), the control paths, the safety spheres grown by `delta` (if any), the
    /// targets and a horizontal collider plane (if any).
    pub fn new(
        model: &Model,
        grid: (usize, usize),
        states: &[Tensor],
        title: &str,
        delta: Option<f64>,
    ) -> Self {
        let points = crate::plan::state_points;
        let last = states.len().saturating_sub(1);
        let mut picks = vec![0, last / 2, last];
        picks.dedup();
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
        let spheres = obstacle_spheres(model);
        let ground_z = model
            .colliders
            .planes
            .iter()
            .chain(&model.safety_obstacles.planes)
            .find(|p| p.normal[2] > 0.999)
            .map(|p| p.point[2]);
        let targets = points(&model.task.target_positions);
        RolloutFigure {
            title: title.to_string(),
            grid,
            frames,
            control_paths,
            spheres,
            targets,
            target_particles: model.task.targets.as_slice().to_vec(),
            ground_z,
            safety_margin: delta.filter(|_| !model.safety_obstacles.is_empty()),
        }
    }

    /// The figure, borrowing this data.
    pub fn figure(&self) -> TrajectoryFigure<'_> {
        TrajectoryFigure {
            title: self.title.clone(),
            grid: self.grid,
            frames: self
                .frames
                .iter()
                .map(|(f, l)| (f.as_slice(), l.clone()))
                .collect(),
            control_paths: self.control_paths.clone(),
            spheres: &self.spheres,
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
}
