//! The result JSON's nested lists to and from the library's tensors: controls (`T × 3K`), states
//! (`N × 3`), gripper positions, a mesh cloth's triangles.

use autodiff::Tensor;
use cloth::{Controls, Model, Scene};

/// Controls tensor (`T × 3K`) as nested `[x, y, z]` lists.
pub fn controls_to_nested(controls: &Controls) -> Vec<Vec<[f64; 3]>> {
    cloth::ControlsView::to_nested(controls)
}

/// A state tensor (`N × 3`) as a list of points.
pub fn state_points(x: &Tensor) -> Vec<[f64; 3]> {
    x.data()
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// Controls from nested lists, checked against the model's shape.
pub fn controls_from_nested(
    model: &Model,
    u: &[Vec<[f64; 3]>],
) -> Result<Controls, cloth::ClothError> {
    let (t, k) = (model.task.horizon, model.n_controls());
    if u.len() != t || u.iter().any(|row| row.len() != k) {
        let found = u.iter().map(Vec::len).max().unwrap_or(0);
        return Err(cloth::ClothError::Controls(format!(
            "expected {t} steps × {k} control points, got {} steps × {found}",
            u.len()
        )));
    }
    let c = Tensor::new(t, 3 * k, u.iter().flatten().flatten().copied().collect());
    model.check_controls(&c)?;
    Ok(c)
}

/// Absolute positions of every control point at every state: `(T + 1) × controls × 3`.
pub fn gripper_positions(model: &Model, states: &[Tensor]) -> Vec<Vec<[f64; 3]>> {
    states
        .iter()
        .map(|x| {
            model
                .controls
                .as_slice()
                .iter()
                .map(|&p| [x.get(p, 0), x.get(p, 1), x.get(p, 2)])
                .collect()
        })
        .collect()
}

/// A mesh cloth's triangles for the result JSON; `None` for a grid.
pub fn mesh_triangles(scene: &Scene, model: &Model) -> Option<Vec<[usize; 3]>> {
    scene.cloth.is_mesh().then(|| model.triangles.to_vec())
}
