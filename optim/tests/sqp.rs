//! SQP behaviour on problems with known solutions.

use optim::test_problems::{hock_schittkowski, rosenbrock_start, FailsAfter, Rosenbrock, TwoDisks};
use optim::{
    Bounds, ControlFlow, DenseMatrix, EvalError, Jacobian, NormTerm, OptimError, Problem,
    SparseMatrix, SqpSettings, SqpSolver, Status,
};

fn solver() -> SqpSolver {
    SqpSolver::new(SqpSettings::default()).expect("default settings are valid")
}

#[test]
fn hock_schittkowski_problems_reach_the_published_optimum() {
    let problems = hock_schittkowski();
    assert!(problems.len() >= 10);
    for mut p in problems {
        let x0 = p.x0.clone();
        let sol = solver().solve(&mut p, &x0).expect("valid problem");
        assert_eq!(sol.status, Status::Converged, "{}: {}", p.name, sol.message);
        assert!(
            p.error(sol.objective) <= 1e-6,
            "{}: objective {} vs published {}",
            p.name,
            sol.objective,
            p.f_star
        );
        assert!(sol.kkt_residual <= 1e-6 && sol.constraint_violation <= 1e-8);
    }
}

#[test]
fn locally_infeasible_problem_is_reported_infeasible() {
    let sol = solver()
        .solve(&mut TwoDisks { far_disk: None }, &[0.2, 0.7])
        .unwrap();
    match sol.status {
        Status::Infeasible { best_violation } => {
            assert!((best_violation - 1.25).abs() < 1e-4, "{best_violation}");
        }
        other => panic!("expected Infeasible, got {other:?}: {}", sol.message),
    }
    assert!(
        (sol.x[0] - 1.5).abs() < 1e-3 && sol.x[1].abs() < 1e-3,
        "{:?}",
        sol.x
    );
}

/// `min −100 x  s.t.  x ≤ 0`, started just outside the feasible set: the elastic QP with the initial
/// weight prefers to violate the constraint, while the feasibility LP removes the violation entirely.
struct SteepAtTheBoundary;

impl Problem for SteepAtTheBoundary {
    fn num_variables(&self) -> usize {
        1
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(-100.0 * x[0])
    }
    fn gradient(&mut self, _x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = -100.0;
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = -x[0];
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -1.0);
        Ok(())
    }
}

#[test]
fn nearly_feasible_start_with_a_consistent_linearization_is_not_infeasible() {
    // Violation 1e-7: above tol_feasibility, below tol_optimality.
    let sol = solver().solve(&mut SteepAtTheBoundary, &[1e-7]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(sol.x[0].abs() < 1e-8, "{:?}", sol.x);
}

/// `min (x − 1)²  s.t.  x ≥ 0,  1e7 x² − x − 5e−8 ≥ 0`, started at x = −1e−7. The feasible set is
/// x ≥ (1 + √3)/2e7, behind a hump of the ℓ1 violation: that violation falls from the start to its
/// local minimizer x_r = (1 − √3)/2e7 (where the second constraint turns active) and rises beyond it.
/// The first linearization is inconsistent (d ≥ 1e−7 and d ≤ 5e−8), but the feasibility LP halves the
/// violation there, so the start is not stationary for it; x_r is.
struct SmallInconsistentViolation;

impl Problem for SmallInconsistentViolation {
    fn num_variables(&self) -> usize {
        1
    }
    fn num_inequalities(&self) -> usize {
        2
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok((x[0] - 1.0).powi(2))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 1.0);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = x[0];
        c[1] = 1e7 * x[0] * x[0] - x[0] - 5e-8;
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, 1.0);
        j.set(1, 0, 2e7 * x[0] - 1.0);
        Ok(())
    }
}

#[test]
fn small_violation_is_infeasible_only_where_it_is_stationary() {
    let sol = solver()
        .solve(&mut SmallInconsistentViolation, &[-1e-7])
        .unwrap();
    let x_r = (1.0 - 3f64.sqrt()) / 2e7;
    match sol.status {
        // Not at the start's 1e-7: the LP reduces that violation by half.
        // The LP resolves reductions only to Clarabel's tolerance: x_r is reached to 1e-3 of itself.
        Status::Infeasible { best_violation } => assert!(
            (best_violation + x_r).abs() < 1e-3 * x_r.abs(),
            "{best_violation} vs {}: {} after {} iterations",
            -x_r,
            sol.message,
            sol.iterations
        ),
        other => panic!("expected Infeasible, got {other:?}: {}", sol.message),
    }
    assert!(
        (sol.x[0] - x_r).abs() < 1e-3 * x_r.abs(),
        "{:?} vs {x_r}",
        sol.x
    );
}

