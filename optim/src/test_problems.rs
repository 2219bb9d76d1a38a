//! Standard test problems with published optima: a Hock–Schittkowski selection (W. Hock, K. Schittkowski,
//! *Test Examples for Nonlinear Programming Codes*, 1981) and the chained Rosenbrock function.
//!
//! Used by the crate's tests and the `hock_schittkowski` example; behind the `test-problems` feature
//! (not solver API), so that benchmarks and other crates can still exercise the solvers on the same
//! problems. [`FailsAfter`] wraps any problem so that its
//! objective evaluations start failing after a budget.

use crate::error::EvalError;
use crate::linalg::{DenseMatrix, Jacobian};
use crate::problem::{Bounds, NormTerm, Problem};

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
    let sqrt3 = 3f64.sqrt();
    let _ = sqrt3;
    vec![
        tp(
            "HS1",
            2,
            0,
            0,
            &[-2.0, 1.0],
            Some((vec![-INF, -1.5], vec![INF, INF])),
            0.0,
            |x| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2),
            |x, g| {
                g[0] = -400.0 * x[0] * (x[1] - x[0] * x[0]) - 2.0 * (1.0 - x[0]);
                g[1] = 200.0 * (x[1] - x[0] * x[0]);
            },
            none,
            none,
            none,
            none,
        ),
        tp(
            "HS4",
            2,
            0,
            0,
            &[1.125, 0.125],
            Some((vec![1.0, 0.0], vec![INF, INF])),
            8.0 / 3.0,
            |x| (x[0] + 1.0).powi(3) / 3.0 + x[1],
            |x, g| {
                g[0] = (x[0] + 1.0).powi(2);
                g[1] = 1.0;
            },
            none,
            none,
            none,
            none,
        ),
        tp(
            "HS5",
            2,
            0,
            0,
            &[0.0, 0.0],
            Some((vec![-1.5, -3.0], vec![4.0, 3.0])),
            -0.5 * 3f64.sqrt() - std::f64::consts::PI / 3.0,
            |x| (x[0] + x[1]).sin() + (x[0] - x[1]).powi(2) - 1.5 * x[0] + 2.5 * x[1] + 1.0,
            |x, g| {
                let c = (x[0] + x[1]).cos();
                g[0] = c + 2.0 * (x[0] - x[1]) - 1.5;
                g[1] = c - 2.0 * (x[0] - x[1]) + 2.5;
            },
            none,
            none,
            none,
            none,
        ),
        tp(
            "HS10",
            2,
            1,
            0,
            &[-10.0, 10.0],
            None,
            -1.0,
            |x| x[0] - x[1],
            |_, g| {
                g[0] = 1.0;
                g[1] = -1.0;
            },
            |x, c| c[0] = -3.0 * x[0] * x[0] + 2.0 * x[0] * x[1] - x[1] * x[1] + 1.0,
            |x, j| {
                j[0] = -6.0 * x[0] + 2.0 * x[1];
                j[1] = 2.0 * x[0] - 2.0 * x[1];
            },
            none,
            none,
        ),
        tp(
            "HS11",
            2,
            1,
            0,
            &[4.9, 0.1],
            None,
            -8.498464223,
            |x| (x[0] - 5.0).powi(2) + x[1] * x[1] - 25.0,
            |x, g| {
                g[0] = 2.0 * (x[0] - 5.0);
                g[1] = 2.0 * x[1];
            },
            |x, c| c[0] = -x[0] * x[0] + x[1],
            |x, j| {
                j[0] = -2.0 * x[0];
                j[1] = 1.0;
            },
            none,
            none,
        ),
        tp(
            "HS12",
            2,
            1,
            0,
            &[0.0, 0.0],
            None,
            -30.0,
            |x| 0.5 * x[0] * x[0] + x[1] * x[1] - x[0] * x[1] - 7.0 * x[0] - 7.0 * x[1],
            |x, g| {
                g[0] = x[0] - x[1] - 7.0;
                g[1] = 2.0 * x[1] - x[0] - 7.0;
            },
            |x, c| c[0] = 25.0 - 4.0 * x[0] * x[0] - x[1] * x[1],
            |x, j| {
                j[0] = -8.0 * x[0];
                j[1] = -2.0 * x[1];
            },
            none,
            none,
        ),
        tp(
            "HS14",
            2,
            1,
            1,
            &[2.0, 2.0],
            None,
            9.0 - 2.875 * 7f64.sqrt(),
            |x| (x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2),
            |x, g| {
                g[0] = 2.0 * (x[0] - 2.0);
                g[1] = 2.0 * (x[1] - 1.0);
            },
            |x, c| c[0] = -0.25 * x[0] * x[0] - x[1] * x[1] + 1.0,
            |x, j| {
                j[0] = -0.5 * x[0];
                j[1] = -2.0 * x[1];
            },
            |x, h| h[0] = x[0] - 2.0 * x[1] + 1.0,
            |_, j| {
                j[0] = 1.0;
                j[1] = -2.0;
            },
        ),
        tp(
            "HS15",
            2,
            2,
            0,
            &[-2.0, 1.0],
            Some((vec![-INF, -INF], vec![0.5, INF])),
            306.5,
            |x| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2),
            |x, g| {
                g[0] = -400.0 * x[0] * (x[1] - x[0] * x[0]) - 2.0 * (1.0 - x[0]);
                g[1] = 200.0 * (x[1] - x[0] * x[0]);
            },
            |x, c| {
                c[0] = x[0] * x[1] - 1.0;
                c[1] = x[0] + x[1] * x[1];
            },
            |x, j| {
                j[0] = x[1];
                j[1] = x[0];
                j[2] = 1.0;
                j[3] = 2.0 * x[1];
            },
            none,
            none,
        ),
        tp(
            "HS21",
            2,
            1,
            0,
            &[-1.0, -1.0],
            Some((vec![2.0, -50.0], vec![50.0, 50.0])),
            -99.96,
            |x| 0.01 * x[0] * x[0] + x[1] * x[1] - 100.0,
            |x, g| {
                g[0] = 0.02 * x[0];
                g[1] = 2.0 * x[1];
            },
            |x, c| c[0] = 10.0 * x[0] - x[1] - 10.0,
            |_, j| {
                j[0] = 10.0;
                j[1] = -1.0;
            },
            none,
            none,
        ),
        tp(
            "HS22",
            2,
            2,
            0,
            &[2.0, 2.0],
            None,
            1.0,
            |x| (x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2),
            |x, g| {
                g[0] = 2.0 * (x[0] - 2.0);
                g[1] = 2.0 * (x[1] - 1.0);
            },
            |x, c| {
                c[0] = -x[0] - x[1] + 2.0;
                c[1] = -x[0] * x[0] + x[1];
            },
            |x, j| {
                j[0] = -1.0;
                j[1] = -1.0;
                j[2] = -2.0 * x[0];
                j[3] = 1.0;
            },
            none,
            none,
        ),
        tp(
            "HS24",
            2,
            3,
            0,
            &[1.0, 0.5],
            Some((vec![0.0, 0.0], vec![INF, INF])),
            -1.0,
            |x| ((x[0] - 3.0).powi(2) - 9.0) * x[1].powi(3) / (27.0 * 3f64.sqrt()),
            |x, g| {
                let k = 27.0 * 3f64.sqrt();
                g[0] = 2.0 * (x[0] - 3.0) * x[1].powi(3) / k;
                g[1] = ((x[0] - 3.0).powi(2) - 9.0) * 3.0 * x[1] * x[1] / k;
            },
            |x, c| {
                let s = 3f64.sqrt();
                c[0] = x[0] / s - x[1];
                c[1] = x[0] + s * x[1];
                c[2] = -x[0] - s * x[1] + 6.0;
            },
            |_, j| {
                let s = 3f64.sqrt();
                j.copy_from_slice(&[1.0 / s, -1.0, 1.0, s, -1.0, -s]);
            },
            none,
            none,
        ),
        tp(
            "HS29",
            3,
            1,
            0,
            &[1.0, 1.0, 1.0],
            None,
            -16.0 * 2f64.sqrt(),
            |x| -x[0] * x[1] * x[2],
            |x, g| {
                g[0] = -x[1] * x[2];
                g[1] = -x[0] * x[2];
                g[2] = -x[0] * x[1];
            },
            |x, c| c[0] = -x[0] * x[0] - 2.0 * x[1] * x[1] - 4.0 * x[2] * x[2] + 48.0,
            |x, j| {
                j[0] = -2.0 * x[0];
                j[1] = -4.0 * x[1];
                j[2] = -8.0 * x[2];
            },
            none,
            none,
        ),
        tp(
            "HS34",
            3,
            2,
            0,
            &[0.0, 1.05, 2.9],
            Some((vec![0.0, 0.0, 0.0], vec![100.0, 100.0, 10.0])),
            -(10f64.ln().ln()),
            |x| -x[0],
            |_, g| {
                g[0] = -1.0;
                g[1] = 0.0;
                g[2] = 0.0;
            },
            |x, c| {
                c[0] = x[1] - x[0].exp();
                c[1] = x[2] - x[1].exp();
            },
            |x, j| {
                j.copy_from_slice(&[-x[0].exp(), 1.0, 0.0, 0.0, -x[1].exp(), 1.0]);
            },
            none,
            none,
        ),
        tp(
            "HS35",
            3,
            1,
            0,
            &[0.5, 0.5, 0.5],
            Some((vec![0.0; 3], vec![INF; 3])),
            1.0 / 9.0,
            |x| {
                9.0 - 8.0 * x[0] - 6.0 * x[1] - 4.0 * x[2]
                    + 2.0 * x[0] * x[0]
                    + 2.0 * x[1] * x[1]
                    + x[2] * x[2]
                    + 2.0 * x[0] * x[1]
                    + 2.0 * x[0] * x[2]
            },
            |x, g| {
                g[0] = -8.0 + 4.0 * x[0] + 2.0 * x[1] + 2.0 * x[2];
                g[1] = -6.0 + 4.0 * x[1] + 2.0 * x[0];
                g[2] = -4.0 + 2.0 * x[2] + 2.0 * x[0];
            },
            |x, c| c[0] = 3.0 - x[0] - x[1] - 2.0 * x[2],
            |_, j| j.copy_from_slice(&[-1.0, -1.0, -2.0]),
            none,
            none,
        ),
        tp(
            "HS43",
            4,
            3,
            0,
            &[0.0; 4],
            None,
            -44.0,
            |x| {
                x[0] * x[0] + x[1] * x[1] + 2.0 * x[2] * x[2] + x[3] * x[3]
                    - 5.0 * x[0]
                    - 5.0 * x[1]
                    - 21.0 * x[2]
                    + 7.0 * x[3]
            },
            |x, g| {
                g[0] = 2.0 * x[0] - 5.0;
                g[1] = 2.0 * x[1] - 5.0;
                g[2] = 4.0 * x[2] - 21.0;
                g[3] = 2.0 * x[3] + 7.0;
            },
            |x, c| {
                c[0] = 8.0 - x[0] * x[0] - x[1] * x[1] - x[2] * x[2] - x[3] * x[3] - x[0] + x[1]
                    - x[2]
                    + x[3];
                c[1] = 10.0 - x[0] * x[0] - 2.0 * x[1] * x[1] - x[2] * x[2] - 2.0 * x[3] * x[3]
                    + x[0]
                    + x[3];
                c[2] =
                    5.0 - 2.0 * x[0] * x[0] - x[1] * x[1] - x[2] * x[2] - 2.0 * x[0] + x[1] + x[3];
            },
            |x, j| {
                j.copy_from_slice(&[
                    -2.0 * x[0] - 1.0,
                    -2.0 * x[1] + 1.0,
                    -2.0 * x[2] - 1.0,
                    -2.0 * x[3] + 1.0,
                    -2.0 * x[0] + 1.0,
                    -4.0 * x[1],
                    -2.0 * x[2],
                    -4.0 * x[3] + 1.0,
                    -4.0 * x[0] - 2.0,
                    -2.0 * x[1] + 1.0,
                    -2.0 * x[2],
                    1.0,
                ]);
            },
            none,
            none,
        ),
        tp(
            "HS44",
            4,
            6,
            0,
            &[0.0; 4],
            Some((vec![0.0; 4], vec![INF; 4])),
            -15.0,
            |x| x[0] - x[1] - x[2] - x[0] * x[2] + x[0] * x[3] + x[1] * x[2] - x[1] * x[3],
            |x, g| {
                g[0] = 1.0 - x[2] + x[3];
                g[1] = -1.0 + x[2] - x[3];
                g[2] = -1.0 - x[0] + x[1];
                g[3] = x[0] - x[1];
            },
            |x, c| {
                c[0] = 8.0 - x[0] - 2.0 * x[1];
                c[1] = 12.0 - 4.0 * x[0] - x[1];
                c[2] = 12.0 - 3.0 * x[0] - 4.0 * x[1];
                c[3] = 8.0 - 2.0 * x[2] - x[3];
                c[4] = 8.0 - x[2] - 2.0 * x[3];
                c[5] = 5.0 - x[2] - x[3];
            },
            |_, j| {
                j.copy_from_slice(&[
                    -1.0, -2.0, 0.0, 0.0, //
                    -4.0, -1.0, 0.0, 0.0, //
                    -3.0, -4.0, 0.0, 0.0, //
                    0.0, 0.0, -2.0, -1.0, //
                    0.0, 0.0, -1.0, -2.0, //
                    0.0, 0.0, -1.0, -1.0,
                ]);
            },
            none,
            none,
        ),
        tp(
            "HS65",
            3,
            1,
            0,
            &[-5.0, 5.0, 0.0],
            Some((vec![-4.5, -4.5, -5.0], vec![4.5, 4.5, 5.0])),
            0.9535288567,
            |x| (x[0] - x[1]).powi(2) + (x[0] + x[1] - 10.0).powi(2) / 9.0 + (x[2] - 5.0).powi(2),
            |x, g| {
                let a = 2.0 * (x[0] - x[1]);
                let b = 2.0 * (x[0] + x[1] - 10.0) / 9.0;
                g[0] = a + b;
                g[1] = -a + b;
                g[2] = 2.0 * (x[2] - 5.0);
            },
            |x, c| c[0] = 48.0 - x[0] * x[0] - x[1] * x[1] - x[2] * x[2],
            |x, j| j.copy_from_slice(&[-2.0 * x[0], -2.0 * x[1], -2.0 * x[2]]),
            none,
            none,
        ),
        tp(
            "HS71",
            4,
            1,
            1,
            &[1.0, 5.0, 5.0, 1.0],
            Some((vec![1.0; 4], vec![5.0; 4])),
            17.0140173,
            |x| x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2],
            |x, g| {
                g[0] = x[3] * (2.0 * x[0] + x[1] + x[2]);
                g[1] = x[0] * x[3];
                g[2] = x[0] * x[3] + 1.0;
                g[3] = x[0] * (x[0] + x[1] + x[2]);
            },
            |x, c| c[0] = x[0] * x[1] * x[2] * x[3] - 25.0,
            |x, j| {
                j.copy_from_slice(&[
                    x[1] * x[2] * x[3],
                    x[0] * x[2] * x[3],
                    x[0] * x[1] * x[3],
                    x[0] * x[1] * x[2],
                ])
            },
            |x, h| h[0] = x.iter().map(|v| v * v).sum::<f64>() - 40.0,
            |x, j| {
                for (ji, xi) in j.iter_mut().zip(x) {
                    *ji = 2.0 * xi;
                }
            },
        ),
        tp(
            "HS76",
            4,
            3,
            0,
            &[0.5; 4],
            Some((vec![0.0; 4], vec![INF; 4])),
            -4.681818181,
            |x| {
                x[0] * x[0] + 0.5 * x[1] * x[1] + x[2] * x[2] + 0.5 * x[3] * x[3] - x[0] * x[2]
                    + x[2] * x[3]
                    - x[0]
                    - 3.0 * x[1]
                    + x[2]
                    - x[3]
            },
            |x, g| {
                g[0] = 2.0 * x[0] - x[2] - 1.0;
                g[1] = x[1] - 3.0;
                g[2] = 2.0 * x[2] - x[0] + x[3] + 1.0;
                g[3] = x[3] + x[2] - 1.0;
            },
            |x, c| {
                c[0] = 5.0 - x[0] - 2.0 * x[1] - x[2] - x[3];
                c[1] = 4.0 - 3.0 * x[0] - x[1] - 2.0 * x[2] + x[3];
                c[2] = x[1] + 4.0 * x[2] - 1.5;
            },
            |_, j| {
                j.copy_from_slice(&[
                    -1.0, -2.0, -1.0, -1.0, //
                    -3.0, -1.0, -2.0, 1.0, //
                    0.0, 1.0, 4.0, 0.0,
                ])
            },
            none,
            none,
        ),
        tp(
            "HS100",
            7,
            4,
            0,
            &[1.0, 2.0, 0.0, 4.0, 0.0, 1.0, 1.0],
            None,
            680.6300573,
            |x| {
                (x[0] - 10.0).powi(2)
                    + 5.0 * (x[1] - 12.0).powi(2)
                    + x[2].powi(4)
                    + 3.0 * (x[3] - 11.0).powi(2)
                    + 10.0 * x[4].powi(6)
                    + 7.0 * x[5] * x[5]
                    + x[6].powi(4)
                    - 4.0 * x[5] * x[6]
                    - 10.0 * x[5]
                    - 8.0 * x[6]
            },
            |x, g| {
                g[0] = 2.0 * (x[0] - 10.0);
                g[1] = 10.0 * (x[1] - 12.0);
                g[2] = 4.0 * x[2].powi(3);
                g[3] = 6.0 * (x[3] - 11.0);
                g[4] = 60.0 * x[4].powi(5);
                g[5] = 14.0 * x[5] - 4.0 * x[6] - 10.0;
                g[6] = 4.0 * x[6].powi(3) - 4.0 * x[5] - 8.0;
            },
            |x, c| {
                c[0] = 127.0
                    - 2.0 * x[0] * x[0]
                    - 3.0 * x[1].powi(4)
                    - x[2]
                    - 4.0 * x[3] * x[3]
                    - 5.0 * x[4];
                c[1] = 282.0 - 7.0 * x[0] - 3.0 * x[1] - 10.0 * x[2] * x[2] - x[3] + x[4];
                c[2] = 196.0 - 23.0 * x[0] - x[1] * x[1] - 6.0 * x[5] * x[5] + 8.0 * x[6];
                c[3] = -4.0 * x[0] * x[0] - x[1] * x[1] + 3.0 * x[0] * x[1]
                    - 2.0 * x[2] * x[2]
                    - 5.0 * x[5]
                    + 11.0 * x[6];
            },
            |x, j| {
                j.copy_from_slice(&[
                    -4.0 * x[0],
                    -12.0 * x[1].powi(3),
                    -1.0,
                    -8.0 * x[3],
                    -5.0,
                    0.0,
                    0.0,
                    //
                    -7.0,
                    -3.0,
                    -20.0 * x[2],
                    -1.0,
                    1.0,
                    0.0,
                    0.0,
                    //
                    -23.0,
                    -2.0 * x[1],
                    0.0,
                    0.0,
                    0.0,
                    -12.0 * x[5],
                    8.0,
                    //
                    -8.0 * x[0] + 3.0 * x[1],
                    -2.0 * x[1] + 3.0 * x[0],
                    -4.0 * x[2],
                    0.0,
                    0.0,
                    -5.0,
                    11.0,
                ])
            },
            none,
            none,
        ),
        tp(
            "HS106",
            8,
            6,
            0,
            &[5000.0, 5000.0, 5000.0, 200.0, 350.0, 150.0, 225.0, 425.0],
            Some((
                vec![100.0, 1000.0, 1000.0, 10.0, 10.0, 10.0, 10.0, 10.0],
                vec![
                    10000.0, 10000.0, 10000.0, 1000.0, 1000.0, 1000.0, 1000.0, 1000.0,
                ],
            )),
            7049.24802052867,
            |x| x[0] + x[1] + x[2],
            |_, g| {
                g.fill(0.0);
                g[0] = 1.0;
                g[1] = 1.0;
                g[2] = 1.0;
            },
            |x, c| {
                c[0] = 1.0 - 0.0025 * (x[3] + x[5]);
                c[1] = 1.0 - 0.0025 * (x[4] + x[6] - x[3]);
                c[2] = 1.0 - 0.01 * (x[7] - x[4]);
                c[3] = x[0] * x[5] - 833.33252 * x[3] - 100.0 * x[0] + 83333.333;
                c[4] = x[1] * x[6] - 1250.0 * x[4] - x[1] * x[3] + 1250.0 * x[3];
                c[5] = x[2] * x[7] - 1_250_000.0 - x[2] * x[4] + 2500.0 * x[4];
            },
            |x, j| {
                j.fill(0.0);
                let n = 8;
                j[3] = -0.0025;
                j[5] = -0.0025;
                j[n + 3] = 0.0025;
                j[n + 4] = -0.0025;
                j[n + 6] = -0.0025;
                j[2 * n + 4] = 0.01;
                j[2 * n + 7] = -0.01;
                j[3 * n] = x[5] - 100.0;
                j[3 * n + 3] = -833.33252;
                j[3 * n + 5] = x[0];
                j[4 * n + 1] = x[6] - x[3];
                j[4 * n + 3] = -x[1] + 1250.0;
                j[4 * n + 4] = -1250.0;
                j[4 * n + 6] = x[1];
                j[5 * n + 2] = x[7] - x[4];
                j[5 * n + 4] = -x[2] + 2500.0;
                j[5 * n + 7] = x[2];
            },
            none,
            none,
        ),
        tp(
            "HS113",
            10,
            8,
            0,
            &[2.0, 3.0, 5.0, 5.0, 1.0, 2.0, 7.0, 3.0, 6.0, 10.0],
            None,
            24.3062091,
            |x| {
                x[0] * x[0] + x[1] * x[1] + x[0] * x[1] - 14.0 * x[0] - 16.0 * x[1]
                    + (x[2] - 10.0).powi(2)
                    + 4.0 * (x[3] - 5.0).powi(2)
                    + (x[4] - 3.0).powi(2)
                    + 2.0 * (x[5] - 1.0).powi(2)
                    + 5.0 * x[6] * x[6]
                    + 7.0 * (x[7] - 11.0).powi(2)
                    + 2.0 * (x[8] - 10.0).powi(2)
                    + (x[9] - 7.0).powi(2)
                    + 45.0
            },
            |x, g| {
                g[0] = 2.0 * x[0] + x[1] - 14.0;
                g[1] = 2.0 * x[1] + x[0] - 16.0;
                g[2] = 2.0 * (x[2] - 10.0);
                g[3] = 8.0 * (x[3] - 5.0);
                g[4] = 2.0 * (x[4] - 3.0);
                g[5] = 4.0 * (x[5] - 1.0);
                g[6] = 10.0 * x[6];
                g[7] = 14.0 * (x[7] - 11.0);
                g[8] = 4.0 * (x[8] - 10.0);
                g[9] = 2.0 * (x[9] - 7.0);
            },
            |x, c| {
                c[0] = 105.0 - 4.0 * x[0] - 5.0 * x[1] + 3.0 * x[6] - 9.0 * x[7];
                c[1] = -10.0 * x[0] + 8.0 * x[1] + 17.0 * x[6] - 2.0 * x[7];
                c[2] = 8.0 * x[0] - 2.0 * x[1] - 5.0 * x[8] + 2.0 * x[9] + 12.0;
                c[3] = -3.0 * (x[0] - 2.0).powi(2) - 4.0 * (x[1] - 3.0).powi(2) - 2.0 * x[2] * x[2]
                    + 7.0 * x[3]
                    + 120.0;
                c[4] = -5.0 * x[0] * x[0] - 8.0 * x[1] - (x[2] - 6.0).powi(2) + 2.0 * x[3] + 40.0;
                c[5] = -0.5 * (x[0] - 8.0).powi(2) - 2.0 * (x[1] - 4.0).powi(2) - 3.0 * x[4] * x[4]
                    + x[5]
                    + 30.0;
                c[6] = -x[0] * x[0] - 2.0 * (x[1] - 2.0).powi(2) + 2.0 * x[0] * x[1] - 14.0 * x[4]
                    + 6.0 * x[5];
                c[7] = 3.0 * x[0] - 6.0 * x[1] - 12.0 * (x[8] - 8.0).powi(2) + 7.0 * x[9];
            },
            |x, j| {
                j.fill(0.0);
                let n = 10;
                let mut s = |i: usize, k: usize, v: f64| j[i * n + k] = v;
                s(0, 0, -4.0);
                s(0, 1, -5.0);
                s(0, 6, 3.0);
                s(0, 7, -9.0);
                s(1, 0, -10.0);
                s(1, 1, 8.0);
                s(1, 6, 17.0);
                s(1, 7, -2.0);
                s(2, 0, 8.0);
                s(2, 1, -2.0);
                s(2, 8, -5.0);
                s(2, 9, 2.0);
                s(3, 0, -6.0 * (x[0] - 2.0));
                s(3, 1, -8.0 * (x[1] - 3.0));
                s(3, 2, -4.0 * x[2]);
                s(3, 3, 7.0);
                s(4, 0, -10.0 * x[0]);
                s(4, 1, -8.0);
                s(4, 2, -2.0 * (x[2] - 6.0));
                s(4, 3, 2.0);
                s(5, 0, -(x[0] - 8.0));
                s(5, 1, -4.0 * (x[1] - 4.0));
                s(5, 4, -6.0 * x[4]);
                s(5, 5, 1.0);
                s(6, 0, -2.0 * x[0] + 2.0 * x[1]);
                s(6, 1, -4.0 * (x[1] - 2.0) + 2.0 * x[0]);
                s(6, 4, -14.0);
                s(6, 5, 6.0);
                s(7, 0, 3.0);
                s(7, 1, -6.0);
                s(7, 8, -24.0 * (x[8] - 8.0));
                s(7, 9, 7.0);
            },
            none,
            none,
        ),
        hs118(),
    ]
}

