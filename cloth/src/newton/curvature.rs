//! Where the exact Hessian is indefinite: leaving a saddle of `Φ` (a direction of negative
//! curvature of the exact Hessian, and the step along it), and shifting a stalled iteration's
//! Hessian.
//!
//! Where Newton's iteration comes to rest at a stationary point that is not a minimizer (a
//! symmetric cloth under a symmetric load stays symmetric, and past a buckling load its symmetric
//! state is a saddle), no Newton step leaves it. Its unstable mode does: the eigenvector of the
//! generalized problem `(H_p − H) v = μ H_p v` with the largest `μ` (`H` the exact Hessian, `H_p`
//! the per-constraint PSD projection, so `H_p − H` is positive semidefinite and `vᵀHv < 0`
//! exactly when `μ > 1`), found by Lanczos on `H_p⁻¹ (H_p − H)` with `H_p`'s Cholesky factor
//! (at `u_obstacle` 40 × 40's saddles the top two `μ` are 1.0016 and about 0.99: the power
//! iteration this replaced took 130 solves per saddle). The step off the saddle tries both signs
//! of the mode and takes the one that lowers `Φ` more ([`escape_length`]); [`orient`] only fixes
//! the sign the search starts from, which decides an exact tie: toward the predicted state `x̃`
//! (the way the step's inertia and gravity pull), and where that pull has no component along the
//! mode beyond round-off (a symmetric cloth under a symmetric load and an antisymmetric mode),
//! the sign that makes the mode's product with a fixed generic vector positive: a choice
//! round-off cannot flip (the pull's component and the mode's largest coordinate can: at a
//! symmetric saddle both are ties decided by the last bits of the state, which any change of the
//! solver's arithmetic moves).
//!
//! Away from the tolerance, where the exact Hessian is indefinite, the iteration takes the
//! per-term semidefinite projection ([`super::psd`]). Where a whole projected step leaves the
//! residual nearly where it was (the projection stiffens the soft modes the cloth moves along,
//! as when it crumples on the ground), the solve shifts the exact Hessian by a multiple of its
//! mean diagonal instead, the smallest of a geometric sequence that factorizes
//! ([`NewtonSystem::shift_exact`]).

use super::assembly::{HessianKind, Pattern};
use super::factor::Factor;
use super::solve::NewtonSystem;
use super::stats::StepStats;
use crate::geometry::dot;
use autodiff::Tensor;

/// Lanczos iterations at most (the basis is kept: 2 vectors per iteration).
const MAX_LANCZOS_ITERATIONS: usize = 150;
/// The top Ritz pair `(μ, v)` is taken when `‖H_p⁻¹(H_p − H)v − μv‖` (in the `H_p` norm) is at
/// most this fraction of `μ`. The escape needs a direction of clearly negative curvature, not the
/// eigenvector to round-off: at u_obstacle 100 × 100, 1e-3 instead of 1e-10 takes the forward
/// pass from 935 to 554 s with the same counts (at 40 × 40: 218 Newton iterations against 216,
/// `L` the same to 13 digits; docs/performance.md).
const LANCZOS_TOLERANCE: f64 = 1e-3;
/// The pull toward `x̃` orients the mode when its component along it exceeds this fraction of
/// the two norms' product; below, it is taken for round-off (measured at `u_obstacle` 40 × 40's
/// symmetric saddle: 5e-13 and 1e-11 under two orders of the same arithmetic; a genuinely
/// asymmetric pull there: 9e-5).
const PULL_TIE: f64 = 1e-6;

/// A fixed, generic vector of length `n` (entries in `[−½, ½)`): no coordinate direction is
/// favoured.
fn generic(n: usize) -> Vec<f64> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// `y = A v` for the symmetric matrix whose lower triangle is `values` in `pattern`.
/// Column `j`'s contributions to `y[j]` are summed in a register, in the same order as entry by
/// entry (the lower triangle has no row above `j`), so the bits are those of the plain loop.
pub(super) fn sym_mul(pattern: &Pattern, values: &[f64], v: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    for j in 0..pattern.n_dof {
        let col = pattern.col_ptr[j]..pattern.col_ptr[j + 1];
        let (vj, mut yj) = (v[j], y[j]);
        for (&i, &a) in pattern.row_idx[col.clone()].iter().zip(&values[col]) {
            if i == j {
                yj += a * vj;
            } else {
                y[i] += a * vj;
                yj += a * v[i];
            }
        }
        y[j] = yj;
    }
}