/// `min x₀² + w x₁²  s.t.  s (x₀ + x₁ − 1) ≥ 0` for a curvature `w` and a constraint scale `s`.
struct AboveLine {
    w: f64,
    s: f64,
}

impl Problem for AboveLine {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x[0] * x[0] + self.w * x[1] * x[1])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * x[0];
        g[1] = 2.0 * self.w * x[1];
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = self.s * (x[0] + x[1] - 1.0);
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, self.s);
        j.set(0, 1, self.s);
        Ok(())
    }
}

#[test]
fn callback_sees_each_iteration_once_across_a_hessian_reset() {
    let mut seen = Vec::new();
    let sol = solver()
        .solve_with_callback(
            // min x₀² + 10 x₁²  s.t.  x₀ + x₁ ≥ 1, its objective failing after 4 evaluations.
            &mut FailsAfter::new(AboveLine { w: 10.0, s: 1.0 }, 4),
            &[3.0, -1.0],
            |info| {
                seen.push(info.iteration);
                ControlFlow::Continue(())
            },
        )
        .unwrap();
    // The line search fails after a BFGS update, so the Hessian is reset and the iteration repeated.
    assert_eq!(sol.status, Status::EvaluationFailed, "{}", sol.message);
    assert!(sol.iterations >= 1);
    let expected: Vec<usize> = (0..=sol.iterations).collect();
    assert_eq!(seen, expected);
}

#[test]
fn an_interrupting_evaluation_ends_the_run_at_once() {
    // The same problem, its evaluations declined after 4 as a planner's deadline declines them.
    let mut problem = FailsAfter::interrupting(AboveLine { w: 10.0, s: 1.0 }, 4);
    let sol = solver().solve(&mut problem, &[3.0, -1.0]).unwrap();
    assert_eq!(sol.status, Status::Interrupted, "{}", sol.message);
    assert!(sol.message.contains("out of time"), "{}", sol.message);
    // One declined trial ends the run: no shorter step, no Hessian reset (with plain failures,
    // the test above, the line search halves and the run ends `evaluation_failed`).
    assert_eq!(problem.failed, 1);
    assert_eq!(sol.function_evaluations, 5);
}

/// `min (x₀ − 0.3)² + x₁²  s.t.  x₀² + x₁² ≥ 1,  x₀ ≤ 2`, from (0.1, 0): the linearization
/// `−0.99 + 0.2 d₀ ≥ 0` needs `d₀ ≥ 4.95` but the bound allows `d₀ ≤ 1.9`.
struct OutsideDisk;

impl Problem for OutsideDisk {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn bounds(&self) -> Option<Bounds> {
        Some(Bounds::new(
            vec![f64::NEG_INFINITY; 2],
            vec![2.0, f64::INFINITY],
        ))
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok((x[0] - 0.3).powi(2) + x[1] * x[1])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 0.3);
        g[1] = 2.0 * x[1];
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = x[0] * x[0] + x[1] * x[1] - 1.0;
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, 2.0 * x[0]);
        j.set(0, 1, 2.0 * x[1]);
        Ok(())
    }
}

#[test]
fn inconsistent_first_linearization_is_solved_anyway() {
    let mut infos = Vec::new();
    let sol = solver()
        .solve_with_callback(&mut OutsideDisk, &[0.1, 0.0], |info| {
            infos.push(info.clone());
            ControlFlow::Continue(())
        })
        .unwrap();
    assert!(
        infos[0].linearized_violation > 0.1,
        "the first QP must need its elastic slack: {:?}",
        infos[0]
    );
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(
        (sol.x[0] - 1.0).abs() < 1e-6 && sol.x[1].abs() < 1e-6,
        "{:?}",
        sol.x
    );
    assert!((sol.objective - 0.49).abs() < 1e-6);
}

/// `min ½‖x − a‖² + w‖x‖`: `x* = 0` if `‖a‖ ≤ w`, else `x* = a (1 − w/‖a‖)`.
struct ShrinkToward {
    a: Vec<f64>,
    w: f64,
}

