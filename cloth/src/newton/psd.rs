//! The per-constraint positive semidefinite projection of the Newton matrix
//! ([`super::assembly::HessianKind::Projected`]): each constraint's block `s (∇C∇Cᵀ + C∇²C)` with
//! its negative eigenvalues set to 0.
//!
//! A block that a pivoted Cholesky finds semidefinite is kept as it is. Where `∇C` is in the null
//! space of `∇²C` — a constraint whose gradient does not change along its own direction, e.g. a
//! distance (`∇²C ∇C = 0`) — the two terms act on orthogonal subspaces, so the projection is `s ∇C∇Cᵀ` plus the projection of `s C ∇²C` alone: for a
//! compressed distance (`C < 0`, `∇²C ⪰ 0`) just `s ∇C∇Cᵀ`, with no eigendecomposition. Only the
//! other indefinite blocks take nalgebra's eigendecomposition, on a fixed-size matrix (no heap
//! allocation). On `u_obstacle` at n = 40 (per-call timers, loaded host) the eigendecomposition of
//! every indefinite block made a projected assembly 7.6 ms against 1.2 ms for the exact one; with
//! the null-space case it is about 3.5 ms.

use super::assembly::local_hessian;
use super::terms::MAX_DOF;
use nalgebra::allocator::Allocator;
use nalgebra::{ArrayStorage, Const, DefaultAllocator, DimDiff, DimSub, SMatrix, U1};

/// Overwrites `h` (holding `∇²C`, `d × d` row-major, `d = g.len()`) with the projection of
/// `s (∇C∇Cᵀ + C∇²C)` onto the semidefinite matrices (`g = ∇C`, `c = C`).
pub(super) fn projected_local_hessian(s: f64, c: f64, g: &[f64], h: &mut [f64]) {
    let d = g.len();
    if !gradient_in_null_space(g, h) {
        local_hessian(s, c, g, h);
        return project_psd(h, d);
    }
    // Orthogonal ranges: project `s C ∇²C` alone, then add `s ∇C∇Cᵀ`.
    h.iter_mut().for_each(|v| *v *= s * c);
    if !is_semidefinite(h, d) {
        h.iter_mut().for_each(|v| *v = -*v);
        if is_semidefinite(h, d) {
            h.fill(0.0);
        } else {
            // `h` failed the semidefinite test above (negation is exact): straight to the
            // eigendecomposition.
            h.iter_mut().for_each(|v| *v = -*v);
            clamp(h, d);
        }
    }
    for a in 0..d {
        for b in 0..d {
            h[a * d + b] += s * g[a] * g[b];
        }
    }
}

/// Whether `∇²C ∇C = 0` up to round-off (`h` holds `∇²C`).
fn gradient_in_null_space(g: &[f64], h: &[f64]) -> bool {
    let d = g.len();
    let h_max = h.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let g_max = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = (d * d) as f64 * f64::EPSILON * h_max * g_max;
    h.chunks_exact(d)
        .all(|row| row.iter().zip(g).map(|(a, b)| a * b).sum::<f64>().abs() <= tol)
}

/// Sets the negative eigenvalues of the symmetric `d × d` matrix `h` to 0 (a block that
/// [`is_semidefinite`] passes is left as it is, without the eigendecomposition). The
/// eigendecomposition is nalgebra's on a fixed-size matrix of the block's size (`d = 3 · arity`,
/// arity 1 to [`crate::constraint::MAX_ARITY`]), so it allocates nothing: with heap-allocated
/// dynamic matrices it was 14% of a 40 × 40 Newton rollout with ∇L.
pub(super) fn project_psd(h: &mut [f64], d: usize) {
    if !is_semidefinite(h, d) {
        clamp(h, d);
    }
}

/// [`clamp_eigenvalues`] for the block size `d`.
fn clamp(h: &mut [f64], d: usize) {
    match d {
        3 => clamp_eigenvalues::<3>(h),
        6 => clamp_eigenvalues::<6>(h),
        9 => clamp_eigenvalues::<9>(h),
        12 => clamp_eigenvalues::<12>(h),
        _ => panic!("a constraint block has 3 to {MAX_DOF} coordinates, not {d}"),
    }
}

