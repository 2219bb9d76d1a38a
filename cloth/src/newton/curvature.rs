//! Leaving a saddle of `Φ`: a direction of negative curvature of the exact Hessian, and the
//! step along it.
//!
//! Where Newton's iteration comes to rest at a stationary point that is not a minimizer (a
//! symmetric cloth under a symmetric load stays symmetric, and past a buckling load its symmetric
//! state is a saddle), no Newton step leaves it. Its unstable mode does: the eigenvector of the
//! generalized problem `(H_p − H) v = μ H_p v` with the largest `μ` (`H` the exact Hessian, `H_p`
//! the per-constraint PSD projection, so `H_p − H` is positive semidefinite and `vᵀHv < 0`
//! exactly when `μ > 1`), found by power iteration on `H_p⁻¹ (H_p − H)` with `H_p`'s Cholesky
//! factor. Which way the cloth buckles is a modelling choice at an exact symmetry; the rule here
//! is geometric: toward the predicted state `x̃` (the way the step's inertia and gravity pull),
//! and at an exact tie the sign that makes the mode's largest coordinate positive.

use super::assembly::Pattern;
use super::factor::Factor;

/// Power iterations at most.
const MAX_POWER_ITERATIONS: usize = 200;
/// Relative change of the Rayleigh quotient at which the power iteration stops.
const POWER_TOLERANCE: f64 = 1e-10;

