//! The same scene at another mesh resolution, for convergence and scaling studies.

use crate::scene::{ParticleRef, Scene, SceneError};

/// The particle of a `to`-point axis nearest to particle `i` of a `from`-point axis, by fractional
/// position along the axis.
fn map_axis(i: usize, from: usize, to: usize) -> usize {
    if from <= 1 || to <= 1 {
        return 0;
    }
    ((i as f64) * (to - 1) as f64 / (from - 1) as f64).round() as usize
}

impl Scene {
    /// This scene with a `rows × cols` cloth of the same size and placement.
    ///
    /// Control and target particles move to the particle at the nearest fractional grid position
    /// (corners stay corners); target positions are unchanged, so `G` measures the same material
    /// points. When coarsening maps several targets to one particle, the first of them is kept.
    pub fn refined(&self, rows: usize, cols: usize) -> Result<Scene, SceneError> {
        let (r0, c0) = (self.cloth.rows, self.cloth.cols);
        if self.cloth.is_mesh() {
            return Err(SceneError::Invalid {
                field: "cloth.mesh".into(),
                reason: "a mesh cloth cannot be refined to a grid (remesh the OBJ file instead)"
                    .into(),
            });
        }
        if !self.custom_constraints.is_empty() {
            // Their particle lists (e.g. every triangle) have no counterpart on another grid.
            return Err(SceneError::Invalid {
                field: "custom_constraints".into(),
                reason: format!(
                    "a scene with custom constraints cannot be refined: their particles belong to the {r0} × {c0} grid"
                ),
            });
        }
        if self
            .cloth
            .initial_state
            .as_ref()
            .is_some_and(|s| s.recipe.is_none())
        {
            return Err(SceneError::Invalid {
                field: "cloth.initial_state".into(),
                reason: format!(
                    "positions given for the {r0} × {c0} grid cannot be refined (a recipe can)"
                ),
            });
        }
        let map = |p: ParticleRef| match p {
            ParticleRef::Grid([r, c]) => {
                ParticleRef::Grid([map_axis(r, r0, rows), map_axis(c, c0, cols)])
            }
            vertex => vertex,
        };
        let mut scene = self.clone();
        scene.cloth.rows = rows;
        scene.cloth.cols = cols;
        scene.controls = self.controls.iter().copied().map(map).collect();
        if let Some(phases) = scene
            .cloth
            .initial_state
            .as_mut()
            .and_then(|s| s.recipe.as_mut())
        {
            for phase in phases {
                phase.hold = phase.hold.iter().copied().map(map).collect();
            }
        }
        scene.task.targets.clear();
        for t in &self.task.targets {
            let particle = map(t.particle);
            if scene.task.targets.iter().all(|k| k.particle != particle) {
                scene.task.targets.push(crate::scene::Target {
                    particle,
                    ..t.clone()
                });
            }
        }
        scene.name = format!("{}@{rows}x{cols}", self.name);
        scene.validate()?;
        Ok(scene)
    }
}
