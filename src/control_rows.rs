//! Inequality rows on the controls alone (no simulation): control points against collider
//! planes, and the robot limits `task.limits` other than strain (workspace, step size, gripper
//! separation).
//!
//! The controls are per-step displacements, so gripper `k`'s absolute position at step `t` is
//! `p_k(t) = p_k⁰ + Σ_{s<t} u_{s,k}`: linear in the controls. Every row reads `≥ 0`.

use cloth::Model;

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
    [0, 1, 2].map(|j| model.rest.get(p, j))
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
    /// The limit this row enforces (its `task.limits` field) and the step `1..=T` it constrains.
    pub fn label(&self) -> (&'static str, usize) {
        match *self {
            ControlRow::Step { t, .. } => ("max_step", t + 1),
            ControlRow::MinSeparation { t, .. } | ControlRow::MaxSeparation { t, .. } => {
                ("gripper_separation", t)
            }
        }
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
        }
    }
}
