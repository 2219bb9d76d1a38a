//! Whether a route keeps the task's gripper limits: a route that breaks them starts the planner
//! far from feasible, so the route families ([`super::lay`], [`super::drape`]) do not offer it.

use cloth::scene::Workspace;

/// Gripper positions of a route: `paths[t][k]`, steps `0..=T`.
type Paths = Vec<Vec<[f64; 3]>>;

/// True when no gripper moves more than `max_step` (if any) in one step of `paths`, to 1e-9
/// relative.
pub fn within_max_step(paths: &Paths, max_step: Option<f64>) -> bool {
    let Some(m) = max_step else {
        return true;
    };
    paths.windows(2).all(|w| {
        w[0].iter().zip(&w[1]).all(|(a, b)| {
            let s = (0..3).map(|j| (b[j] - a[j]).powi(2)).sum::<f64>().sqrt();
            s <= m * (1.0 + 1e-9)
        })
    })
}

/// True when every gripper position of `paths` lies in `workspace` (if any), to 1e-9.
pub fn within_workspace(paths: &Paths, workspace: Option<&Workspace>) -> bool {
    workspace.is_none_or(|w| {
        paths
            .iter()
            .flatten()
            .all(|p| (0..3).all(|j| p[j] >= w.min[j] - 1e-9 && p[j] <= w.max[j] + 1e-9))
    })
}
