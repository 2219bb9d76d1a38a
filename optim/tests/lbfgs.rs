//! L-BFGS on problems with known solutions.

use optim::test_problems::{hock_schittkowski, rosenbrock_start, FailsAfter, Rosenbrock};
use optim::{
    Bounds, ControlFlow, EvalError, LbfgsSettings, LbfgsSolver, OptimError, Problem, Status,
};

fn solver() -> LbfgsSolver {
    LbfgsSolver::new(LbfgsSettings::default()).expect("default settings are valid")
}

#[test]
fn rosenbrock_2() {
    let mut p = Rosenbrock { n: 2 };
    let sol = solver().solve(&mut p, &rosenbrock_start(2)).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    for x in &sol.x {
        assert!((x - 1.0).abs() < 1e-5, "{:?}", sol.x);
    }
    assert!(sol.objective < 1e-10);
    assert!(sol.kkt_residual <= 1e-6);
}

#[test]
fn rosenbrock_100() {
    let mut p = Rosenbrock { n: 100 };
    let mut iterations = 0;
    let sol = solver()
        .solve_with_callback(&mut p, &rosenbrock_start(100), |info| {
            iterations = info.iteration;
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert_eq!(iterations, sol.iterations);
    for x in &sol.x {
        assert!((x - 1.0).abs() < 1e-5, "{:?}", sol.x);
    }
    assert!(sol.objective < 1e-10);
}

/// `min Rosenbrock(x)  s.t.  x₀ ≤ 0.5`: optimum (0.5, 0.25), f = 0.25, multiplier 1 on the bound.
struct BoundedRosenbrock;

impl Problem for BoundedRosenbrock {
    fn num_variables(&self) -> usize {
        2
    }
    fn bounds(&self) -> Option<Bounds> {
        Some(Bounds::new(
            vec![f64::NEG_INFINITY; 2],
            vec![0.5, f64::INFINITY],
        ))
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Rosenbrock { n: 2 }.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        Rosenbrock { n: 2 }.gradient(x, g)
    }
}

#[test]
fn bounded_rosenbrock() {
    let sol = solver()
        .solve(&mut BoundedRosenbrock, &[-1.2, 1.0])
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(
        (sol.x[0] - 0.5).abs() < 1e-7 && (sol.x[1] - 0.25).abs() < 1e-6,
        "{:?}",
        sol.x
    );
    assert!((sol.objective - 0.25).abs() < 1e-9);
    assert!((sol.multipliers.upper_bound[0] - 1.0).abs() < 1e-5);
}

#[test]
fn bound_constrained_hock_schittkowski() {
    for name in ["HS1", "HS4", "HS5"] {
        let mut p = hock_schittkowski()
            .into_iter()
            .find(|p| p.name == name)
            .unwrap();
        let x0 = p.x0.clone();
        let sol = solver().solve(&mut p, &x0).unwrap();
        assert_eq!(sol.status, Status::Converged, "{name}: {}", sol.message);
        assert!(p.error(sol.objective) <= 1e-6, "{name}: {}", sol.objective);
    }
}

#[test]
fn general_constraints_are_rejected() {
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS21")
        .unwrap();
    let x0 = p.x0.clone();
    assert!(matches!(
        solver().solve(&mut p, &x0),
        Err(OptimError::Unsupported(_))
    ));
}

/// `f(x) = (x − 3)²`, undefined for `x > 3.5`; the first steps overshoot into the hole.
struct Hole;

impl Problem for Hole {
    fn num_variables(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        if x[0] > 3.5 {
            Err(EvalError::new("undefined"))
        } else {
            Ok((x[0] - 3.0).powi(2))
        }
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 3.0);
        Ok(())
    }
}

#[test]
fn failed_evaluations_shorten_the_step() {
    let sol = solver().solve(&mut Hole, &[-100.0]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!((sol.x[0] - 3.0).abs() < 1e-6);
}

#[test]
fn iteration_limit_is_not_convergence() {
    let s = LbfgsSolver::new(LbfgsSettings::builder().max_iterations(5).build().unwrap()).unwrap();
    let sol = s
        .solve(&mut Rosenbrock { n: 10 }, &rosenbrock_start(10))
        .unwrap();
    assert_eq!(sol.status, Status::IterationLimit);
    assert!(sol.kkt_residual > 1e-6);
}

/// `x₀² + 10 x₁²` (wrapped in [`FailsAfter`] so that its objective evaluations fail after a budget).
struct Elliptic;

impl Problem for Elliptic {
    fn num_variables(&self) -> usize {
        2
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x[0] * x[0] + 10.0 * x[1] * x[1])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * x[0];
        g[1] = 20.0 * x[1];
        Ok(())
    }
}

#[test]
fn callback_sees_each_iteration_once_across_a_memory_reset() {
    let mut seen = Vec::new();
    let sol = solver()
        .solve_with_callback(&mut FailsAfter::new(Elliptic, 4), &[1.0, 1.0], |info| {
            seen.push(info.iteration);
            ControlFlow::Continue(())
        })
        .unwrap();
    // The line search fails with a non-empty memory, which is reset and the iteration repeated.
    assert_eq!(sol.status, Status::EvaluationFailed, "{}", sol.message);
    assert!(sol.iterations >= 1);
    let expected: Vec<usize> = (0..=sol.iterations).collect();
    assert_eq!(seen, expected);
}

#[test]
fn an_interrupting_evaluation_ends_the_run_at_once() {
    let mut problem = FailsAfter::interrupting(Elliptic, 4);
    let sol = solver().solve(&mut problem, &[1.0, 1.0]).unwrap();
    assert_eq!(sol.status, Status::Interrupted, "{}", sol.message);
    assert!(sol.message.contains("out of time"), "{}", sol.message);
    // One declined trial ends the run: no memory reset, no further trials (with plain failures,
    // the test above, the line search tries again and the run ends `evaluation_failed`).
    assert_eq!(problem.failed, 1);
    assert!(
        sol.objective < 11.0,
        "the last accepted iterate, not the start"
    );
}
