//! The first-order quantities of an iterate: linearized violations, the Lagrangian's gradient,
//! the multipliers from a QP solution and the scaled KKT residual.

use crate::eval::{PointDerivatives, PointValues};
use crate::linalg::{dot, norm2, norm_inf};
use crate::problem::{tmul_add, NormData};
use crate::qp::QpSolution;
use crate::status::Multipliers;

/// Per constraint: `max(0, −(cᵢ + Jᵢ d))`, then `|h_j + J_{h,j} d|`.
pub(super) fn linearized_violations(
    pt: &PointValues,
    dv: &PointDerivatives,
    d: &[f64],
) -> Vec<f64> {
    violations_after(&pt.c, &pt.h, dv, d)
}

/// Per row, the violation of the rows whose values are `c`, `h` and whose Jacobians are `dv`'s,
/// moved linearly by `d`: `max(0, −(cᵢ + Jᵢd))`, then `|h_j + J_{h,j}d|`.
pub(super) fn violations_after(c: &[f64], h: &[f64], dv: &PointDerivatives, d: &[f64]) -> Vec<f64> {
    let mut jd = vec![0.0; c.len()];
    dv.jc.mul_vec(d, &mut jd);
    let mut hd = vec![0.0; h.len()];
    dv.jh.mul_vec(d, &mut hd);
    c.iter()
        .zip(&jd)
        .map(|(c, a)| (-(c + a)).max(0.0))
        .chain(h.iter().zip(&hd).map(|(h, a)| (h + a).abs()))
        .collect()
}

/// `Σ max(0, −(c + J d)) + Σ |h + J_h d|`.
pub(super) fn linearized_violation(pt: &PointValues, dv: &PointDerivatives, d: &[f64]) -> f64 {
    linearized_violations(pt, dv, d).iter().sum()
}

/// `∇f − J_cᵀλ − J_hᵀμ` (smooth part of the Lagrangian).
pub(super) fn lagrangian_gradient(dv: &PointDerivatives, mult: &Multipliers) -> Vec<f64> {
    let mut gl = dv.g.clone();
    dv.jc.tmul_add(&mult.inequality, -1.0, &mut gl);
    dv.jh.tmul_add(&mult.equality, -1.0, &mut gl);
    gl
}

/// Multipliers in the problem's conventions from a QP solution: `λ ≥ 0`, bound duals only where the
/// variable bound (not the step bound) defines the box side, norm subgradients projected onto `‖y‖ ≤ w`.
pub(super) fn extract_multipliers(
    sol: &QpSolution,
    x: &[f64],
    lower: &[f64],
    upper: &[f64],
    delta: f64,
    norms: &[NormData],
) -> Multipliers {
    let n = x.len();
    let mut lower_bound = vec![0.0; n];
    let mut upper_bound = vec![0.0; n];
    for j in 0..n {
        if lower[j].is_finite() && lower[j] - x[j] >= -delta {
            lower_bound[j] = sol.box_lower[j].max(0.0);
        }
        if upper[j].is_finite() && upper[j] - x[j] <= delta {
            upper_bound[j] = sol.box_upper[j].max(0.0);
        }
    }
    let norm_terms = sol
        .norm_duals
        .iter()
        .zip(norms)
        .map(|(y, nd)| {
            let ny = norm2(y);
            if ny > nd.weight && ny > 0.0 {
                y.iter().map(|v| v * nd.weight / ny).collect()
            } else {
                y.clone()
            }
        })
        .collect();
    Multipliers {
        inequality: sol.lambda.iter().map(|v| v.max(0.0)).collect(),
        equality: sol.mu.clone(),
        lower_bound,
        upper_bound,
        norm_terms,
    }
}

/// Scaled KKT residual: `max(‖∇ₓL‖∞ / max(1, ‖∇f‖∞), complementarity / max(1, |f|))`.
pub(super) fn kkt_residual(
    pt: &PointValues,
    dv: &PointDerivatives,
    mult: &Multipliers,
    norms: &[NormData],
    lower: &[f64],
    upper: &[f64],
) -> f64 {
    let mut gl = lagrangian_gradient(dv, mult);
    for (k, nd) in norms.iter().enumerate() {
        tmul_add(nd.rows(&dv.norm_jac[k]), &mult.norm_terms[k], &mut gl);
    }
    for ((gj, zu), zl) in gl.iter_mut().zip(&mult.upper_bound).zip(&mult.lower_bound) {
        *gj += zu - zl;
    }
    let stationarity = norm_inf(&gl) / norm_inf(&dv.g).max(1.0);
    let mut compl = 0.0_f64;
    for (l, c) in mult.inequality.iter().zip(&pt.c) {
        compl = compl.max((l * c).abs());
    }
    for j in 0..pt.x.len() {
        if mult.lower_bound[j] > 0.0 {
            compl = compl.max(mult.lower_bound[j] * (pt.x[j] - lower[j]));
        }
        if mult.upper_bound[j] > 0.0 {
            compl = compl.max(mult.upper_bound[j] * (upper[j] - pt.x[j]));
        }
    }
    for ((nd, r), y) in norms.iter().zip(&pt.residuals).zip(&mult.norm_terms) {
        compl = compl.max(nd.weight * norm2(r) - dot(y, r));
    }
    let complementarity = compl / pt.objective().abs().max(1.0);
    stationarity.max(complementarity)
}