fn hs118() -> TestProblem {
    let mut lower = vec![8.0, 43.0, 3.0];
    let mut upper = vec![21.0, 57.0, 16.0];
    for _ in 0..4 {
        lower.extend_from_slice(&[0.0, 0.0, 0.0]);
        upper.extend_from_slice(&[90.0, 120.0, 60.0]);
    }
    tp(
        "HS118",
        15,
        29,
        0,
        &[
            20.0, 55.0, 15.0, 20.0, 60.0, 20.0, 20.0, 60.0, 20.0, 20.0, 60.0, 20.0, 20.0, 60.0,
            20.0,
        ],
        Some((lower, upper)),
        664.8204500,
        |x| {
            let (a, q) = ([2.3, 1.7, 2.2], [0.0001, 0.0001, 0.00015]);
            x.iter()
                .enumerate()
                .map(|(i, v)| a[i % 3] * v + q[i % 3] * v * v)
                .sum()
        },
        |x, g| {
            let (a, q) = ([2.3, 1.7, 2.2], [0.0001, 0.0001, 0.00015]);
            for (i, v) in x.iter().enumerate() {
                g[i] = a[i % 3] + 2.0 * q[i % 3] * v;
            }
        },
        |x, c| {
            // Ramp limits: 0 ≤ x_cur − x_prev + 7 ≤ upper (13, 14, 13).
            let ramp = [13.0, 14.0, 13.0];
            let mut r = 0;
            for b in 1..5 {
                for i in 0..3 {
                    let v = x[3 * b + i] - x[3 * (b - 1) + i] + 7.0;
                    c[r] = v;
                    c[r + 1] = ramp[i] - v;
                    r += 2;
                }
            }
            let demand = [60.0, 50.0, 70.0, 85.0, 100.0];
            for (b, dmd) in demand.iter().enumerate() {
                c[r] = x[3 * b] + x[3 * b + 1] + x[3 * b + 2] - dmd;
                r += 1;
            }
        },
        |_, j| {
            j.fill(0.0);
            let n = 15;
            let mut r = 0;
            for b in 1..5 {
                for i in 0..3 {
                    j[r * n + 3 * b + i] = 1.0;
                    j[r * n + 3 * (b - 1) + i] = -1.0;
                    j[(r + 1) * n + 3 * b + i] = -1.0;
                    j[(r + 1) * n + 3 * (b - 1) + i] = 1.0;
                    r += 2;
                }
            }
            for b in 0..5 {
                for i in 0..3 {
                    j[r * n + 3 * b + i] = 1.0;
                }
                r += 1;
            }
        },
        none,
        none,
    )
}

