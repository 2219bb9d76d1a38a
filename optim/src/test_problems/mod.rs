//! Standard test problems with published optima: a Hock–Schittkowski selection (W. Hock, K. Schittkowski,
//! *Test Examples for Nonlinear Programming Codes*, 1981), the chained Rosenbrock function, and a
//! nonlinear least-squares class written as residual norms ([`least_squares`]).
//!
//! Used by the crate's tests and the `hock_schittkowski` example; behind the `test-problems` feature
//! (not solver API), so that benchmarks and other crates can still exercise the solvers on the same
//! problems. [`FailsAfter`] wraps any problem so that its
//! objective evaluations start failing after a budget.

mod fails_after;
mod hs_large;
mod hs_small;
mod least_squares;
mod rosenbrock;
mod two_disks;

pub use fails_after::FailsAfter;
pub use least_squares::{least_squares, LeastSquares, NormModel};
pub use rosenbrock::{rosenbrock_start, Rosenbrock};
pub use two_disks::TwoDisks;

use crate::error::EvalError;
use crate::linalg::Jacobian;
use crate::problem::{Bounds, Problem};

type Func = fn(&[f64]) -> f64;
type VecFunc = fn(&[f64], &mut [f64]);

/// A test problem with closed-form derivatives and a known optimal value.
#[derive(Clone, Debug)]
pub struct TestProblem {
    /// Short name, e.g. `"HS71"`.
    pub name: &'static str,
    /// Number of variables.
    pub n: usize,
    /// Number of inequality constraints `c(x) ≥ 0`.
    pub m: usize,
    /// Number of equality constraints.
    pub q: usize,
    /// The published starting point (it may violate the bounds; solvers project it).
    pub x0: Vec<f64>,
    /// Bounds, if any.
    pub bounds: Option<Bounds>,
    /// The published optimal objective value.
    pub f_star: f64,
    f: Func,
    g: VecFunc,
    c: VecFunc,
    /// Row-major `m × n` Jacobian of `c`.
    jc: VecFunc,
    h: VecFunc,
    /// Row-major `q × n` Jacobian of `h`.
    jh: VecFunc,
}

impl TestProblem {
    /// `|f − f*| / max(1, |f*|)`.
    pub fn error(&self, f: f64) -> f64 {
        (f - self.f_star).abs() / self.f_star.abs().max(1.0)
    }
}

fn none(_: &[f64], _: &mut [f64]) {}

fn fill_dense(jac: &mut Jacobian, x: &[f64], fun: VecFunc) -> Result<(), EvalError> {
    match jac {
        Jacobian::Dense(d) => {
            fun(x, d.as_mut_slice());
            Ok(())
        }
        Jacobian::Sparse(_) => Err(EvalError::new("expected a dense Jacobian")),
    }
}

impl Problem for TestProblem {
    fn num_variables(&self) -> usize {
        self.n
    }
    fn num_inequalities(&self) -> usize {
        self.m
    }
    fn num_equalities(&self) -> usize {
        self.q
    }
    fn bounds(&self) -> Option<Bounds> {
        self.bounds.clone()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok((self.f)(x))
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) -> Result<(), EvalError> {
        (self.g)(x, grad);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        (self.c)(x, c);
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        fill_dense(jac, x, self.jc)
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        (self.h)(x, h);
        Ok(())
    }
    fn equality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        fill_dense(jac, x, self.jh)
    }
}

#[allow(clippy::too_many_arguments)]
fn tp(
    name: &'static str,
    n: usize,
    m: usize,
    q: usize,
    x0: &[f64],
    bounds: Option<(Vec<f64>, Vec<f64>)>,
    f_star: f64,
    f: Func,
    g: VecFunc,
    c: VecFunc,
    jc: VecFunc,
    h: VecFunc,
    jh: VecFunc,
) -> TestProblem {
    TestProblem {
        name,
        n,
        m,
        q,
        x0: x0.to_vec(),
        bounds: bounds.map(|(l, u)| Bounds::new(l, u)),
        f_star,
        f,
        g,
        c,
        jc,
        h,
        jh,
    }
}

const INF: f64 = f64::INFINITY;

