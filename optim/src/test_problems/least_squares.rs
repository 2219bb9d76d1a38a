//! Nonlinear least-squares problems `min w‖r(x)‖ s.t. c(x) ≥ 0`, each handed to the solver in
//! either of two ways ([`NormModel`]): as a declared residual norm (the SQP's Gauss–Newton model)
//! or inside the smooth objective (the SQP's BFGS model of its curvature).

use crate::error::EvalError;
use crate::linalg::{norm2, Jacobian};
use crate::problem::{Problem, ResidualNorm};

use super::{fill_dense, VecFunc};

/// How a [`LeastSquares`] problem hands its term `w‖r(x)‖` to the solver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormModel {
    /// A [`ResidualNorm`] with its residual and Jacobian.
    Residual,
    /// Inside the smooth objective, with the gradient `w Jᵀr/‖r‖` (0 at `r = 0`).
    Smooth,
}

/// `min weight · ‖r(x)‖  s.t. c(x) ≥ 0` with closed-form derivatives.
#[derive(Clone, Debug)]
pub struct LeastSquares {
    /// Short name, e.g. `"rosenbrock"`.
    pub name: &'static str,
    /// Number of variables.
    pub n: usize,
    /// Length of the residual.
    pub p: usize,
    /// Number of inequality constraints `c(x) ≥ 0`.
    pub m: usize,
    /// The weight `w`.
    pub weight: f64,
    /// The usual starting point.
    pub x0: Vec<f64>,
    /// The optimal value of `w‖r‖`, where it is known in closed form or to many digits.
    pub f_star: Option<f64>,
    /// How the norm is handed to the solver.
    pub model: NormModel,
    r: VecFunc,
    /// Row-major `p × n` Jacobian of `r`.
    jr: VecFunc,
    c: VecFunc,
    /// Row-major `m × n` Jacobian of `c`.
    jc: VecFunc,
}

impl LeastSquares {
    /// The same problem handed over as `model` says.
    pub fn with_model(mut self, model: NormModel) -> Self {
        self.model = model;
        self
    }

    /// `r(x)`.
    pub fn residual_at(&self, x: &[f64]) -> Vec<f64> {
        let mut r = vec![0.0; self.p];
        (self.r)(x, &mut r);
        r
    }

    /// The row-major Jacobian of `r` at `x`.
    pub fn jacobian_at(&self, x: &[f64]) -> Vec<f64> {
        let mut j = vec![0.0; self.p * self.n];
        (self.jr)(x, &mut j);
        j
    }
}

impl Problem for LeastSquares {
    fn num_variables(&self) -> usize {
        self.n
    }
    fn num_inequalities(&self) -> usize {
        self.m
    }
    fn residual_norms(&self) -> Vec<ResidualNorm> {
        match self.model {
            NormModel::Residual => vec![ResidualNorm::new(self.weight, self.p)],
            NormModel::Smooth => Vec::new(),
        }
    }
    fn residual(&mut self, x: &[f64], _j: usize, r: &mut [f64]) -> Result<(), EvalError> {
        (self.r)(x, r);
        Ok(())
    }
    fn residual_jacobian(
        &mut self,
        x: &[f64],
        _j: usize,
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        fill_dense(jac, x, self.jr)
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(match self.model {
            NormModel::Residual => 0.0,
            NormModel::Smooth => self.weight * norm2(&self.residual_at(x)),
        })
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g.fill(0.0);
        if self.model == NormModel::Smooth {
            let r = self.residual_at(x);
            let nr = norm2(&r);
            if nr > 0.0 {
                let j = self.jacobian_at(x);
                for (i, ri) in r.iter().enumerate() {
                    for (k, gk) in g.iter_mut().enumerate() {
                        *gk += self.weight * ri / nr * j[i * self.n + k];
                    }
                }
            }
        }
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        (self.c)(x, c);
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        fill_dense(jac, x, self.jc)
    }
}

fn none(_: &[f64], _: &mut [f64]) {}

/// Rosenbrock's `r = (10(x₂ − x₁²), 1 − x₁)`.
fn rosenbrock_r(x: &[f64], r: &mut [f64]) {
    r[0] = 10.0 * (x[1] - x[0] * x[0]);
    r[1] = 1.0 - x[0];
}