/// `y = A v` for the symmetric matrix whose lower triangle is `values` in `pattern`.
fn sym_mul(pattern: &Pattern, values: &[f64], v: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    for j in 0..pattern.n_dof {
        let col = pattern.col_ptr[j]..pattern.col_ptr[j + 1];
        for (&i, &a) in pattern.row_idx[col.clone()].iter().zip(&values[col]) {
            y[i] += a * v[j];
            if i != j {
                y[j] += a * v[i];
            }
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A unit direction (degree-of-freedom order) along which the exact Hessian (`exact`, lower
/// triangle in `pattern`) is negative, or `None` when the power iteration finds none.
/// `projected` holds `H_p` and `factor` its factorization.
pub fn negative_curvature(
    pattern: &Pattern,
    exact: &[f64],
    projected: &[f64],
    factor: &Factor,
) -> Option<Vec<f64>> {
    let n = pattern.n_dof;
    let gap: Vec<f64> = projected.iter().zip(exact).map(|(p, e)| p - e).collect();
    // A fixed, generic start (no coordinate direction is favoured).
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut v: Vec<f64> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let (mut y, mut hp_v) = (vec![0.0; n], vec![0.0; n]);
    let mut mu = 0.0;
    for _ in 0..MAX_POWER_ITERATIONS {
        let norm = dot(&v, &v).sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return None;
        }
        v.iter_mut().for_each(|a| *a /= norm);
        sym_mul(pattern, &gap, &v, &mut y);
        let dv = dot(&v, &y);
        factor.solve_in_place(&mut y, 1);
        // μ's Rayleigh quotient vᵀ(H_p − H)v / vᵀH_p v, for the stopping test.
        sym_mul(pattern, projected, &v, &mut hp_v);
        let next = dv / dot(&v, &hp_v);
        std::mem::swap(&mut v, &mut y);
        let converged = (next - mu).abs() <= POWER_TOLERANCE * next.abs();
        mu = next;
        if converged {
            break;
        }
    }
    let norm = dot(&v, &v).sqrt();
    if norm == 0.0 || !norm.is_finite() {
        return None;
    }
    v.iter_mut().for_each(|a| *a /= norm);
    sym_mul(pattern, exact, &v, &mut y);
    (dot(&v, &y) < 0.0).then_some(v)
}

/// Orients the mode `v` toward the predicted state: the sign of `vᵀ M (x̃ − x)` (`m_pull` is
/// `M (x̃ − x)` in degree-of-freedom order); at an exact tie, the sign that makes `v`'s largest
/// coordinate positive.
pub fn orient(v: &mut [f64], m_pull: &[f64]) {
    let along = dot(v, m_pull);
    let scale = dot(v, v).sqrt() * dot(m_pull, m_pull).sqrt();
    let flip = if along.abs() > 1e-12 * scale {
        along < 0.0
    } else {
        let big = v
            .iter()
            .fold(0.0f64, |b, &a| if a.abs() > b.abs() { a } else { b });
        big < 0.0
    };
    if flip {
        v.iter_mut().for_each(|a| *a = -*a);
    }
}

/// The step length along `v` that lowers `phi(η) = Φ(x + ηv)` the most among `η₀ 2^k` (from
/// `η₀`, doubling while `Φ` keeps falling); `None` when no length lowers `Φ` below `phi0` by
/// more than its round-off.
pub fn step_length(eta0: f64, phi0: f64, mut phi: impl FnMut(f64) -> f64) -> Option<f64> {
    let floor = phi0 - 1024.0 * f64::EPSILON * phi0.abs();
    let (mut best, mut best_phi) = (None, floor);
    let mut eta = eta0;
    for _ in 0..64 {
        let p = phi(eta);
        // NaN (a state too far to evaluate) counts as no decrease.
        if p < best_phi {
            best = Some(eta);
            best_phi = p;
        } else if best.is_some() {
            break;
        }
        eta *= 2.0;
    }
    best
}

/// The signed step along the mode `v` that lowers `phi(η) = Φ(x + ηv)` the most: the best
/// [`step_length`] each way, the lower one kept (an asymmetric saddle falls off one side); where
/// both lower `Φ` equally to its round-off (a symmetric saddle), the positive way, which
/// [`orient`] chose.
pub fn escape_length(eta0: f64, phi0: f64, mut phi: impl FnMut(f64) -> f64) -> Option<f64> {
    let ahead = step_length(eta0, phi0, &mut phi).map(|e| (e, phi(e)));
    let back = step_length(eta0, phi0, |e| phi(-e)).map(|e| (-e, phi(-e)));
    let tie = 1024.0 * f64::EPSILON * phi0.abs();
    match (ahead, back) {
        (Some(a), Some(b)) => Some(if b.1 < a.1 - tie { b.0 } else { a.0 }),
        (a, b) => a.or(b).map(|(e, _)| e),
    }
}

#[cfg(test)]
mod tests {
    use super::{escape_length, orient, step_length};

    #[test]
    fn orientation_follows_the_pull_then_the_largest_coordinate() {
        let mut v = vec![0.6, -0.8];
        orient(&mut v, &[-1.0, 0.0]);
        assert_eq!(v, vec![-0.6, 0.8]);
        let mut v = vec![0.6, -0.8];
        orient(&mut v, &[0.0, 0.0]);
        assert_eq!(v, vec![-0.6, 0.8]);
    }

    #[test]
    fn step_length_finds_the_minimum_of_a_double_well_within_a_factor_two() {
        // Φ(η) = −η² + η⁴: minimum at η = 1/√2 ≈ 0.707, value −1/4.
        let eta = step_length(1e-8, 0.0, |e| -e * e + e.powi(4)).unwrap();
        assert!((0.35..=1.42).contains(&eta), "{eta}");
        // A minimum at the start: no step.
        assert!(step_length(1e-8, 0.0, |e| e * e).is_none());
    }

    #[test]
    fn escape_takes_the_side_that_falls_further_and_the_positive_one_at_a_tie() {
        // −η² + η³/2 + η⁴/... : deeper on the negative side.
        let lopsided = |e: f64| -e * e + 0.5 * e.powi(3) + 0.25 * e.powi(4);
        assert!(escape_length(1e-8, 0.0, lopsided).unwrap() < 0.0);
        let symmetric = |e: f64| -e * e + e.powi(4);
        assert!(escape_length(1e-8, 0.0, symmetric).unwrap() > 0.0);
    }
}
