//! The L-BFGS memory: the stored pairs, the two-loop recursion, and the search direction it
//! gives (with the two-metric projection's held variables under bounds).

use crate::eval::Evaluator;
use crate::linalg::{axpy, dot, norm2, norm_inf};
use crate::problem::Problem;
use std::collections::VecDeque;

/// The last pairs `(s, y, 1/sᵀy)`, oldest first, and the initial scaling `γ = sᵀy/yᵀy` of the
/// newest.
pub(super) struct Memory {
    pairs: VecDeque<(Vec<f64>, Vec<f64>, f64)>,
    gamma: f64,
    /// No step has been taken since the memory was last emptied.
    pub fresh: bool,
}

impl Memory {
    /// An empty memory (`γ = 1`).
    pub fn new() -> Self {
        Memory {
            pairs: VecDeque::new(),
            gamma: 1.0,
            fresh: true,
        }
    }

    /// Forgets the pairs (keeping `γ`).
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.fresh = true;
    }

    /// Forgets the pairs and `γ`.
    pub fn reset(&mut self) {
        self.pairs.clear();
        self.gamma = 1.0;
        self.fresh = true;
    }

    /// Stores the step `s` with the gradient change `y` when its curvature `sᵀy` is positive
    /// (relative to `‖s‖‖y‖`), keeping at most `limit` pairs.
    pub fn store(&mut self, s: &[f64], y: Vec<f64>, limit: usize) {
        let sy = dot(s, &y);
        let yy = dot(&y, &y);
        if sy > 1e-12 * norm2(s) * norm2(&y) && sy > 0.0 {
            self.gamma = sy / yy;
            self.pairs.push_back((s.to_vec(), y, 1.0 / sy));
            if self.pairs.len() > limit {
                self.pairs.pop_front();
            }
        }
    }

    /// The search direction at `x` with gradient `g` (projected-gradient max-norm `pg_norm`),
    /// and the first trial step length. Under bounds, variables within `ε = min(pg_norm, 1e-3)`
    /// of a bound that the gradient pushes outwards are held: they take the scaled gradient
    /// step, the L-BFGS direction acts on the rest. Without descent the memory is cleared and
    /// the direction is the scaled gradient step.
    pub fn direction<P: Problem + ?Sized>(
        &mut self,
        ev: &Evaluator<'_, P>,
        x: &[f64],
        g: &[f64],
        pg_norm: f64,
    ) -> (Vec<f64>, f64) {
        let n = ev.n;
        let bounded = ev.has_bounds;
        let eps = pg_norm.min(1e-3);
        let held: Vec<bool> = (0..n)
            .map(|i| {
                bounded
                    && ((x[i] - ev.lower[i] <= eps && g[i] > 0.0)
                        || (ev.upper[i] - x[i] <= eps && g[i] < 0.0))
            })
            .collect();
        let masked: Vec<f64> = (0..n).map(|i| if held[i] { 0.0 } else { g[i] }).collect();
        let mut d: Vec<f64> = two_loop(&self.pairs, &masked, self.gamma)
            .into_iter()
            .map(|v| -v)
            .collect();
        for i in 0..n {
            if held[i] {
                d[i] = -self.gamma * g[i];
            }
        }
        let descent = dot(&d, &masked) < 0.0;
        if !descent && norm_inf(&masked) > 0.0 {
            self.clear();
            d = g.iter().map(|gi| -self.gamma * gi).collect();
        }
        let alpha0 = if self.pairs.is_empty() {
            (1.0 / norm_inf(&d).max(1e-300)).min(1.0)
        } else {
            1.0
        };
        (d, alpha0)
    }
}

/// Two-loop recursion: `H · v` with the stored pairs (`H₀ = γI`).
fn two_loop(pairs: &VecDeque<(Vec<f64>, Vec<f64>, f64)>, v: &[f64], gamma: f64) -> Vec<f64> {
    let mut q = v.to_vec();
    let mut alphas = Vec::with_capacity(pairs.len());
    for (s, y, rho) in pairs.iter().rev() {
        let a = rho * dot(s, &q);
        axpy(-a, y, &mut q);
        alphas.push(a);
    }
    for v in &mut q {
        *v *= gamma;
    }
    for ((s, y, rho), a) in pairs.iter().zip(alphas.iter().rev()) {
        let b = rho * dot(y, &q);
        axpy(a - b, s, &mut q);
    }
    q
}