impl Problem for ShrinkToward {
    fn num_variables(&self) -> usize {
        self.a.len()
    }
    fn norm_terms(&self) -> Vec<NormTerm> {
        let n = self.a.len();
        vec![NormTerm::from_dense(
            self.w,
            &DenseMatrix::identity(n),
            vec![0.0; n],
        )]
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(0.5
            * x.iter()
                .zip(&self.a)
                .map(|(x, a)| (x - a).powi(2))
                .sum::<f64>())
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        for ((g, x), a) in g.iter_mut().zip(x).zip(&self.a) {
            *g = x - a;
        }
        Ok(())
    }
}

#[test]
fn norm_term_optimum_on_the_kink_is_found_exactly() {
    let a = vec![0.3, -0.2, 0.1];
    let na = a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut p = ShrinkToward {
        a: a.clone(),
        w: 1.0,
    };
    let sol = solver().solve(&mut p, &[2.0, 1.0, -1.0]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    let nx = sol.x.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(nx < 1e-7, "x = {:?}", sol.x);
    assert!((sol.objective - 0.5 * na * na).abs() < 1e-9);
    // The subgradient multiplier certifies optimality: y = a, ‖y‖ ≤ w.
    let y = &sol.multipliers.norm_terms[0];
    for (yi, ai) in y.iter().zip(&a) {
        assert!((yi - ai).abs() < 1e-6, "{y:?}");
    }
}

#[test]
fn norm_term_optimum_off_the_kink_matches_closed_form() {
    let a = vec![3.0, -2.0, 1.0];
    let w = 1.0;
    let na = a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut p = ShrinkToward { a: a.clone(), w };
    // Start exactly on the kink, where a smooth quasi-Newton method has no gradient.
    let sol = solver().solve(&mut p, &[0.0, 0.0, 0.0]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    for (x, a) in sol.x.iter().zip(&a) {
        assert!((x - a * (1.0 - w / na)).abs() < 1e-6, "{:?}", sol.x);
    }
    let expected = 0.5 * w * w + w * (na - w);
    assert!((sol.objective - expected).abs() < 1e-9);
}

/// A trajectory: `u₁…u_T ∈ ℝ²`, `u₀ = 0`, minimize `½ Σ ‖u_t − p‖² + w Σ ‖u_t − u_{t−1}‖`.
/// With `T‖p‖ > w` the optimum keeps all controls equal, `u_t = p (1 − w/(T‖p‖))`: every difference but
/// the first sits on its kink, with subgradients `y_t = (T − t + 1)(w/T) p̂` strictly inside the ball.
/// Started from all zeros, where every norm term is on its kink.
struct Trajectory {
    steps: usize,
    target: [f64; 2],
    weight: f64,
}

impl Problem for Trajectory {
    fn num_variables(&self) -> usize {
        2 * self.steps
    }
    fn norm_terms(&self) -> Vec<NormTerm> {
        let n = self.num_variables();
        let mut terms = vec![NormTerm::distance_to(self.weight, n, &[0, 1], &[0.0, 0.0])];
        for t in 1..self.steps {
            terms.push(NormTerm::difference(
                self.weight,
                n,
                &[2 * t, 2 * t + 1],
                &[2 * t - 2, 2 * t - 1],
            ));
        }
        terms
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x.chunks(2)
            .map(|u| 0.5 * ((u[0] - self.target[0]).powi(2) + (u[1] - self.target[1]).powi(2)))
            .sum())
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        for (gi, (xi, k)) in g.iter_mut().zip(x.iter().zip((0..2).cycle())) {
            *gi = xi - self.target[k];
        }
        Ok(())
    }
}

#[test]
fn trajectory_of_norm_terms_from_an_all_zero_start() {
    let target = [0.6, -0.8];
    let (steps, weight) = (5, 1.0);
    let mut p = Trajectory {
        steps,
        target,
        weight,
    };
    let sol = solver().solve(&mut p, &vec![0.0; 2 * steps]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    let shrink = 1.0 - weight / steps as f64; // ‖p‖ = 1
    for u in sol.x.chunks(2) {
        assert!((u[0] - shrink * target[0]).abs() < 1e-6, "{:?}", sol.x);
        assert!((u[1] - shrink * target[1]).abs() < 1e-6, "{:?}", sol.x);
    }
    let expected = 0.5 * steps as f64 * (1.0 - shrink).powi(2) + weight * shrink;
    assert!((sol.objective - expected).abs() < 1e-7);
}

/// `min (x − 3)²  s.t.  4 − x² ≥ 0`, whose objective cannot be evaluated for `x > 2.5`.
struct Domain;

impl Problem for Domain {
    fn num_variables(&self) -> usize {
        1
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        if x[0] > 2.5 {
            return Err(EvalError::new("outside the simulation's domain"));
        }
        Ok((x[0] - 3.0).powi(2))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 3.0);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = 4.0 - x[0] * x[0];
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -2.0 * x[0]);
        Ok(())
    }
}

