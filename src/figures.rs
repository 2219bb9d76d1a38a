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
    /// the final frame, the control paths, the safety spheres grown by `delta` (if any), the
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
        let frames = picks
            .iter()
            .map(|&t| (points(&states[t]), format!("step {t}")))
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
}