/// A unit direction (degree-of-freedom order) along which the exact Hessian (`exact`, lower
/// triangle in `pattern`) is negative, or `None` when none is found: the top eigenvector of
/// `(H_p − H) v = μ H_p v` by Lanczos in the `H_p` inner product with full reorthogonalization
/// (each iteration one solve with `factor` and two products), stopped when the top Ritz pair's
/// residual is below [`LANCZOS_TOLERANCE`] of its value. `projected` holds `H_p` and `factor`
/// its factorization.
pub(super) fn negative_curvature(
    pattern: &Pattern,
    exact: &[f64],
    projected: &[f64],
    factor: &Factor,
) -> Option<Vec<f64>> {
    let n = pattern.n_dof;
    if n == 0 {
        return None;
    }
    let gap: Vec<f64> = projected.iter().zip(exact).map(|(p, e)| p - e).collect();
    // The Lanczos basis q_j (H_p-orthonormal) and H_p q_j.
    let (mut q, mut bq): (Vec<Vec<f64>>, Vec<Vec<f64>>) = (Vec::new(), Vec::new());
    let (mut alpha, mut beta) = (Vec::new(), Vec::new());
    let mut w = generic(n);
    let mut bw = vec![0.0; n];
    sym_mul(pattern, projected, &w, &mut bw);
    let mut top = None;
    for _ in 0..MAX_LANCZOS_ITERATIONS.min(n) {
        let norm = dot(&w, &bw).sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            break;
        }
        if let Some(&b) = beta.last() {
            if norm <= f64::EPSILON * b {
                break; // an invariant subspace: the Ritz pairs are exact
            }
        }
        if !q.is_empty() {
            beta.push(norm);
        }
        w.iter_mut().for_each(|a| *a /= norm);
        bw.iter_mut().for_each(|a| *a /= norm);
        q.push(std::mem::take(&mut w));
        bq.push(std::mem::take(&mut bw));
        let j = q.len() - 1;
        // w = H_p⁻¹ (H_p − H) q_j, then H_p-orthogonalized against the basis (twice).
        let mut r = vec![0.0; n];
        sym_mul(pattern, &gap, &q[j], &mut r);
        alpha.push(dot(&q[j], &r));
        factor.solve_in_place(&mut r, 1);
        w = r;
        for _ in 0..2 {
            for (qi, bqi) in q.iter().zip(&bq) {
                let c = dot(bqi, &w);
                w.iter_mut().zip(qi).for_each(|(a, b)| *a -= c * b);
            }
        }
        bw = vec![0.0; n];
        sym_mul(pattern, projected, &w, &mut bw);
        let (theta, s) = top_ritz_pair(&alpha, &beta);
        let residual = dot(&w, &bw).max(0.0).sqrt() * s[j].abs();
        top = Some(s);
        if residual <= LANCZOS_TOLERANCE * theta.abs() {
            break;
        }
    }
    let s = top?;
    let mut v = vec![0.0; n];
    for (qi, si) in q.iter().zip(&s) {
        v.iter_mut().zip(qi).for_each(|(a, b)| *a += si * b);
    }
    let norm = dot(&v, &v).sqrt();
    if norm == 0.0 || !norm.is_finite() {
        return None;
    }
    v.iter_mut().for_each(|a| *a /= norm);
    let mut y = vec![0.0; n];
    sym_mul(pattern, exact, &v, &mut y);
    (dot(&v, &y) < 0.0).then_some(v)
}

/// The largest eigenvalue of the symmetric tridiagonal matrix with diagonal `alpha` and
/// off-diagonal `beta`, and its unit eigenvector.
fn top_ritz_pair(alpha: &[f64], beta: &[f64]) -> (f64, Vec<f64>) {
    let m = alpha.len();
    let t = nalgebra::DMatrix::from_fn(m, m, |i, j| {
        if i == j {
            alpha[i]
        } else if i == j + 1 {
            beta[j]
        } else if j == i + 1 {
            beta[i]
        } else {
            0.0
        }
    });
    let eig = nalgebra::SymmetricEigen::new(t);
    let k = (0..m)
        .max_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
        .expect("a nonempty basis");
    (
        eig.eigenvalues[k],
        eig.eigenvectors.column(k).iter().copied().collect(),
    )
}

/// Orients the mode `v` toward the predicted state: the sign of `vᵀ M (x̃ − x)` (`m_pull` is
/// `M (x̃ − x)` in degree-of-freedom order) where it exceeds round-off ([`PULL_TIE`]); else the
/// sign that makes `vᵀw` positive for a fixed generic `w`.
pub(super) fn orient(v: &mut [f64], m_pull: &[f64]) {
    let along = dot(v, m_pull);
    let scale = dot(v, v).sqrt() * dot(m_pull, m_pull).sqrt();
    let flip = if along.abs() > PULL_TIE * scale {
        along < 0.0
    } else {
        dot(v, &generic(v.len())) < 0.0
    };
    if flip {
        v.iter_mut().for_each(|a| *a = -*a);
    }
}