#[test]
fn failed_evaluations_shorten_the_step() {
    // From x = 0 the Jacobian vanishes and the first step (−∇f = 6) lands outside the domain.
    let sol = solver().solve(&mut Domain, &[0.0]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!((sol.x[0] - 2.0).abs() < 1e-7);
    assert!((sol.objective - 1.0).abs() < 1e-7);
}

struct Broken;

impl Problem for Broken {
    fn num_variables(&self) -> usize {
        2
    }
    fn objective(&mut self, _x: &[f64]) -> Result<f64, EvalError> {
        Ok(f64::NAN)
    }
    fn gradient(&mut self, _x: &[f64], _g: &mut [f64]) -> Result<(), EvalError> {
        Ok(())
    }
}

#[test]
fn evaluation_failure_at_the_start_is_reported() {
    let sol = solver().solve(&mut Broken, &[0.0, 0.0]).unwrap();
    assert_eq!(sol.status, Status::EvaluationFailed);
    assert!(sol.message.contains("starting point"), "{}", sol.message);
}

#[test]
fn limits_and_callback_stop_are_reported_honestly() {
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS100")
        .unwrap();
    let x0 = p.x0.clone();
    let s = SqpSolver::new(SqpSettings::builder().max_iterations(3).build().unwrap()).unwrap();
    let sol = s.solve(&mut p, &x0).unwrap();
    assert_eq!(sol.status, Status::IterationLimit);
    assert_eq!(sol.iterations, 3);

    let mut seen = Vec::new();
    let sol = solver()
        .solve_with_callback(&mut p, &x0, |info| {
            seen.push((info.iteration, info.function_evaluations));
            if info.iteration == 2 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    assert_eq!(sol.status, Status::Interrupted);
    assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), vec![0, 1, 2]);
    assert!(seen.windows(2).all(|w| w[1].1 > w[0].1));
}

/// A non-smooth objective hidden in the smooth part (`|x|`) cannot satisfy the KKT test at the kink
/// from a quasi-Newton model: the run must not claim convergence unless the residual really is small.
struct HiddenKink;

impl Problem for HiddenKink {
    fn num_variables(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(x[0].abs() + 0.01 * x[0])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = x[0].signum() + 0.01;
        Ok(())
    }
}

#[test]
fn never_claims_convergence_at_a_hidden_kink() {
    let sol = solver().solve(&mut HiddenKink, &[1.0]).unwrap();
    // |g| ≥ 0.99 everywhere, so the KKT residual can never drop below tolerance.
    assert_ne!(sol.status, Status::Converged, "{sol:?}");
    assert!(sol.kkt_residual > 0.5 || sol.kkt_residual.is_infinite());
}

/// HS43 with a sparse Jacobian gives the same answer as with the dense one.
struct SparseHs43(optim::test_problems::TestProblem);

impl Problem for SparseHs43 {
    fn num_variables(&self) -> usize {
        4
    }
    fn num_inequalities(&self) -> usize {
        3
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.0.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.0.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        self.0.inequalities(x, c)
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        let mut dense = Jacobian::dense(3, 4);
        self.0.inequality_jacobian(x, &mut dense)?;
        let mut s = SparseMatrix::new(3, 4);
        // Push in reverse order, split into duplicates, to exercise the CSC assembly.
        for i in (0..3).rev() {
            for j in (0..4).rev() {
                if let Jacobian::Dense(d) = &dense {
                    s.push(i, j, 0.5 * d.get(i, j));
                    s.push(i, j, 0.5 * d.get(i, j));
                }
            }
        }
        *jac = Jacobian::Sparse(s);
        Ok(())
    }
}

#[test]
fn sparse_jacobians_are_supported() {
    let p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS43")
        .unwrap();
    let mut sp = SparseHs43(p);
    let sol = solver().solve(&mut sp, &[0.0; 4]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!((sol.objective + 44.0).abs() < 1e-6);
}

#[test]
fn invalid_input_is_an_error_not_a_status() {
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS21")
        .unwrap();
    assert!(matches!(
        solver().solve(&mut p, &[1.0]),
        Err(OptimError::InvalidStartingPoint(_))
    ));
    assert!(matches!(
        solver().solve(&mut p, &[f64::NAN, 0.0]),
        Err(OptimError::InvalidStartingPoint(_))
    ));
    p.bounds = Some(Bounds::new(vec![1.0, 0.0], vec![0.0, 1.0]));
    assert!(matches!(
        solver().solve(&mut p, &[0.5, 0.5]),
        Err(OptimError::InvalidProblem(_))
    ));
    assert!(SqpSolver::new(SqpSettings {
        elastic_weight: 0.0,
        ..SqpSettings::default()
    })
    .is_err());
}

#[test]
fn solution_serializes_to_json() {
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS35")
        .unwrap();
    let x0 = p.x0.clone();
    let sol = solver().solve(&mut p, &x0).unwrap();
    let json = serde_json::to_string(&sol).unwrap();
    let back: optim::Solution = serde_json::from_str(&json).unwrap();
    assert_eq!(back.status, Status::Converged);
    assert_eq!(back.iterations, sol.iterations);
}

/// `min x₀² + x₁²  s.t.  10⁶ (x₀ + x₁ − 1) ≥ 0`: the constraint is scaled internally, but the reported
/// multiplier is the one of the constraint as written, `λ = 10⁻⁶`, and the violation is unscaled.
#[test]
fn constraint_scaling_is_invisible_in_the_results() {
    let mut infos = Vec::new();
    let sol = solver()
        .solve_with_callback(&mut AboveLine { w: 1.0, s: 1e6 }, &[0.0, 0.0], |i| {
            infos.push(i.constraint_violation);
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!((sol.x[0] - 0.5).abs() < 1e-7 && (sol.x[1] - 0.5).abs() < 1e-7);
    assert!(
        (sol.multipliers.inequality[0] - 1e-6).abs() < 1e-12,
        "{:?}",
        sol.multipliers
    );
    // At x = 0 the unscaled violation is 10⁶.
    assert_eq!(infos[0], 1e6);
}

#[test]
fn clarabel_failures_are_reported_not_hidden() {
    // One interior-point iteration per QP: Clarabel stops with MaxIterations every time.
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == "HS35")
        .unwrap();
    let x0 = p.x0.clone();
    let s = SqpSolver::new(SqpSettings::builder().qp_max_iterations(1).build().unwrap()).unwrap();
    let sol = s.solve(&mut p, &x0).unwrap();
    assert_eq!(sol.status, Status::Stalled, "{}", sol.message);
    assert!(sol.message.contains("MaxIterations"), "{}", sol.message);
}

/// `min ½xᵀQx + gᵀx  s.t.  Ax ≥ b` with linear constraints given as data.
struct LinearQp {
    q: DenseMatrix,
    g: Vec<f64>,
    a: DenseMatrix,
    b: Vec<f64>,
}

impl Problem for LinearQp {
    fn num_variables(&self) -> usize {
        self.g.len()
    }
    fn num_inequalities(&self) -> usize {
        self.b.len()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        Some(self.q.clone())
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        let n = x.len();
        Ok((0..n)
            .map(|i| {
                x[i] * (self.g[i] + 0.5 * (0..n).map(|j| self.q.get(i, j) * x[j]).sum::<f64>())
            })
            .sum())
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) -> Result<(), EvalError> {
        for (i, gi) in grad.iter_mut().enumerate() {
            *gi = self.g[i] + self.q.row(i).iter().zip(x).map(|(q, x)| q * x).sum::<f64>();
        }
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        for (i, ci) in c.iter_mut().enumerate() {
            *ci = self.a.row(i).iter().zip(x).map(|(a, x)| a * x).sum::<f64>() - self.b[i];
        }
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        *jac = Jacobian::Dense(self.a.clone());
        Ok(())
    }
}

/// The random convex QP (n = 5, m = 6, 3 active rows at `x*`) on which the first QP subproblem made
/// Clarabel 0.11.1 cycle until `MaxIterations` with its default settings (its Ruiz equilibration; the
/// same data solves in ~10 interior-point iterations without it). Shrunk by proptest from
/// `tests/random_qp.rs`; every number is the exact `f64` that test built.
fn clarabel_cycling_qp() -> (LinearQp, Vec<f64>, Vec<f64>) {
    let q = vec![
        1.9781326765955214,
        0.0,
        -0.5040413190788106,
        0.0,
        0.0,
        0.0,
        1.8115628561957942,
        0.8691944337974458,
        -0.8847525037956445,
        -0.6193257772255863,
        -0.5040413190788106,
        0.8691944337974458,
        2.8735665263738457,
        -0.9475815036586605,
        -0.6633060078613126,
        0.0,
        -0.8847525037956445,
        -0.9475815036586605,
        1.9645426561806696,
        0.6751787959272069,
        0.0,
        -0.6193257772255863,
        -0.6633060078613126,
        0.6751787959272069,
        1.4726244127707337,
    ];
    let g = vec![
        2.0009020930206427,
        -3.5283041984871266,
        0.5264067663401049,
        1.8125929747804945,
        -1.6666687674267222,
    ];
    let a = vec![
        vec![0.0, 0.9578297189722299, 0.0, 0.0, 0.0],
        vec![
            0.7048027184804828,
            -0.35131590098222076,
            0.573496694978836,
            0.0,
            -0.9130132061546171,
        ],
        vec![
            0.442961742269267,
            -0.49973545806128394,
            0.5890376787240341,
            0.13188383658815703,
            -0.6626846462721255,
        ],
        vec![
            0.48898432784058915,
            -0.8697493238466748,
            0.0,
            0.40873107406070996,
            -0.4361235913758201,
        ],
        vec![
            0.43585563187349824,
            -0.27781556798459844,
            0.6209104117874865,
            0.0,
            0.0,
        ],
        vec![0.0, -0.8999829656535497, 0.8657201409561787, 0.0, 0.0],
    ];
    let b = vec![
        1.6916354040968078,
        -0.6204635378837348,
        -0.8825892293737787,
        -2.5951018827525525,
        -1.0185851942761937,
        -2.1850888409036564,
    ];
    let x_star = vec![0.0, 1.7661128805984072, 0.0, 0.0, 0.0];
    let x0 = vec![
        -1.1524925112569986,
        -2.8054880263757647,
        -2.4079757413242246,
        1.3185849973991368,
        0.0,
    ];
    let qp = LinearQp {
        q: DenseMatrix::from_row_major(5, 5, q).unwrap(),
        g,
        a: DenseMatrix::from_rows(&a).unwrap(),
        b,
    };
    (qp, x_star, x0)
}

fn assert_solves_to(qp: &mut LinearQp, x_star: &[f64], x0: &[f64]) {
    let sol = solver().solve(qp, x0).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(sol.iterations <= 2, "took {} iterations", sol.iterations);
    assert!(sol.kkt_residual <= 1e-6 && sol.constraint_violation <= 1e-8);
    for (x, xs) in sol.x.iter().zip(x_star) {
        assert!(
            (x - xs).abs() <= 1e-6 * 3.0,
            "x = {:?}, x* = {x_star:?}",
            sol.x
        );
    }
}

#[test]
fn qp_on_which_clarabel_cycles_is_solved_by_the_fallback_settings() {
    let (mut qp, x_star, x0) = clarabel_cycling_qp();
    assert_solves_to(&mut qp, &x_star, &x0);
}

/// The same problem with degenerate rows appended: `0 ≥ 0` (an all-zero row, active everywhere),
/// `0 ≥ −1` (all-zero, never active), exact duplicates of the active rows 0 and 1 and of the inactive
/// row 3. The feasible set and the optimum are unchanged; only the multipliers are no longer unique.
#[test]
fn zero_and_duplicate_constraint_rows_are_solved() {
    let (qp, x_star, x0) = clarabel_cycling_qp();
    let mut rows: Vec<Vec<f64>> = (0..6).map(|i| qp.a.row(i).to_vec()).collect();
    let mut b = qp.b.clone();
    for (row, bi) in [
        (vec![0.0; 5], 0.0),
        (vec![0.0; 5], -1.0),
        (rows[0].clone(), b[0]),
        (rows[1].clone(), b[1]),
        (rows[3].clone(), b[3]),
    ] {
        rows.push(row);
        b.push(bi);
    }
    let mut degenerate = LinearQp {
        a: DenseMatrix::from_rows(&rows).unwrap(),
        b,
        ..qp
    };
    assert_solves_to(&mut degenerate, &x_star, &x0);
}

/// An all-zero row that is violated (`0 ≥ 1`) cannot be repaired by any step: locally infeasible,
/// with best violation 1, and never `Converged`.
#[test]
fn violated_zero_constraint_row_is_reported_infeasible() {
    let (qp, _, x0) = clarabel_cycling_qp();
    let mut rows: Vec<Vec<f64>> = (0..6).map(|i| qp.a.row(i).to_vec()).collect();
    rows.push(vec![0.0; 5]);
    let mut b = qp.b.clone();
    b.push(1.0);
    let mut p = LinearQp {
        a: DenseMatrix::from_rows(&rows).unwrap(),
        b,
        ..qp
    };
    let sol = solver().solve(&mut p, &x0).unwrap();
    match sol.status {
        Status::Infeasible { best_violation } => {
            assert!((best_violation - 1.0).abs() < 1e-9, "{best_violation}");
        }
        other => panic!("expected Infeasible, got {other:?}: {}", sol.message),
    }
}

/// [`Rosenbrock`] with a chosen starting Hessian approximation.
struct WarmRosenbrock(Rosenbrock, Option<DenseMatrix>);

impl Problem for WarmRosenbrock {
    fn num_variables(&self) -> usize {
        self.0.num_variables()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        self.1.clone()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.0.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.0.gradient(x, g)
    }
}

/// A run stopped early returns its quasi-Newton Hessian, another solve accepts it as its initial
/// Hessian (it would be an error if it were not symmetric positive definite), and the run resumed
/// from its point with it needs fewer iterations than one restarted from the identity: what the
/// planner's κ continuation relies on.
#[test]
fn final_hessian_warm_starts_a_resumed_solve() {
    let n = 6;
    let stop_early = SqpSolver::new(SqpSettings::builder().max_iterations(25).build().unwrap())
        .unwrap()
        .solve(
            &mut WarmRosenbrock(Rosenbrock { n }, None),
            &rosenbrock_start(n),
        )
        .unwrap();
    assert_eq!(stop_early.status, Status::IterationLimit);
    let b = stop_early
        .hessian
        .clone()
        .expect("the SQP returns its Hessian");
    let resume = |hessian: Option<DenseMatrix>| {
        solver()
            .solve(
                &mut WarmRosenbrock(Rosenbrock { n }, hessian),
                &stop_early.x,
            )
            .unwrap()
    };
    let (cold, warm) = (resume(None), resume(Some(b)));
    assert_eq!(cold.status, Status::Converged);
    assert_eq!(warm.status, Status::Converged);
    assert!(
        warm.iterations < cold.iterations,
        "warm {} vs cold {} iterations",
        warm.iterations,
        cold.iterations
    );
}

/// An initial Hessian that makes the first step negligible (`10³⁰·I`): the solver falls back to the
/// identity instead of stopping `Stalled` at iteration 0.
#[test]
fn failing_initial_hessian_falls_back_to_the_identity() {
    let n = 2;
    let mut huge = DenseMatrix::identity(n);
    huge.as_mut_slice().iter_mut().for_each(|v| *v *= 1e30);
    let sol = solver()
        .solve(
            &mut WarmRosenbrock(Rosenbrock { n }, Some(huge)),
            &rosenbrock_start(n),
        )
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(sol.x.iter().all(|v| (v - 1.0).abs() < 1e-5), "{:?}", sol.x);
}

/// Rosenbrock with an inactive linear constraint `x₀ + x₁ ≤ 10`, recording every point whose
/// objective is evaluated.
struct RecordedRosenbrock {
    inner: Rosenbrock,
    points: Vec<Vec<f64>>,
}

impl Problem for RecordedRosenbrock {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.points.push(x.to_vec());
        self.inner.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.inner.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = 10.0 - x[0] - x[1];
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -1.0);
        j.set(0, 1, -1.0);
        Ok(())
    }
}

/// Under linear constraints the second-order correction of a rejected full step is that step
/// again (to rounding): it is not evaluated a second time (for a planner, a whole simulation).
#[test]
fn a_rejected_step_is_not_evaluated_again_as_its_own_correction() {
    let mut p = RecordedRosenbrock {
        inner: Rosenbrock { n: 2 },
        points: Vec::new(),
    };
    let sol = solver().solve(&mut p, &rosenbrock_start(2)).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!((sol.x[0] - 1.0).abs() < 1e-5 && (sol.x[1] - 1.0).abs() < 1e-5);
    let mut near_repeats = 0;
    for (i, a) in p.points.iter().enumerate() {
        let repeats = p.points[..i].iter().any(|b| {
            a != b
                && a.iter()
                    .zip(b)
                    .all(|(u, v)| (u - v).abs() <= 1e-12 * u.abs().max(1.0))
        });
        near_repeats += usize::from(repeats);
    }
    assert_eq!(near_repeats, 0, "of {} evaluations", p.points.len());
}

/// `min x₀⁴ + x₁²  s.t.  x₀² + x₁² ≤ 4`, every evaluated point recorded.
struct QuarticInDisk {
    points: Vec<Vec<f64>>,
}

impl Problem for QuarticInDisk {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.points.push(x.to_vec());
        Ok(x[0].powi(4) + x[1] * x[1])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 4.0 * x[0].powi(3);
        g[1] = 2.0 * x[1];
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = 4.0 - x[0] * x[0] - x[1] * x[1];
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -2.0 * x[0]);
        j.set(0, 1, -2.0 * x[1]);
        Ok(())
    }
}