/// The chained Rosenbrock function `Σ 100(x_{i+1} − x_i²)² + (1 − x_i)²` in `n ≥ 2` variables, minimum
/// 0 at `(1, …, 1)`; the usual start is `(−1.2, 1, −1.2, 1, …)` ([`rosenbrock_start`]).
#[derive(Clone, Copy, Debug)]
pub struct Rosenbrock {
    /// Number of variables.
    pub n: usize,
}

/// The standard starting point `(−1.2, 1, −1.2, 1, …)`.
pub fn rosenbrock_start(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| if i % 2 == 0 { -1.2 } else { 1.0 })
        .collect()
}

impl Problem for Rosenbrock {
    fn num_variables(&self) -> usize {
        self.n
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x.windows(2)
            .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
            .sum())
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g.fill(0.0);
        for i in 0..x.len() - 1 {
            let t = x[i + 1] - x[i] * x[i];
            g[i] += -400.0 * x[i] * t - 2.0 * (1.0 - x[i]);
            g[i + 1] += 200.0 * t;
        }
        Ok(())
    }
}

/// `min x₀ + x₁` over two disjoint unit disks, `1 − ‖x‖² ≥ 0` and `1 − ‖x − (3, 0)‖² ≥ 0`: locally
/// infeasible, the ℓ1 violation is stationary at (1.5, 0) with max violation 1.25. With `far_disk`
/// = `Some(r²)`, a third row `r² − ‖x‖² ≥ 0` that stays far from active for large `r²`.
#[derive(Clone, Debug)]
pub struct TwoDisks {
    /// Squared radius of the optional third, far disk around the origin.
    pub far_disk: Option<f64>,
}

