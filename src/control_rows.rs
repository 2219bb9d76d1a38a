//! Inequality rows on the controls alone (no simulation): control points against the colliders
//! (linear rows for planes, smooth rows for every other kind), and the robot limits
//! `task.limits` other than strain (workspace, step size, gripper separation).
//!
//! The controls are per-step displacements, so gripper `k`'s absolute position at step `t` is
//! `p_k(t) = p_k⁰ + Σ_{s<t} u_{s,k}`: linear in the controls. Every row reads `≥ 0`. No collider
//! moves a gripper (it has infinite mass), so only these rows keep it out of them.

use autodiff::{soft_min_value, soft_min_weights};
use cloth::nalgebra::Vector3;
use cloth::sdf::{SignedDistance, Union};
use cloth::Model;
use std::sync::Arc;

/// A linear inequality `offset + Σ coeff·x ≥ 0`.
#[derive(Clone, Debug)]
pub(crate) struct LinearRow {
    pub coeffs: Vec<(usize, f64)>,
    pub offset: f64,
}

impl LinearRow {
    /// The row's value at `x`.
    pub fn value(&self, x: &[f64]) -> f64 {
        self.offset + self.coeffs.iter().map(|&(j, a)| a * x[j]).sum::<f64>()
    }
}

/// Index of control entry `(step, gripper, axis)` in the flat variable vector.
fn entry(model: &Model, step: usize, gripper: usize, axis: usize) -> usize {
    step * 3 * model.n_controls() + 3 * gripper + axis
}

/// Rest position of gripper `k`.
fn rest_of(model: &Model, k: usize) -> [f64; 3] {
    let p = model.controls.as_slice()[k];
    [0, 1, 2].map(|j| model.start.get(p, j))
}

/// `n·(p_k(t) − q)` as a linear row.
fn position_row(model: &Model, t: usize, k: usize, n: [f64; 3], q: [f64; 3]) -> LinearRow {
    let p0 = rest_of(model, k);
    let coeffs = (0..t)
        .flat_map(|s| (0..3).map(move |j| (s, j)))
        .filter(|&(_, j)| n[j] != 0.0)
        .map(|(s, j)| (entry(model, s, k, j), n[j]))
        .collect();
    LinearRow {
        coeffs,
        offset: (0..3).map(|j| n[j] * (p0[j] - q[j])).sum(),
    }
}

/// Rows keeping each control point on the free side of each collider plane at steps 1..T:
/// `n·(p_k(t) − q) ≥ 0`.
pub(crate) fn collider_rows(model: &Model) -> Vec<LinearRow> {
    let mut rows = Vec::new();
    for plane in &model.colliders.planes {
        let n = [0, 1, 2].map(|j| plane.normal[j]);
        let q = [0, 1, 2].map(|j| plane.point[j]);
        for k in 0..model.n_controls() {
            for t in 1..=model.task.horizon {
                rows.push(position_row(model, t, k, n, q));
            }
        }
    }
    rows
}

/// Workspace rows (`task.limits.workspace`): `p_{k,j}(t) − min_j ≥ 0` and `max_j − p_{k,j}(t) ≥ 0`
/// for every gripper `k`, step 1..T and axis `j`.
pub(crate) fn workspace_rows(model: &Model) -> Vec<LinearRow> {
    let Some(w) = &model.task.limits.workspace else {
        return Vec::new();
    };
    let mut rows = Vec::new();
    for k in 0..model.n_controls() {
        for t in 1..=model.task.horizon {
            for j in 0..3 {
                let mut e = [0.0; 3];
                e[j] = 1.0;
                rows.push(position_row(model, t, k, e, w.min));
                rows.push(position_row(model, t, k, e.map(|v| -v), w.max));
            }
        }
    }
    rows
}