/// From (1, 1) the first full step (−4, −2) lands at (−3, −1): outside the disk, and with the
/// objective up from 2 to 82. A second-order correction repairs only the row's curvature (here it
/// would evaluate (−4.5, −2.5), objective 416), so it is not tried: every point the first line
/// search evaluates lies on the step's ray.
#[test]
fn no_correction_is_evaluated_when_the_objective_alone_fails_the_test() {
    let mut p = QuarticInDisk { points: Vec::new() };
    let mut first_search_end = None;
    let sol = solver()
        .solve_with_callback(&mut p, &[1.0, 1.0], |info| {
            if info.iteration == 1 {
                first_search_end = Some(info.function_evaluations);
            }
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    let end = first_search_end.expect("a second iteration");
    let trials = &p.points[1..end];
    assert!(trials.len() >= 2, "the full step is rejected: {trials:?}");
    for x in trials {
        // On the ray (1 − 4α, 1 − 2α): x₀ − 1 = 2 (x₁ − 1).
        assert!(
            (x[0] - 1.0 - 2.0 * (x[1] - 1.0)).abs() < 1e-8,
            "{x:?} off the ray"
        );
    }
}

/// Powell's example of the Maratos effect (Nocedal & Wright, Example 15.4):
/// `min 2(x₀² + x₁² − 1) − x₀  s.t.  x₀² + x₁² = 1`, with the Lagrangian's exact Hessian (the
/// identity) as the initial one; every evaluated point recorded.
struct Maratos {
    points: Vec<Vec<f64>>,
}

impl Problem for Maratos {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_equalities(&self) -> usize {
        1
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        DenseMatrix::from_row_major(2, 2, vec![1.0, 0.0, 0.0, 1.0])
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.points.push(x.to_vec());
        Ok(2.0 * (x[0] * x[0] + x[1] * x[1] - 1.0) - x[0])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 4.0 * x[0] - 1.0;
        g[1] = 4.0 * x[1];
        Ok(())
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        h[0] = x[0] * x[0] + x[1] * x[1] - 1.0;
        Ok(())
    }
    fn equality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, 2.0 * x[0]);
        j.set(0, 1, 2.0 * x[1]);
        Ok(())
    }
}

