//! Times the SQP on a synthetic problem shaped like the cloth application: 60 variables
//! (10 steps × 2 control points × 3), 1000 dense nonlinear inequality constraints, and 9 norm terms
//! `‖u_t − u_{t−1}‖` (6-vectors), started from all zeros (every norm term on its kink).
//!
//! ```sh
//! cargo run --release -p optim --example cloth_sized
//! ```

use optim::{
    ControlFlow, DenseMatrix, EvalError, Jacobian, NormTerm, Problem, SqpSettings, SqpSolver,
};
use std::time::Instant;

const STEPS: usize = 10;
const PER_STEP: usize = 6;
const N: usize = STEPS * PER_STEP;
const M: usize = 1000;

/// Deterministic pseudo-random numbers in [-1, 1] (64-bit LCG).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// `min Σ (x − t)² + 0.1 Σ sin x + 0.5 Σ ‖u_t − u_{t−1}‖  s.t.  1 − aᵢᵀx − 0.1 (aᵢᵀx)² ≥ 0`.
struct ClothLike {
    target: Vec<f64>,
    a: DenseMatrix,
}

impl ClothLike {
    fn new() -> Self {
        let mut rng = Lcg(42);
        let target = (0..N).map(|_| 2.0 * rng.next()).collect();
        let scale = 1.0 / (N as f64).sqrt();
        let data = (0..M * N).map(|_| scale * rng.next()).collect();
        let a = DenseMatrix::from_row_major(M, N, data).expect("shape");
        Self { target, a }
    }
    fn ax(&self, x: &[f64], i: usize) -> f64 {
        self.a.row(i).iter().zip(x).map(|(a, x)| a * x).sum()
    }
}

impl Problem for ClothLike {
    fn num_variables(&self) -> usize {
        N
    }
    fn num_inequalities(&self) -> usize {
        M
    }
    fn norm_terms(&self) -> Vec<NormTerm> {
        (1..STEPS)
            .map(|t| {
                let cur: Vec<usize> = (t * PER_STEP..(t + 1) * PER_STEP).collect();
                let prev: Vec<usize> = ((t - 1) * PER_STEP..t * PER_STEP).collect();
                NormTerm::difference(0.5, N, &cur, &prev)
            })
            .collect()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x.iter()
            .zip(&self.target)
            .map(|(x, t)| (x - t).powi(2) + 0.1 * x.sin())
            .sum())
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        for ((g, x), t) in g.iter_mut().zip(x).zip(&self.target) {
            *g = 2.0 * (x - t) + 0.1 * x.cos();
        }
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        for (i, ci) in c.iter_mut().enumerate() {
            let s = self.ax(x, i);
            *ci = 1.0 - s - 0.1 * s * s;
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        for i in 0..M {
            let s = self.ax(x, i);
            let k = -(1.0 + 0.2 * s);
            let a_row: Vec<f64> = self.a.row(i).to_vec();
            if let Some(row) = jac.dense_row_mut(i) {
                for (r, a) in row.iter_mut().zip(&a_row) {
                    *r = k * a;
                }
            }
        }
        Ok(())
    }
}

fn main() {
    let mut p = ClothLike::new();
    let solver = SqpSolver::new(SqpSettings::default()).expect("valid settings");
    let start = Instant::now();
    let mut last = Instant::now();
    let sol = solver
        .solve_with_callback(&mut p, &[0.0; N], |info| {
            println!(
                "iter {:3}  f {:12.6}  viol {:.1e}  kkt {:.1e}  step {:.1e}  α {:.2}  ν {:.0e}  {:6.1} ms",
                info.iteration,
                info.objective,
                info.constraint_violation,
                info.kkt_residual,
                info.step_norm,
                info.step_length,
                info.penalty,
                last.elapsed().as_secs_f64() * 1e3
            );
            last = Instant::now();
            ControlFlow::Continue(())
        })
        .expect("valid problem");
    let total = start.elapsed().as_secs_f64();
    let active = {
        let mut c = vec![0.0; M];
        let _ = p.inequalities(&sol.x, &mut c);
        c.iter().filter(|v| v.abs() < 1e-6).count()
    };
    println!(
        "\n{} after {} iterations ({} f-evals, {} g-evals), objective {:.8}, {} active constraints",
        sol.status,
        sol.iterations,
        sol.function_evaluations,
        sol.gradient_evaluations,
        sol.objective,
        active
    );
    println!(
        "total {:.1} ms, {:.1} ms per iteration (problem evaluations here cost ~0.1 ms)",
        total * 1e3,
        total * 1e3 / sol.iterations.max(1) as f64
    );
}