/// The step length along `v` that lowers `phi(η) = Φ(x + ηv)` the most among `η₀ 2^k` (from
/// `η₀`, doubling while `Φ` keeps falling); `None` when no length lowers `Φ` below `phi0` by
/// more than its round-off. `phi` is `+∞` where a step filter stops the move, and then stops
/// every longer one along the ray: the search ends there.
fn step_length(eta0: f64, phi0: f64, mut phi: impl FnMut(f64) -> f64) -> Option<f64> {
    let floor = phi0 - 1024.0 * f64::EPSILON * phi0.abs();
    let (mut best, mut best_phi) = (None, floor);
    let mut eta = eta0;
    for _ in 0..64 {
        let p = phi(eta);
        if p == f64::INFINITY {
            break;
        }
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
pub(super) fn escape_length(eta0: f64, phi0: f64, mut phi: impl FnMut(f64) -> f64) -> Option<f64> {
    let ahead = step_length(eta0, phi0, &mut phi).map(|e| (e, phi(e)));
    let back = step_length(eta0, phi0, |e| phi(-e)).map(|e| (-e, phi(-e)));
    let tie = 1024.0 * f64::EPSILON * phi0.abs();
    match (ahead, back) {
        (Some(a), Some(b)) => Some(if b.1 < a.1 - tie { b.0 } else { a.0 }),
        (a, b) => a.or(b).map(|(e, _)| e),
    }
}

/// Saddles one solve leaves at most (a guard against cycling between saddles).
const MAX_SADDLE_ESCAPES: usize = 8;

/// A whole step with the projected Hessian that leaves the KKT residual above this fraction of
/// where it started has stalled (the solve then shifts the exact Hessian instead).
const STALLED_PROJECTION: f64 = 0.9;
/// The first shift of the exact Hessian, in units of its mean diagonal.
const FIRST_SHIFT: f64 = 1e-3;

/// A solve's shift state after an iterate with residual `res`: `shift` as it was, or, where
/// shifting is `enabled` and the whole projected step that started at residual `projected_from`
/// left the residual above [`STALLED_PROJECTION`] of that (the projection stiffens the soft
/// modes the iterate moves along), [`FIRST_SHIFT`]: from then on the solve shifts the exact
/// Hessian instead of projecting it.
pub(super) fn shift_after(
    shift: Option<f64>,
    projected_from: Option<f64>,
    res: f64,
    enabled: bool,
) -> Option<f64> {
    let stalled = projected_from.is_some_and(|before| res > STALLED_PROJECTION * before);
    shift.or((enabled && stalled).then_some(FIRST_SHIFT))
}
/// Factorizations tried per shifted Newton matrix (the shift grows 4× each).
const SHIFT_TRIES: usize = 12;

impl NewtonSystem {
    /// Factorizes the exact Hessian in `values` (not positive definite) shifted by `μ` times the
    /// mean of its diagonal's magnitudes, `μ` from a quarter of the `last` shift up by 4× until
    /// the factorization succeeds (at most [`SHIFT_TRIES`] tries): that `μ`, or `None`, with
    /// `values` as they were, when none does.
    pub(super) fn shift_exact(&mut self, last: f64) -> Option<f64> {
        let diag = &self.pattern.diag;
        let base: Vec<f64> = diag.iter().map(|&i| self.values[i]).collect();
        let mean = base.iter().map(|v| v.abs()).sum::<f64>() / base.len().max(1) as f64;
        let mut mu = 0.25 * last;
        for _ in 0..SHIFT_TRIES {
            for (&i, &b) in diag.iter().zip(&base) {
                self.values[i] = b + mu * mean;
            }
            if self.factor.factorize(&self.pattern, &self.values) {
                return Some(mu);
            }
            mu *= 4.0;
        }
        for (&i, &b) in diag.iter().zip(&base) {
            self.values[i] = b;
        }
        None
    }

    /// At `x`, a stationary point of `Φ` for `xt` that is not a minimizer: moves `x` along the
    /// exact Hessian's unstable mode, the way and by the length that lower `Φ` the most
    /// ([`escape_length`]; at a tie, the way [`orient`] picks) and returns the new `Φ`
    /// ([`Escape::Left`]); leaves `x` where it is when no direction of negative curvature is
    /// found or the solve has left [`MAX_SADDLE_ESCAPES`] saddles already
    /// ([`Escape::NoDirection`]), or when no length along the mode lowers `Φ` by more than its
    /// round-off ([`Escape::TooShallow`]).
    pub(super) fn leave_saddle(
        &mut self,
        x: &mut Tensor,
        xt_d: &[f64],
        stats: &mut StepStats,
    ) -> Escape {
        if stats.escapes == MAX_SADDLE_ESCAPES {
            return Escape::NoDirection;
        }
        self.assemble_at(x.data(), xt_d, HessianKind::Exact);
        let exact = self.values.clone();
        self.assemble_at(x.data(), xt_d, HessianKind::Projected);
        if !self.factor.factorize(&self.pattern, &self.values) {
            return Escape::NoDirection;
        }
        self.saddle_searches += 1;
        let p = &self.pattern;
        let Some(mut v) = negative_curvature(p, &exact, &self.values, &self.factor) else {
            return Escape::NoDirection;
        };
        self.contacts.project_tangent(&mut v);
        // M (x̃ − x) in degree-of-freedom order.
        let diff: Vec<f64> = xt_d.iter().zip(x.data()).map(|(a, b)| a - b).collect();
        let mut free = vec![0.0; p.n_dof];
        p.gather(&diff, &mut free);
        let mut scattered = vec![0.0; diff.len()];
        p.add_mass_times(&free, &mut scattered);
        let mut pull = free;
        p.gather(&scattered, &mut pull);
        orient(&mut v, &pull);
        let phi0 = p.energy(x.data(), xt_d);
        let x_max = x.data().iter().fold(1.0f64, |m, a| m.max(a.abs()));
        let mut trial = x.clone();
        let contacts = &self.contacts;
        // The doubling search asks the filters of many short moves along `v`: those no
        // self-contact pair can stop skip its sweep.
        let free = p.self_free_move(x.data());
        let mut phi_at = |eta: f64| {
            if p.max_step_free(x.data(), eta, &v, free) < 1.0 {
                // The move would pass a collider (smooth contact).
                return f64::INFINITY;
            }
            trial.data_mut().copy_from_slice(x.data());
            p.add_scaled(trial.data_mut(), eta, &v);
            contacts.project(trial.data_mut());
            p.energy(trial.data(), xt_d)
        };
        let Some(eta) = escape_length(f64::EPSILON.sqrt() * x_max, phi0, &mut phi_at) else {
            return Escape::TooShallow;
        };
        let phi_t = phi_at(eta);
        x.data_mut().copy_from_slice(trial.data());
        stats.escapes += 1;
        Escape::Left(phi_t)
    }
}

/// How [`NewtonSystem::leave_saddle`] ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Escape {
    /// `x` moved off the saddle; `Φ` there.
    Left(f64),
    /// No direction of negative curvature was found (or the solve may leave no more saddles).
    NoDirection,
    /// The unstable mode was found, but no step along it lowers `Φ` by more than its round-off:
    /// the saddle is too shallow to leave in `f64`. The iterates after it stay within round-off of
    /// it (their steps are of the size of the residual), so each would find the same mode and
    /// the same flat `Φ`: the solve gives up at once ([`crate::ClothError::NewtonSaddle`]).
    TooShallow,
}

#[cfg(test)]
mod tests {
    use super::{escape_length, orient, step_length};

    #[test]
    fn orientation_follows_the_pull_then_a_generic_vector() {
        let mut v = vec![0.6, -0.8];
        orient(&mut v, &[-1.0, 0.0]);
        assert_eq!(v, vec![-0.6, 0.8]);
        // A pull at round-off does not decide; the generic vector does, whatever v's sign.
        let w = super::generic(2);
        let mut v = vec![0.6, -0.8];
        orient(&mut v, &[1e-9, 1e-9 * 0.6 / 0.8]);
        assert!(super::dot(&v, &w) > 0.0);
        let mut minus = vec![-0.6, 0.8];
        orient(&mut minus, &[0.0, 0.0]);
        assert_eq!(minus, v);
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
    fn a_move_the_filter_stops_ends_the_search_along_its_ray() {
        // Blocked from η = 1e-3 on (as a step filter stops every longer move along a ray):
        // the search asks nothing past the first blocked length, and keeps the best before it.
        let mut asked = Vec::new();
        let mut phi = |e: f64| {
            asked.push(e);
            if e >= 1e-3 {
                f64::INFINITY
            } else {
                -e
            }
        };
        let eta = step_length(1e-8, 0.0, &mut phi).unwrap();
        assert!(eta < 1e-3 && 2.0 * eta >= 1e-3, "{eta}");
        assert_eq!(asked.iter().filter(|&&e| e >= 1e-3).count(), 1, "{asked:?}");
        // Blocked at once, and rising before it: no step.
        assert!(step_length(1e-8, 0.0, |e| if e > 1e-7 { f64::INFINITY } else { e }).is_none());
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