impl Problem for TwoDisks {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        2 + usize::from(self.far_disk.is_some())
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x[0] + x[1])
    }
    fn gradient(&mut self, _x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g.copy_from_slice(&[1.0, 1.0]);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        let r0 = x[0] * x[0] + x[1] * x[1];
        c[0] = 1.0 - r0;
        c[1] = 1.0 - (x[0] - 3.0).powi(2) - x[1] * x[1];
        if let Some(r2) = self.far_disk {
            c[2] = r2 - r0;
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        let rows: &[(usize, f64)] = if self.far_disk.is_some() {
            &[(0, 0.0), (1, 3.0), (2, 0.0)]
        } else {
            &[(0, 0.0), (1, 3.0)]
        };
        for &(i, cx) in rows {
            j.set(i, 0, -2.0 * (x[0] - cx));
            j.set(i, 1, -2.0 * x[1]);
        }
        Ok(())
    }
}

/// `problem` with a budget of objective evaluations: once `budget` of them have succeeded, every
/// further [`Problem::objective`] call fails with an [`EvalError`]; everything else is forwarded.
/// Exercises how the solvers handle failed evaluations.
#[derive(Clone, Debug)]
pub struct FailsAfter<P> {
    /// The wrapped problem.
    pub problem: P,
    /// Objective evaluations left before they start failing.
    pub budget: usize,
}

impl<P: Problem> Problem for FailsAfter<P> {
    fn num_variables(&self) -> usize {
        self.problem.num_variables()
    }
    fn num_inequalities(&self) -> usize {
        self.problem.num_inequalities()
    }
    fn num_equalities(&self) -> usize {
        self.problem.num_equalities()
    }
    fn bounds(&self) -> Option<Bounds> {
        self.problem.bounds()
    }
    fn norm_terms(&self) -> Vec<NormTerm> {
        self.problem.norm_terms()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        self.problem.initial_hessian()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        if self.budget == 0 {
            return Err(EvalError::new("out of budget"));
        }
        self.budget -= 1;
        self.problem.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.problem.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        self.problem.inequalities(x, c)
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.problem.inequality_jacobian(x, jac)
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        self.problem.equalities(x, h)
    }
    fn equality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.problem.equality_jacobian(x, jac)
    }
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
