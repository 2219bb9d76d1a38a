//! The Gauss–Newton model of residual norms against the BFGS model of the same term inside the
//! smooth objective, on the nonlinear least-squares class of `optim::test_problems`: the same
//! optimum, in far fewer iterations (counts, not times, with a margin).

use optim::test_problems::{least_squares, LeastSquares, NormModel};
use optim::{
    EvalError, LbfgsSettings, LbfgsSolver, OptimError, Problem, ResidualNorm, Solution,
    SqpSettings, SqpSolver, Status,
};

fn solve(p: &LeastSquares, model: NormModel) -> Solution {
    let mut q = p.clone().with_model(model);
    let solver = SqpSolver::new(SqpSettings::default()).expect("settings");
    solver.solve(&mut q, &p.x0).expect("valid problem")
}

fn problem(name: &str) -> LeastSquares {
    least_squares()
        .into_iter()
        .find(|p| p.name == name)
        .expect("a problem of the class")
}

/// Gauss–Newton converges to the optimum within `cap` iterations; the BFGS model of the same term
/// takes at least `factor` times as many iterations, or never verifies convergence.
fn assert_faster(name: &str, cap: usize, factor: f64) {
    let p = problem(name);
    let gn = solve(&p, NormModel::Residual);
    assert_eq!(gn.status, Status::Converged, "{name}: {}", gn.message);
    assert!(gn.iterations <= cap, "{name}: {} iterations", gn.iterations);
    if let Some(f_star) = p.f_star {
        assert!(
            (gn.objective - f_star).abs() <= 1e-8,
            "{name}: {}",
            gn.objective
        );
    }
    let bfgs = solve(&p, NormModel::Smooth);
    assert!(
        bfgs.status != Status::Converged || bfgs.iterations as f64 >= factor * gn.iterations as f64,
        "{name}: Gauss–Newton {} iterations, BFGS {}",
        gn.iterations,
        bfgs.iterations
    );
    // The Gauss–Newton optimum is no worse than what BFGS reaches.
    assert!(gn.objective <= bfgs.objective + 1e-8, "{name}");
    // One gradient evaluation per iteration and one at the start, both ways.
    assert_eq!(gn.gradient_evaluations, gn.iterations + 1, "{name}");
}

#[test]
fn rosenbrock_as_a_residual_norm_converges_where_bfgs_cannot_verify_it() {
    // Zero residual: ‖r‖ has a kink at the optimum, which only the cone model can certify.
    assert_faster("rosenbrock", 25, 2.0);
    let bfgs = solve(&problem("rosenbrock"), NormModel::Smooth);
    assert_ne!(bfgs.status, Status::Converged);
}

#[test]
fn chained_rosenbrock_converges_in_far_fewer_iterations() {
    assert_faster("chained rosenbrock", 60, 2.0);
}

#[test]
fn data_fitting_reaches_the_same_optimum_in_far_fewer_iterations() {
    let p = problem("exponential fit");
    assert_faster(p.name, 10, 2.0);
    let (gn, bfgs) = (solve(&p, NormModel::Residual), solve(&p, NormModel::Smooth));
    assert_eq!(bfgs.status, Status::Converged);
    assert!((gn.objective - bfgs.objective).abs() <= 1e-9 * bfgs.objective);
    for (a, b) in gn.x.iter().zip(&bfgs.x) {
        assert!((a - b).abs() <= 1e-5, "{:?} vs {:?}", gn.x, bfgs.x);
    }
}

#[test]
fn constrained_least_squares_reaches_the_boundary_optimum() {
    let p = problem("rosenbrock in the disk");
    assert_faster(p.name, 15, 1.0);
    let gn = solve(&p, NormModel::Residual);
    let radius = (gn.x[0] * gn.x[0] + gn.x[1] * gn.x[1]).sqrt();
    assert!((radius - 1.0).abs() <= 1e-6, "{radius}");
    assert!(gn.multipliers.inequality[0] > 0.0);
    assert_eq!(gn.multipliers.norm_terms.len(), 1);
    assert_eq!(gn.multipliers.norm_terms[0].len(), p.p);
}

