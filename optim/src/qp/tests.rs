//! Tests of the QP subproblem.

use super::*;
use crate::linalg::{DenseMatrix, SparseMatrix};
use crate::problem::NormTerm;
use clarabel::solver::IPSolver;
use solve::FALLBACKS;

#[test]
fn triplets_compress_sorted_and_merged() {
    let mut t = TripletBuilder::with_capacity(4);
    t.push(2, 0, 1.0);
    t.push(0, 0, 2.0);
    t.push(0, 0, 3.0);
    t.push(1, 1, 4.0);
    let c = t.into_csc(3, 2);
    assert_eq!(c.colptr, vec![0, 2, 3]);
    assert_eq!(c.rowval, vec![0, 2, 1]);
    assert_eq!(c.nzval, vec![5.0, 1.0, 4.0]);
    assert!(c.check_format().is_ok());
}

#[test]
fn huge_gradient_gives_the_clipped_step_and_unscaled_duals() {
    // The first QP of `swing` simulated with 1000 iterations per step, in miniature: 10 steps of
    // 6 controls from rest, identity Hessian, the step box ±0.5, one norm term per step
    // difference, and the rollout's gradient, whose entries fall from 1e10 (a nearly unstable
    // rollout) to 1e-4 over the steps. Clarabel reports `DualInfeasible` on this data with its defaults and
    // with every fallback setting; divided by its largest entry, it solves.
    let (steps, width) = (10, 6);
    let n = steps * width;
    // ∂L/∂U of `swing` at rest with 1000 iterations per step, rounded to 4 digits.
    #[rustfmt::skip]
    let g: [f64; 60] = [
        1.0608e-01, 1.0317e+10, -3.4232e-01, -1.4497e-01, 1.0532e+07, -3.3580e-01,
        1.0787e-01, 2.2234e+09, -3.4387e-01, -1.4346e-01, 7.0376e+06, -3.3259e-01,
        1.1037e-01, 9.2754e+07, -3.4610e-01, -1.4131e-01, 3.0972e+05, -3.2830e-01,
        1.1375e-01, 1.7099e+06, -3.4897e-01, -1.3826e-01, 5.3813e+03, -3.2231e-01,
        1.1813e-01, 2.0921e+04, -3.5232e-01, -1.3387e-01, 6.0166e+01, -3.1374e-01,
        1.2349e-01, 2.0704e+02, -3.5540e-01, -1.2746e-01, 3.9819e-01, -3.0116e-01,
        1.2921e-01, 1.8185e+00, -3.5595e-01, -1.1787e-01, -6.4515e-02, -2.8216e-01,
        1.3302e-01, -1.1337e-02, -3.4787e-01, -1.0314e-01, -3.3442e-02, -2.5236e-01,
        1.2818e-01, -7.1756e-03, -3.1571e-01, -8.0007e-02, -1.0328e-02, -2.0352e-01,
        9.6148e-02, -3.6904e-04, -2.2175e-01, -4.4340e-02, -8.2904e-04, -1.2139e-01,
    ];
    let mut h = vec![0.0; n * n];
    for j in 0..n {
        h[j * n + j] = 1.0;
    }
    let terms: Vec<NormTerm> = (1..steps)
        .map(|t| {
            let mut a = SparseMatrix::new(width, n);
            for k in 0..width {
                a.push(k, width * (t - 1) + k, -1.0);
                a.push(k, width * t + k, 1.0);
            }
            NormTerm::new(1.0, a, vec![0.0; width])
        })
        .collect();
    let norms = NormData::from_terms(&terms, &[], n).expect("norm terms");
    let no_jacobian = Vec::new();
    let residuals = vec![vec![0.0; width]; steps - 1];
    let (jc, je) = (Jacobian::dense(0, n), Jacobian::dense(0, n));
    let (lo, up) = (vec![-0.5; n], vec![0.5; n]);
    let data = QpData {
        n,
        hessian: &h,
        gradient: &g,
        ineq: &[],
        ineq_jac: &jc,
        eq: &[],
        eq_jac: &je,
        norms: &norms,
        norm_rows: norms.iter().map(|nd| nd.rows(&no_jacobian)).collect(),
        norm_residuals: &residuals,
        step_lower: &lo,
        step_upper: &up,
    };
    let mut qp = QpSubproblem::new(&data, QpMode::Optimality, &[], 1e-9, 200).expect("build");
    // The premise: the data as built defeats the defaults and every fallback.
    qp.solver.solve();
    assert!(!qp.extract(&qp.solver.solution).outcome.is_usable());
    for fallback in FALLBACKS {
        assert!(qp.solve_usable(None, Some(fallback)).is_none());
    }
    let s = qp.solve();
    assert!(s.outcome.is_usable(), "{:?}", s.outcome);
    // The steep coordinates (within 1e6 of the steepest: the solve's accuracy is relative to
    // the largest entry) sit on the box, against their gradient, and their box duals
    // (unscaled) balance the gradient: d + g + z_up − z_lo − (norm terms) = 0, the norm
    // terms' part at most 2 (two unit-weight terms per coordinate).
    let largest = g.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    for j in (0..n).filter(|&j| g[j].abs() >= 1e-6 * largest) {
        let want = -0.5 * g[j].signum();
        assert!((s.d[j] - want).abs() < 1e-6, "d[{j}] = {} ≠ {want}", s.d[j]);
        let dual = s.box_upper[j] - s.box_lower[j];
        let residual = s.d[j] + g[j] + dual;
        assert!(residual.abs() <= 2.0 + 1e-9, "stationarity {j}: {residual}");
    }
    assert!(s.d.iter().all(|d| d.abs() <= 0.5 + 1e-9), "{:?}", s.d);
}

#[test]
fn box_constrained_qp_matches_closed_form() {
    // min ½‖d‖² + gᵀd, d ∈ [-1, 1]², c: d0 + d1 ≥ 0.5 − 0 (c = −0.5, J = [1, 1])
    let g = [1.0, -3.0];
    let h = [1.0, 0.0, 0.0, 1.0];
    let jc = Jacobian::Dense(DenseMatrix::from_rows(&[vec![1.0, 1.0]]).unwrap());
    let je = Jacobian::dense(0, 2);
    let data = QpData {
        n: 2,
        hessian: &h,
        gradient: &g,
        ineq: &[-0.5],
        ineq_jac: &jc,
        eq: &[],
        eq_jac: &je,
        norms: &[],
        norm_rows: Vec::new(),
        norm_residuals: &[],
        step_lower: &[-1.0, -1.0],
        step_upper: &[1.0, 1.0],
    };
    let mut qp = QpSubproblem::new(&data, QpMode::Optimality, &[100.0], 1e-9, 100).expect("build");
    let s = qp.solve();
    assert!(s.outcome.is_usable());
    // Unconstrained minimizer (-1, 3) clipped: d1 = 1 (upper bound), d0 = -1, d0 + d1 = 0 ≥ 0.5? No:
    // the linear constraint is active: d0 + d1 = 0.5 with d1 = 1 → d0 = -0.5.
    assert!((s.d[0] + 0.5).abs() < 1e-6, "{:?}", s.d);
    assert!((s.d[1] - 1.0).abs() < 1e-6, "{:?}", s.d);
    // Stationarity in d0: d0 + g0 = λ → λ = 0.5
    assert!((s.lambda[0] - 0.5).abs() < 1e-6);
}
