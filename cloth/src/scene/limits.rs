//! `task.limits`: their values, and where the grippers start against them.

use super::format::*;
use super::validate::{check_coordinate, check_non_negative, check_positive, check_vec3};
use super::{invalid, Scene, SceneError};
use crate::geometry::norm3;

impl Scene {
    pub(super) fn validate_limits(&self) -> Result<(), SceneError> {
        let limits = &self.task.limits;
        if let Some(step) = limits.max_step {
            check_positive("task.limits.max_step", step)?;
            check_coordinate("task.limits.max_step", step)?;
        }
        if let Some(strain) = limits.max_strain {
            check_positive("task.limits.max_strain", strain)?;
            check_coordinate("task.limits.max_strain", strain)?;
        }
        if let Some(w) = &limits.workspace {
            check_vec3("task.limits.workspace.min", &w.min)?;
            check_vec3("task.limits.workspace.max", &w.max)?;
            for j in 0..3 {
                if w.min[j] > w.max[j] {
                    return Err(invalid(
                        format!("task.limits.workspace.min[{j}]"),
                        format!("{} exceeds max[{j}] = {}", w.min[j], w.max[j]),
                    ));
                }
            }
        }
        if let Some([lo, hi]) = limits.gripper_separation {
            let field = "task.limits.gripper_separation";
            check_non_negative(&format!("{field}[0]"), lo)?;
            check_coordinate(&format!("{field}[0]"), lo)?;
            check_positive(&format!("{field}[1]"), hi)?;
            check_coordinate(&format!("{field}[1]"), hi)?;
            if lo > hi {
                return Err(invalid(
                    field,
                    format!("min {lo} exceeds max {hi} (expected [min, max])"),
                ));
            }
        }
        // A recipe's start is known once the simulator has run it (`crate::start`).
        let recipe = (self.cloth.initial_state.as_ref()).is_some_and(|s| s.recipe.is_some());
        match self.cloth.initial_state.as_ref().and_then(|s| s.given()) {
            Some(start) => self.check_grippers_at(start),
            None if recipe => Ok(()),
            None => self.check_grippers_at(&self.rest_positions()),
        }
    }

    /// The robot limits the grippers must meet where the cloth starts (`positions`, in particle
    /// order): inside the workspace, and their separation within its bounds.
    pub(crate) fn check_grippers_at(&self, positions: &[[f64; 3]]) -> Result<(), SceneError> {
        let limits = &self.task.limits;
        let grippers: Vec<(ParticleRef, [f64; 3])> = self
            .controls
            .iter()
            .zip(self.control_indices())
            .map(|(&rc, p)| (rc, positions[p]))
            .collect();
        if let Some(w) = &limits.workspace {
            for (particle, p) in &grippers {
                if (0..3).any(|j| p[j] < w.min[j] || p[j] > w.max[j]) {
                    return Err(invalid(
                        "task.limits.workspace",
                        format!("control point {particle} starts outside it, at {p:?}"),
                    ));
                }
            }
        }
        if let Some([lo, hi]) = limits.gripper_separation {
            for (a, (ra, pa)) in grippers.iter().enumerate() {
                for (rb, pb) in &grippers[a + 1..] {
                    let d = norm3(&[pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2]]);
                    if d < lo || d > hi {
                        return Err(invalid(
                            "task.limits.gripper_separation",
                            format!(
                                "control points {ra} and {rb} start {d} apart, outside [{lo}, {hi}]"
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}
