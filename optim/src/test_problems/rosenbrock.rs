//! The chained Rosenbrock function: unconstrained, in any number of variables.

use crate::error::EvalError;
use crate::problem::Problem;

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