/// From a point of the circle the full step raises both the objective and the violation (the
/// Maratos effect), yet the second-order correction is tried (the model predicts it passes, as
/// the objective's rise is the row's curvature) and taken whole.
#[test]
fn the_correction_still_overcomes_the_maratos_effect() {
    let theta: f64 = 0.4;
    let mut p = Maratos { points: Vec::new() };
    let mut first = None;
    let sol = solver()
        .solve_with_callback(&mut p, &[theta.cos(), theta.sin()], |info| {
            if info.iteration == 1 {
                first = Some(info.clone());
            }
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    assert!(
        (sol.x[0] - 1.0).abs() < 1e-6 && sol.x[1].abs() < 1e-6,
        "{:?}",
        sol.x
    );
    let first = first.expect("a second iteration");
    // The start, the rejected full step, its correction.
    assert_eq!(first.function_evaluations, 3, "{:?}", p.points);
    assert_eq!(first.step_length, 1.0);
    let h = |x: &[f64]| (x[0] * x[0] + x[1] * x[1] - 1.0).abs();
    assert!(
        h(&p.points[1]) > 0.1,
        "the full step leaves the circle: {:?}",
        p.points[1]
    );
    assert!(h(&p.points[2]) < 0.1 * h(&p.points[1]), "{:?}", p.points[2]);
}