#[test]
fn lbfgs_adds_residual_norms_to_the_objective() {
    let p = problem("exponential fit");
    let solver = LbfgsSolver::new(LbfgsSettings::default()).expect("settings");
    let mut residual = p.clone();
    let mut smooth = p.clone().with_model(NormModel::Smooth);
    let a = solver.solve(&mut residual, &p.x0).expect("valid");
    let b = solver.solve(&mut smooth, &p.x0).expect("valid");
    assert_eq!(a.status, Status::Converged, "{}", a.message);
    assert_eq!(a.iterations, b.iterations);
    assert!((a.objective - b.objective).abs() <= 1e-12 * b.objective.max(1.0));
}

/// One residual norm of the given declaration, `r(x) = x − 1`, optionally non-finite.
struct Declared {
    norm: ResidualNorm,
    nan: bool,
}

impl Problem for Declared {
    fn num_variables(&self) -> usize {
        2
    }
    fn residual_norms(&self) -> Vec<ResidualNorm> {
        vec![self.norm.clone()]
    }
    fn residual(&mut self, x: &[f64], _j: usize, r: &mut [f64]) -> Result<(), EvalError> {
        for (ri, xi) in r.iter_mut().zip(x) {
            *ri = if self.nan { f64::NAN } else { xi - 1.0 };
        }
        Ok(())
    }
    fn residual_jacobian(
        &mut self,
        _x: &[f64],
        _j: usize,
        jac: &mut optim::Jacobian,
    ) -> Result<(), EvalError> {
        jac.set(0, 0, 1.0);
        jac.set(1, 1, 1.0);
        Ok(())
    }
    fn objective(&mut self, _x: &[f64]) -> Result<f64, EvalError> {
        Ok(0.0)
    }
    fn gradient(&mut self, _x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g.fill(0.0);
        Ok(())
    }
}

#[test]
fn bad_residual_norms_are_named() {
    let solver = SqpSolver::new(SqpSettings::default()).expect("settings");
    let run = |weight: f64, dimension: usize, nan: bool| {
        let mut p = Declared {
            norm: ResidualNorm::new(weight, dimension),
            nan,
        };
        solver.solve(&mut p, &[0.0, 0.0])
    };
    let err = run(-1.0, 2, false).expect_err("negative weight");
    assert!(matches!(&err, OptimError::InvalidProblem(m) if m.contains("residual norm 0")));
    let err = run(1.0, 0, false).expect_err("no rows");
    assert!(err.to_string().contains("dimension 0"), "{err}");
    let sol = run(1.0, 2, true).expect("valid declaration");
    assert_eq!(sol.status, Status::EvaluationFailed);
    assert!(sol.message.contains("residual 0"), "{}", sol.message);
    // A linear residual norm is solved exactly: one step lands on the kink.
    let sol = run(1.0, 2, false).expect("valid");
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(sol.x.iter().all(|v| (v - 1.0).abs() <= 1e-8), "{:?}", sol.x);
}

#[test]
fn bfgs_learns_nothing_of_the_modelled_term() {
    // Rosenbrock's curvature is in the hundreds; with no smooth part, every update's gradient
    // difference is zero, so the damped updates only shrink the identity it starts from.
    let p = problem("rosenbrock");
    let gn = solve(&p, NormModel::Residual);
    let b = gn.hessian.expect("a positive definite matrix");
    assert!((0..2).all(|i| b.get(i, i) <= 1.0), "{b:?}");
    let bfgs = solve(&p, NormModel::Smooth);
    let b = bfgs.hessian.expect("a positive definite matrix");
    assert!((0..2).any(|i| b.get(i, i) > 10.0), "{b:?}");
}
