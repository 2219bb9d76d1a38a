//! Rough test problems shared by the progress and restoration tests: Rosenbrock with noise its
//! gradient ignores, as a simulator's gradient ignores a change of contact set.

use optim::test_problems::Rosenbrock;
use optim::{EvalError, Jacobian, Problem};

/// The Rosenbrock function in `n` variables plus `ε·noise(x)`, optionally with `x₀ ≤ 0.5`
/// (active at the optimum): `noise` is constant on cells of width `h` and hashes each cell to
/// `[−1, 1]`; the gradient is Rosenbrock's alone.
pub struct RoughRosenbrock {
    pub n: usize,
    pub eps: f64,
    pub h: f64,
    pub constrained: bool,
}

impl RoughRosenbrock {
    pub fn noise(&self, x: &[f64]) -> f64 {
        let mut hash: u64 = 0x9e37_79b9_7f4a_7c15;
        for &v in x {
            hash ^= ((v / self.h).floor() as i64) as u64;
            hash = hash.wrapping_mul(0xbf58_476d_1ce4_e5b9).rotate_left(31);
        }
        (hash >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

impl Problem for RoughRosenbrock {
    fn num_variables(&self) -> usize {
        self.n
    }
    fn num_inequalities(&self) -> usize {
        usize::from(self.constrained)
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        let smooth = Rosenbrock { n: self.n }.objective(x)?;
        Ok(smooth + self.eps * self.noise(x))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        Rosenbrock { n: self.n }.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        if let Some(c0) = c.first_mut() {
            *c0 = 0.5 - x[0];
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        if self.constrained {
            j.set(0, 0, -1.0);
        }
        Ok(())
    }
}

/// A rough equality: `x₀ − 0.5 + ε·noise(x) = 0` under the Rosenbrock objective, the noise (of
/// the objective too) ignored by the derivatives. Once the violation is at the noise level no
/// step the line search tries lowers it, and the iterates stay infeasible.
pub struct RoughEquality(pub RoughRosenbrock);

impl Problem for RoughEquality {
    fn num_variables(&self) -> usize {
        self.0.n
    }
    fn num_equalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.0.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.0.gradient(x, g)
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        h[0] = x[0] - 0.5 + self.0.eps * self.0.noise(&[x[1], x[0]]);
        Ok(())
    }
    fn equality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, 1.0);
        Ok(())
    }
}