/// A smooth, nonlinear row on the controls, with its exact gradient.
#[derive(Clone, Debug)]
pub(crate) enum ControlRow {
    /// `(m² − ‖u_{t,k}‖²)/(2m) ≥ 0`: gripper `k` moves at most `m` in step `t` (0-based).
    Step { t: usize, k: usize, max: f64 },
    /// `(‖d‖² − m²)/(2m) ≥ 0` with `d = p_a(t) − p_b(t)`: grippers at least `m > 0` apart.
    MinSeparation {
        t: usize,
        a: usize,
        b: usize,
        min: f64,
    },
    /// `(m² − ‖d‖²)/(2m) ≥ 0`: grippers at most `m` apart at step `t`.
    MaxSeparation {
        t: usize,
        a: usize,
        b: usize,
        max: f64,
    },
    /// Gripper `k` out of the colliders `field` (planes left to the linear rows) at step `t`
    /// (1-based) and, when `swept`, on its straight motion from step `t − 1`: the soft minimum
    /// (sharpness `kappa`) over the primitives of their distance at `p_k(t)` and of their
    /// smallest distance along the motion ([`Union::segment_components`], which for a box the
    /// motion enters is minus its crossing depth) `≥ 0`. Smooth where the
    /// primitives are, never above the smallest distance, with the minima's exact gradients.
    Collider {
        t: usize,
        k: usize,
        field: Arc<Union>,
        kappa: f64,
        swept: bool,
    },
}

/// One row per gripper and step keeping the gripper out of `model`'s colliders other than planes
/// (whose linear rows are exact along a straight motion too): on the motion from the step before
/// when `swept`, except a gripper's first step when it starts inside a collider (no plan can
/// move its rest position).
pub(crate) fn gripper_collider_rows(model: &Model, kappa: f64, swept: bool) -> Vec<ControlRow> {
    let field = model.colliders_without_planes();
    if field.is_empty() {
        return Vec::new();
    }
    let field = Arc::new(field);
    let mut rows = Vec::new();
    for k in 0..model.n_controls() {
        let starts_inside = field.distance(&Vector3::from(rest_of(model, k))) < 0.0;
        for t in 1..=model.task.horizon {
            rows.push(ControlRow::Collider {
                t,
                k,
                field: field.clone(),
                kappa,
                swept: swept && !(t == 1 && starts_inside),
            });
        }
    }
    rows
}

/// The entries of a [`ControlRow::Collider`] row at the flat controls `x`: per entry its value,
/// its gradient with respect to a displacement of steps before `t − 1` (which moves both ends of
/// the motion) and with respect to the displacement of step `t − 1` (which moves its end).
fn collider_entries(
    model: &Model,
    x: &[f64],
    (t, k): (usize, usize),
    field: &Union,
    swept: bool,
) -> Vec<(f64, [f64; 3], [f64; 3])> {
    let point = |t: usize| Vector3::from(gripper_position(model, x, t, k));
    let (a, b) = (point(t - 1), point(t));
    let sum = |g: &[f64; 6]| [0, 1, 2].map(|j| g[j] + g[3 + j]);
    let mut entries: Vec<(f64, [f64; 3], [f64; 3])> = field
        .segment_components_with_gradients(&b, &b)
        .iter()
        .map(|(v, g)| (*v, sum(g), sum(g)))
        .collect();
    if swept {
        for (v, g) in field.segment_components_with_gradients(&a, &b) {
            entries.push((v, sum(&g), [g[3], g[4], g[5]]));
        }
    }
    entries
}

/// The smooth rows of `model`'s step and separation limits. Squared norms keep every row smooth
/// (a norm is not differentiable at 0); dividing by `2m` gives them length units and the same
/// zero set as `m − ‖·‖` (`‖d‖ − m` for the minimum).
pub(crate) fn control_rows(model: &Model) -> Vec<ControlRow> {
    let limits = &model.task.limits;
    let (horizon, grippers) = (model.task.horizon, model.n_controls());
    let mut rows = Vec::new();
    if let Some(max) = limits.max_step {
        for t in 0..horizon {
            for k in 0..grippers {
                rows.push(ControlRow::Step { t, k, max });
            }
        }
    }
    if let Some([min, max]) = limits.gripper_separation {
        for t in 1..=horizon {
            for a in 0..grippers {
                for b in a + 1..grippers {
                    if min > 0.0 {
                        rows.push(ControlRow::MinSeparation { t, a, b, min });
                    }
                    rows.push(ControlRow::MaxSeparation { t, a, b, max });
                }
            }
        }
    }
    rows
}