/// The Hock–Schittkowski problems used to validate the SQP (all have inequalities and/or bounds;
/// HS14 and HS71 also have an equality).
pub fn hock_schittkowski() -> Vec<TestProblem> {
    let mut problems = hs_small::problems();
    problems.extend(hs_large::problems());
    problems
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::Jacobian;

    /// Every hand-written derivative agrees with central differences.
    #[test]
    fn derivatives_match_finite_differences() {
        for mut p in hock_schittkowski() {
            let n = p.n;
            // A generic point near the start (avoid exact zeros where some terms are flat).
            let x: Vec<f64> =
                p.x0.iter()
                    .enumerate()
                    .map(|(i, v)| v + 0.1 * (i as f64 + 1.0) + 0.05)
                    .collect();
            let mut g = vec![0.0; n];
            p.gradient(&x, &mut g).unwrap();
            let mut jc = Jacobian::dense(p.m, n);
            p.inequality_jacobian(&x, &mut jc).unwrap();
            let mut jh = Jacobian::dense(p.q, n);
            p.equality_jacobian(&x, &mut jh).unwrap();
            for k in 0..n {
                let h = 1e-6 * x[k].abs().max(1.0);
                let mut xp = x.clone();
                let mut xm = x.clone();
                xp[k] += h;
                xm[k] -= h;
                let fd = (p.objective(&xp).unwrap() - p.objective(&xm).unwrap()) / (2.0 * h);
                let scale = fd.abs().max(g[k].abs()).max(1.0);
                assert!(
                    (fd - g[k]).abs() <= 1e-5 * scale,
                    "{} gradient[{k}]: fd {fd} vs {}",
                    p.name,
                    g[k]
                );
                let (mut cp, mut cm) = (vec![0.0; p.m], vec![0.0; p.m]);
                p.inequalities(&xp, &mut cp).unwrap();
                p.inequalities(&xm, &mut cm).unwrap();
                for i in 0..p.m {
                    let fd = (cp[i] - cm[i]) / (2.0 * h);
                    let Jacobian::Dense(d) = &jc else { panic!() };
                    let a = d.get(i, k);
                    assert!(
                        (fd - a).abs() <= 1e-5 * fd.abs().max(a.abs()).max(1.0),
                        "{} dc[{i}]/dx[{k}]: fd {fd} vs {a}",
                        p.name
                    );
                }
                let (mut hp, mut hm) = (vec![0.0; p.q], vec![0.0; p.q]);
                p.equalities(&xp, &mut hp).unwrap();
                p.equalities(&xm, &mut hm).unwrap();
                for i in 0..p.q {
                    let fd = (hp[i] - hm[i]) / (2.0 * h);
                    let Jacobian::Dense(d) = &jh else { panic!() };
                    let a = d.get(i, k);
                    assert!(
                        (fd - a).abs() <= 1e-5 * fd.abs().max(a.abs()).max(1.0),
                        "{} dh[{i}]/dx[{k}]: fd {fd} vs {a}",
                        p.name
                    );
                }
            }
        }
    }

    /// Every least-squares residual Jacobian (and the smooth form's gradient) agrees with
    /// central differences.
    #[test]
    fn residual_jacobians_match_finite_differences() {
        for p in least_squares() {
            let x: Vec<f64> =
                p.x0.iter()
                    .enumerate()
                    .map(|(i, v)| v + 0.1 * i as f64 + 0.05)
                    .collect();
            let j = p.jacobian_at(&x);
            let mut smooth = p.clone().with_model(NormModel::Smooth);
            let mut g = vec![0.0; p.n];
            smooth.gradient(&x, &mut g).unwrap();
            for k in 0..p.n {
                let mut xp = x.clone();
                let mut xm = x.clone();
                xp[k] += 1e-6;
                xm[k] -= 1e-6;
                let (rp, rm) = (p.residual_at(&xp), p.residual_at(&xm));
                for i in 0..p.p {
                    let fd = (rp[i] - rm[i]) / 2e-6;
                    let a = j[i * p.n + k];
                    assert!(
                        (fd - a).abs() <= 1e-5 * fd.abs().max(1.0),
                        "{} dr[{i}]/dx[{k}]",
                        p.name
                    );
                }
                let fd = (smooth.objective(&xp).unwrap() - smooth.objective(&xm).unwrap()) / 2e-6;
                assert!(
                    (fd - g[k]).abs() <= 1e-5 * fd.abs().max(1.0),
                    "{} df/dx[{k}]",
                    p.name
                );
            }
        }
    }

    #[test]
    fn rosenbrock_gradient_matches_finite_differences() {
        let mut r = Rosenbrock { n: 5 };
        let x = [0.3, -0.2, 1.1, 0.7, -0.5];
        let mut g = [0.0; 5];
        r.gradient(&x, &mut g).unwrap();
        for k in 0..5 {
            let mut xp = x;
            let mut xm = x;
            xp[k] += 1e-6;
            xm[k] -= 1e-6;
            let fd = (r.objective(&xp).unwrap() - r.objective(&xm).unwrap()) / 2e-6;
            assert!((fd - g[k]).abs() < 1e-5 * g[k].abs().max(1.0));
        }
    }
}
