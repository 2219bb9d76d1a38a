//! The fit's small dense algebra: the Gauss–Newton normal equations, the Levenberg–Marquardt
//! step, and the standard errors and identifiability at the fit.
//!
//! Standard errors come from the Gauss–Newton curvature: the covariance of the log-factors is
//! `σ² (JᵀJ)⁺` (`σ` the noise, estimated from the residuals when not given; with given noise the
//! Jacobian is already weighted by it). A direction of `JᵀJ` with no curvature (relative to its
//! largest, after scaling each parameter to unit curvature) is one the observations cannot see:
//! every parameter with a part along it has no standard error. A parameter is *identifiable*
//! when its relative standard error is at most [`IDENTIFIABLE`] with a noise no smaller than
//! [`IDENTIFIABILITY_FLOOR`] of the cloth's size, so that exact observations, whose estimated
//! noise is round-off, still flag a parameter they barely move.

use nalgebra::{DMatrix, DVector};

/// The largest relative standard error (of the log-factor) at which a parameter counts as
/// identifiable: the observations fix it within about ±40% at one standard error.
pub const IDENTIFIABLE: f64 = 0.5;

/// The smallest noise, as a fraction of the cloth's size, that identifiability is judged at
/// (1e-4: 0.04 mm on a 0.4 m towel, below any tracker's error).
pub const IDENTIFIABILITY_FLOOR: f64 = 1e-4;

/// Curvature below this fraction of the largest (after scaling) counts as none.
const RANK_TOLERANCE: f64 = 1e-12;

/// A parameter's spread at the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    /// The standard error of its log-factor; `None` where the observations do not determine it.
    pub log: Option<f64>,
    /// Whether the observations determine it ([`IDENTIFIABLE`]).
    pub identifiable: bool,
}

/// `(JᵀJ, Jᵀr)` for the row-major `m × np` Jacobian `jac` and residuals `r`.
pub fn normal_equations(jac: &[f64], r: &[f64], np: usize) -> (DMatrix<f64>, DVector<f64>) {
    let j = DMatrix::from_row_slice(r.len(), np, jac);
    let r = DVector::from_column_slice(r);
    (j.transpose() * &j, j.transpose() * r)
}

/// The Levenberg–Marquardt step `−(A + λ diag A)⁻¹ g`, the diagonal floored at a tiny fraction
/// of its largest entry so that a parameter the residuals do not move gets no step.
pub fn damped_step(a: &DMatrix<f64>, g: &DVector<f64>, lambda: f64) -> Vec<f64> {
    let n = a.nrows();
    let top = (0..n)
        .map(|i| a[(i, i)])
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut m = a.clone();
    for i in 0..n {
        m[(i, i)] += lambda * a[(i, i)].max(1e-12 * top) + 1e-15 * top;
    }
    match m.cholesky() {
        Some(c) => (-c.solve(g)).iter().copied().collect(),
        None => vec![0.0; n],
    }
}

/// Each parameter's [`Spread`] from the Jacobian `jac` (`m × np`, weighted by `1/σ` when
/// `noise_known`), the noise `sigma` (given or estimated) and the cloth's size `extent`.
pub fn standard_errors(
    jac: &[f64],
    np: usize,
    noise_known: bool,
    sigma: f64,
    extent: f64,
) -> Vec<Spread> {
    let m = jac.len() / np.max(1);
    let (a, _) = normal_equations(jac, &vec![0.0; m], np);
    let floor = IDENTIFIABILITY_FLOOR * extent;
    // Variance factors: for the errors, and for identifiability (the noise floored).
    let (scale, scale_id) = if noise_known {
        (1.0, (floor / sigma).max(1.0).powi(2))
    } else {
        (sigma * sigma, sigma.max(floor).powi(2))
    };
    let variance = pseudo_inverse_diagonal(&a);
    variance
        .iter()
        .map(|v| {
            let log = v.map(|v| (scale * v).sqrt()).filter(|x| x.is_finite());
            let id = v.map(|v| (scale_id * v).sqrt());
            Spread {
                log,
                identifiable: id.is_some_and(|x| x.is_finite() && x <= IDENTIFIABLE),
            }
        })
        .collect()
}

/// The diagonal of `A⁺` for the semidefinite `A`, `None` for a parameter with a part along a
/// direction of no curvature.
fn pseudo_inverse_diagonal(a: &DMatrix<f64>) -> Vec<Option<f64>> {
    let n = a.nrows();
    let d: Vec<f64> = (0..n).map(|i| a[(i, i)].max(0.0).sqrt()).collect();
    let live: Vec<usize> = (0..n).filter(|&i| d[i] > 0.0).collect();
    let mut out = vec![None; n];
    if live.is_empty() {
        return out;
    }
    let b = DMatrix::from_fn(live.len(), live.len(), |i, j| {
        a[(live[i], live[j])] / (d[live[i]] * d[live[j]])
    });
    let eig = b.symmetric_eigen();
    let top = eig.eigenvalues.iter().copied().fold(0.0, f64::max);
    for (i, &p) in live.iter().enumerate() {
        let mut var = 0.0;
        let mut blind = false;
        for (k, &mu) in eig.eigenvalues.iter().enumerate() {
            let v2 = eig.eigenvectors[(i, k)].powi(2);
            if mu > RANK_TOLERANCE * top {
                var += v2 / mu;
            } else if v2 > 1e-8 {
                blind = true;
            }
        }
        out[p] = (!blind).then(|| var / (d[p] * d[p]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `J = diag(2, 0.5)`: variances `1/4` and `4` (σ = 1); a zero column has none.
    #[test]
    fn standard_errors_of_a_diagonal_problem() {
        let s = standard_errors(&[2.0, 0.0, 0.0, 0.5], 2, true, 1.0, 1.0);
        assert!((s[0].log.unwrap() - 0.5).abs() < 1e-12);
        assert!((s[1].log.unwrap() - 2.0).abs() < 1e-12);
        assert!(s[0].identifiable && !s[1].identifiable);
        let s = standard_errors(&[2.0, 0.0, 1.0, 0.0], 2, true, 1.0, 1.0);
        assert_eq!(s[1].log, None);
        assert!(!s[1].identifiable);
        assert!((s[0].log.unwrap() - 1.0 / 5f64.sqrt()).abs() < 1e-12);
    }

    /// Two columns that are equal: each alone undetermined.
    #[test]
    fn collinear_parameters_have_no_standard_error() {
        let s = standard_errors(&[1.0, 1.0, 2.0, 2.0, 3.0, 3.0], 2, false, 0.1, 1.0);
        assert_eq!(s[0].log, None);
        assert_eq!(s[1].log, None);
    }

    /// The damped step solves the Gauss–Newton system as `λ → 0`.
    #[test]
    fn the_damped_step_tends_to_gauss_newton() {
        let (a, g) = normal_equations(&[2.0, 1.0, 0.0, 1.0, 1.0, 0.0], &[1.0, 2.0, 3.0], 2);
        let step = damped_step(&a, &g, 1e-12);
        let exact = a.clone().cholesky().unwrap().solve(&(-g));
        assert!((step[0] - exact[0]).abs() < 1e-9 && (step[1] - exact[1]).abs() < 1e-9);
    }
}