/// Gripper `k`'s absolute position at step `t` (0..=T) under the flat controls `x`.
pub(crate) fn gripper_position(model: &Model, x: &[f64], t: usize, k: usize) -> [f64; 3] {
    let mut p = rest_of(model, k);
    for s in 0..t {
        for (j, pj) in p.iter_mut().enumerate() {
            *pj += x[entry(model, s, k, j)];
        }
    }
    p
}

/// `p_a(t) − p_b(t)`.
fn separation(model: &Model, x: &[f64], t: usize, a: usize, b: usize) -> [f64; 3] {
    let (pa, pb) = (
        gripper_position(model, x, t, a),
        gripper_position(model, x, t, b),
    );
    [0, 1, 2].map(|j| pa[j] - pb[j])
}

fn norm_sq(v: &[f64; 3]) -> f64 {
    v.iter().map(|c| c * c).sum()
}

impl ControlRow {
    /// A collider row's entries at `x` ([`collider_entries`]) and their values (empty for other
    /// rows).
    #[allow(clippy::type_complexity)]
    fn collider_values(
        &self,
        model: &Model,
        x: &[f64],
    ) -> (Vec<(f64, [f64; 3], [f64; 3])>, Vec<f64>) {
        let ControlRow::Collider {
            t,
            k,
            ref field,
            swept,
            ..
        } = *self
        else {
            return (Vec::new(), Vec::new());
        };
        let entries = collider_entries(model, x, (t, k), field, swept);
        let values = entries.iter().map(|e| e.0).collect();
        (entries, values)
    }

    /// The row's value at the flat controls `x`.
    pub fn value(&self, model: &Model, x: &[f64]) -> f64 {
        match *self {
            ControlRow::Step { t, k, max } => {
                let u = [0, 1, 2].map(|j| x[entry(model, t, k, j)]);
                (max * max - norm_sq(&u)) / (2.0 * max)
            }
            ControlRow::MinSeparation { t, a, b, min } => {
                (norm_sq(&separation(model, x, t, a, b)) - min * min) / (2.0 * min)
            }
            ControlRow::MaxSeparation { t, a, b, max } => {
                (max * max - norm_sq(&separation(model, x, t, a, b))) / (2.0 * max)
            }
            ControlRow::Collider { kappa, .. } => {
                let (_, values) = self.collider_values(model, x);
                soft_min_value(&values, kappa)
            }
        }
    }

    /// Writes the row's gradient at `x` into `out` (zeroed, one entry per variable).
    pub fn gradient(&self, model: &Model, x: &[f64], out: &mut [f64]) {
        match *self {
            ControlRow::Step { t, k, max } => {
                for j in 0..3 {
                    let i = entry(model, t, k, j);
                    out[i] = -x[i] / max;
                }
            }
            ControlRow::MinSeparation { t, a, b, min: m }
            | ControlRow::MaxSeparation { t, a, b, max: m } => {
                let sign = if matches!(self, ControlRow::MinSeparation { .. }) {
                    1.0
                } else {
                    -1.0
                };
                let d = separation(model, x, t, a, b);
                for s in 0..t {
                    for j in 0..3 {
                        out[entry(model, s, a, j)] += sign * d[j] / m;
                        out[entry(model, s, b, j)] -= sign * d[j] / m;
                    }
                }
            }
            ControlRow::Collider { t, k, kappa, .. } => {
                let (entries, values) = self.collider_values(model, x);
                let weights = soft_min_weights(&values, kappa);
                for ((_, early, last), w) in entries.iter().zip(weights) {
                    for j in 0..3 {
                        for s in 0..t - 1 {
                            out[entry(model, s, k, j)] += w * early[j];
                        }
                        out[entry(model, t - 1, k, j)] += w * last[j];
                    }
                }
            }
        }
    }
}