/// `Q max(Λ, 0) Qᵀ` of the symmetric `D × D` row-major `h` (symmetrized against round-off).
fn clamp_eigenvalues<const D: usize>(h: &mut [f64])
where
    Const<D>: DimSub<U1>,
    DefaultAllocator: Allocator<DimDiff<Const<D>, U1>>,
{
    // Column-major storage of a symmetric matrix: its rows.
    let cols: [[f64; D]; D] = std::array::from_fn(|a| std::array::from_fn(|b| h[a * D + b]));
    let eig = SMatrix::from_array_storage(ArrayStorage(cols)).symmetric_eigen();
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return;
    }
    let q = &eig.eigenvectors;
    let p = q
        * SMatrix::<f64, D, D>::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0)))
        * q.transpose();
    for a in 0..D {
        for b in 0..D {
            h[a * D + b] = 0.5 * (p[(a, b)] + p[(b, a)]);
        }
    }
}

/// Whether the symmetric `d × d` matrix `h` is positive semidefinite up to round-off, by Cholesky
/// with diagonal pivoting: the largest remaining diagonal is eliminated first; once it is at
/// round-off (`d²ε` of the largest entry), the rest must be round-off too. Eigenvalues down to
/// about minus that round-off pass (they are noise of a semidefinite block).
fn is_semidefinite(h: &[f64], d: usize) -> bool {
    let mut a = [0.0; MAX_DOF * MAX_DOF];
    a[..d * d].copy_from_slice(&h[..d * d]);
    let scale = a[..d * d].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = (d * d) as f64 * f64::EPSILON * scale;
    let mut left = [true; MAX_DOF];
    for _ in 0..d {
        let (k, pivot) = (0..d).filter(|&i| left[i]).map(|i| (i, a[i * d + i])).fold(
            (usize::MAX, f64::NEG_INFINITY),
            |b, c| if c.1 > b.1 { c } else { b },
        );
        if pivot <= tol {
            // The remainder must vanish: a semidefinite matrix with round-off diagonals has
            // round-off off-diagonals too (|a_ij| ≤ √(a_ii a_jj)).
            return (0..d).filter(|&i| left[i]).all(|i| {
                (0..d)
                    .filter(|&j| left[j])
                    .all(|j| a[i * d + j].abs() <= tol)
            });
        }
        left[k] = false;
        for i in (0..d).filter(|&i| left[i]) {
            let f = a[i * d + k] / pivot;
            for j in (0..d).filter(|&j| left[j]) {
                a[i * d + j] -= f * a[k * d + j];
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::{is_semidefinite, project_psd, projected_local_hessian};
    use nalgebra::{DMatrix, SymmetricEigen};
    use proptest::prelude::*;

    /// The reference: `Q max(Λ, 0) Qᵀ` from nalgebra's dynamic eigendecomposition.
    fn clamped_reference(h: &[f64], d: usize) -> DMatrix<f64> {
        let eig = SymmetricEigen::new(DMatrix::from_row_slice(d, d, h));
        let l = eig.eigenvalues.map(|l| l.max(0.0));
        &eig.eigenvectors * DMatrix::from_diagonal(&l) * eig.eigenvectors.transpose()
    }

    proptest! {
        /// Every block size a constraint can have (arity 1 to 4), random symmetric blocks with
        /// some negative eigenvalues: the fixed-size projection equals the dynamic
        /// eigendecomposition's, and its result is semidefinite.
        #[test]
        fn projection_matches_the_eigendecomposition(
            arity in 1usize..=4,
            entries in proptest::collection::vec(-1.0f64..1.0, 144),
            shift in -0.5f64..0.5,
        ) {
            let d = 3 * arity;
            let mut h = vec![0.0; d * d];
            for a in 0..d {
                for b in 0..d {
                    h[a * d + b] = entries[a.max(b) * 12 + a.min(b)] + if a == b { shift } else { 0.0 };
                }
            }
            let expected = clamped_reference(&h, d);
            project_psd(&mut h, d);
            for a in 0..d {
                for b in 0..d {
                    prop_assert!((h[a * d + b] - expected[(a, b)]).abs() < 1e-12,
                        "d = {d}: entry ({a}, {b}) {} vs {}", h[a * d + b], expected[(a, b)]);
                }
            }
            let min = SymmetricEigen::new(DMatrix::from_row_slice(d, d, &h)).eigenvalues.min();
            prop_assert!(min > -1e-12, "d = {d}: smallest eigenvalue {min}");
        }
    }

    /// `Q diag(λ) Qᵀ` for a fixed rotation-like orthogonal `Q` (3 × 3 Householder).
    fn with_eigenvalues(l: [f64; 3]) -> Vec<f64> {
        let v = [1.0, 2.0, -2.0];
        let q = |i: usize, j: usize| f64::from(u8::from(i == j)) - 2.0 * v[i] * v[j] / 9.0;
        let mut h = vec![0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                h[i * 3 + j] = (0..3).map(|k| q(i, k) * l[k] * q(j, k)).sum();
            }
        }
        h
    }

    #[test]
    fn semidefinite_test_matches_the_eigenvalues() {
        assert!(is_semidefinite(&with_eigenvalues([3.0, 1.0, 0.5]), 3));
        assert!(is_semidefinite(&with_eigenvalues([3.0, 0.0, 0.0]), 3));
        assert!(is_semidefinite(&[0.0; 9], 3));
        assert!(!is_semidefinite(&with_eigenvalues([3.0, 1.0, -1e-6]), 3));
        assert!(!is_semidefinite(&with_eigenvalues([3.0, 0.0, -0.5]), 3));
        // Zero diagonal, non-zero coupling: indefinite.
        assert!(!is_semidefinite(
            &[0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            3
        ));
    }

    #[test]
    fn projection_clamps_negative_eigenvalues_and_keeps_semidefinite_blocks() {
        let psd = with_eigenvalues([2.0, 1.0, 0.0]);
        let mut h = psd.clone();
        project_psd(&mut h, 3);
        assert_eq!(h, psd);
        let mut h = with_eigenvalues([2.0, 1.0, -4.0]);
        project_psd(&mut h, 3);
        let expected = with_eigenvalues([2.0, 1.0, 0.0]);
        for (a, b) in h.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-12, "{h:?} vs {expected:?}");
        }
    }

    /// `s (ggᵀ + c K)` as a row-major vector.
    fn block(s: f64, c: f64, g: &[f64], k: &[f64]) -> Vec<f64> {
        let d = g.len();
        (0..d * d)
            .map(|i| s * (g[i / d] * g[i % d] + c * k[i]))
            .collect()
    }

    proptest! {
        /// The local projection equals the eigendecomposition's clamp of the whole block, both
        /// where `∇C` is in `∇²C`'s null space (a distance-like `∇²C = P A Aᵀ P + c₂ P B Bᵀ P`,
        /// `P = I − ĝĝᵀ`, of either sign of `C`) and for a general `∇²C`.
        #[test]
        fn local_projection_matches_the_eigendecomposition(
            arity in 1usize..=4,
            entries in proptest::collection::vec(-1.0f64..1.0, 2 * 144 + 12),
            c in -2.0f64..2.0,
            c2 in -1.0f64..1.0,
            s in 0.1f64..100.0,
        ) {
            let d = 3 * arity;
            let g: Vec<f64> = entries[288..288 + d].to_vec();
            let gn = g.iter().map(|v| v * v).sum::<f64>();
            let p = |i: usize, j: usize| f64::from(u8::from(i == j)) - g[i] * g[j] / gn;
            let (a, b) = (&entries[..144], &entries[144..288]);
            // A general symmetric K, and a null-space one.
            let general: Vec<f64> = (0..d * d).map(|i| a[(i / d).max(i % d) * 12 + (i / d).min(i % d)]).collect();
            let gram = |m: &[f64], i: usize, j: usize| (0..d).map(|l| m[i * 12 + l] * m[j * 12 + l]).sum::<f64>();
            let mut null = vec![0.0; d * d];
            for i in 0..d {
                for j in 0..d {
                    for k in 0..d {
                        for l in 0..d {
                            null[i * d + j] += p(i, k) * (gram(a, k, l) + c2 * gram(b, k, l)) * p(l, j);
                        }
                    }
                }
            }
            for k in [general, null] {
                let expected = clamped_reference(&block(s, c, &g, &k), d);
                let mut h = k.clone();
                projected_local_hessian(s, c, &g, &mut h);
                let scale = expected.iter().fold(1.0f64, |m, v| m.max(v.abs()));
                for i in 0..d {
                    for j in 0..d {
                        prop_assert!((h[i * d + j] - expected[(i, j)]).abs() < 1e-11 * scale,
                            "d = {d}: ({i}, {j}) {} vs {}", h[i * d + j], expected[(i, j)]);
                    }
                }
            }
        }
    }
}