fn rosenbrock_jr(x: &[f64], j: &mut [f64]) {
    j.copy_from_slice(&[-20.0 * x[0], 10.0, -1.0, 0.0]);
}

/// The chained residual `r_{2i} = 10(x_{i+1} − x_i²)`, `r_{2i+1} = 1 − x_i`.
fn chained_r(x: &[f64], r: &mut [f64]) {
    for i in 0..x.len() - 1 {
        r[2 * i] = 10.0 * (x[i + 1] - x[i] * x[i]);
        r[2 * i + 1] = 1.0 - x[i];
    }
}

fn chained_jr(x: &[f64], j: &mut [f64]) {
    let n = x.len();
    j.fill(0.0);
    for i in 0..n - 1 {
        j[2 * i * n + i] = -20.0 * x[i];
        j[2 * i * n + i + 1] = 10.0;
        j[(2 * i + 1) * n + i] = -1.0;
    }
}

/// Sample times and values of the exponential fit: `2 e^{−1.5 t} + 0.5` with ±0.01 alternating.
fn decay_data(i: usize) -> (f64, f64) {
    let t = 0.4 * i as f64;
    let noise = if i % 2 == 0 { 0.01 } else { -0.01 };
    (t, 2.0 * (-1.5 * t).exp() + 0.5 + noise)
}

const DECAY_SAMPLES: usize = 10;

/// `r_i = a e^{b t_i} + c − y_i`.
fn decay_r(x: &[f64], r: &mut [f64]) {
    for (i, ri) in r.iter_mut().enumerate() {
        let (t, y) = decay_data(i);
        *ri = x[0] * (x[1] * t).exp() + x[2] - y;
    }
}

fn decay_jr(x: &[f64], j: &mut [f64]) {
    for i in 0..DECAY_SAMPLES {
        let (t, _) = decay_data(i);
        let e = (x[1] * t).exp();
        j[3 * i..3 * i + 3].copy_from_slice(&[e, x[0] * t * e, 1.0]);
    }
}

/// The unit disk `1 − x₁² − x₂² ≥ 0`.
fn disk_c(x: &[f64], c: &mut [f64]) {
    c[0] = 1.0 - x[0] * x[0] - x[1] * x[1];
}

fn disk_jc(x: &[f64], j: &mut [f64]) {
    j.copy_from_slice(&[-2.0 * x[0], -2.0 * x[1]]);
}

/// The least-squares class, as residual norms: Rosenbrock (zero residual), chained Rosenbrock in
/// 10 variables (zero residual), an exponential fit to noisy data (nonzero residual) and
/// Rosenbrock in the unit disk (constrained; optimum on the boundary).
pub fn least_squares() -> Vec<LeastSquares> {
    let chained_n = 10;
    vec![
        LeastSquares {
            name: "rosenbrock",
            n: 2,
            p: 2,
            m: 0,
            weight: 1.0,
            x0: vec![-1.2, 1.0],
            f_star: Some(0.0),
            model: NormModel::Residual,
            r: rosenbrock_r,
            jr: rosenbrock_jr,
            c: none,
            jc: none,
        },
        LeastSquares {
            name: "chained rosenbrock",
            n: chained_n,
            p: 2 * (chained_n - 1),
            m: 0,
            weight: 1.0,
            x0: super::rosenbrock_start(chained_n),
            f_star: Some(0.0),
            model: NormModel::Residual,
            r: chained_r,
            jr: chained_jr,
            c: none,
            jc: none,
        },
        LeastSquares {
            name: "exponential fit",
            n: 3,
            p: DECAY_SAMPLES,
            m: 0,
            weight: 2.0,
            x0: vec![1.0, -0.5, 0.0],
            f_star: None,
            model: NormModel::Residual,
            r: decay_r,
            jr: decay_jr,
            c: none,
            jc: none,
        },
        LeastSquares {
            name: "rosenbrock in the disk",
            n: 2,
            p: 2,
            m: 1,
            weight: 1.0,
            x0: vec![0.0, 0.0],
            // At (0.7864151541, 0.6176983126), by golden-section search along the boundary.
            f_star: Some(0.213_716_655_222_517),
            model: NormModel::Residual,
            r: rosenbrock_r,
            jr: rosenbrock_jr,
            c: disk_c,
            jc: disk_jc,
        },
    ]
}
