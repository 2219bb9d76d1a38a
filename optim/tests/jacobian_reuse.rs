//! `SqpSettings::jacobian_reuse_margin`: far-from-active inequality rows keep their previous
//! Jacobian rows; the solutions and verdicts stay those of the plain SQP.

use optim::test_problems::{hock_schittkowski, TwoDisks};
use optim::{EvalError, Jacobian, Problem, SqpSettings, SqpSolver, Status};

fn solver(margin: Option<f64>) -> SqpSolver {
    SqpSolver::new(
        SqpSettings::builder()
            .jacobian_reuse_margin(margin)
            .build()
            .expect("valid settings"),
    )
    .expect("valid settings")
}

/// Wraps a problem and records every Jacobian evaluation: the point and which rows were asked for.
struct Recorded<P> {
    problem: P,
    calls: Vec<(Vec<f64>, Vec<bool>)>,
}

impl<P> Recorded<P> {
    fn new(problem: P) -> Self {
        Recorded {
            problem,
            calls: Vec::new(),
        }
    }

    /// How many times row `i` was evaluated.
    fn evaluations_of(&self, i: usize) -> usize {
        self.calls.iter().filter(|(_, w)| w[i]).count()
    }

    /// Rows asked to be skipped, over all calls.
    fn kept(&self) -> usize {
        self.calls
            .iter()
            .map(|(_, w)| w.iter().filter(|&&w| !w).count())
            .sum()
    }

    /// Calls that repeat the previous call's point with every row wanted after some were kept
    /// there: the solver re-evaluated kept rows.
    fn refreshes(&self) -> usize {
        self.calls
            .windows(2)
            .filter(|w| w[0].0 == w[1].0 && w[0].1.contains(&false) && !w[1].1.contains(&false))
            .count()
    }
}

impl<P: Problem> Problem for Recorded<P> {
    fn num_variables(&self) -> usize {
        self.problem.num_variables()
    }
    fn num_inequalities(&self) -> usize {
        self.problem.num_inequalities()
    }
    fn num_equalities(&self) -> usize {
        self.problem.num_equalities()
    }
    fn bounds(&self) -> Option<optim::Bounds> {
        self.problem.bounds()
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        self.problem.objective(x)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.problem.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        self.problem.inequalities(x, c)
    }
    fn inequality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        let m = self.problem.num_inequalities();
        self.calls.push((x.to_vec(), vec![true; m]));
        self.problem.inequality_jacobian(x, jac)
    }
    fn inequality_jacobian_rows(
        &mut self,
        x: &[f64],
        wanted: &[bool],
        jac: &mut Jacobian,
    ) -> Result<(), EvalError> {
        self.calls.push((x.to_vec(), wanted.to_vec()));
        // Every row is filled: the solver must overwrite the unwanted ones with its kept values.
        self.problem.inequality_jacobian(x, jac)
    }
    fn equalities(&mut self, x: &[f64], h: &mut [f64]) -> Result<(), EvalError> {
        self.problem.equalities(x, h)
    }
    fn equality_jacobian(&mut self, x: &[f64], jac: &mut Jacobian) -> Result<(), EvalError> {
        self.problem.equality_jacobian(x, jac)
    }
}

#[test]
fn hock_schittkowski_problems_reach_the_same_optimum_with_reuse() {
    let mut kept = 0;
    for margin in [0.1, 1.0] {
        for p in hock_schittkowski() {
            let (name, x0) = (p.name, p.x0.clone());
            let plain = solver(None).solve(&mut p.clone(), &x0).unwrap();
            let mut p = Recorded::new(p);
            let sol = solver(Some(margin)).solve(&mut p, &x0).unwrap();
            assert_eq!(sol.status, Status::Converged, "{name}: {}", sol.message);
            assert!(
                p.problem.error(sol.objective) <= 1e-6,
                "{name} (margin {margin}): objective {} vs published {}",
                sol.objective,
                p.problem.f_star
            );
            assert!(sol.kkt_residual <= 1e-6 && sol.constraint_violation <= 1e-8);
            let dx = sol.x.iter().zip(&plain.x).map(|(a, b)| (a - b).abs());
            assert!(
                dx.fold(0.0, f64::max)
                    <= 1e-4 * (1.0 + plain.x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))),
                "{name}: {:?} vs {:?}",
                sol.x,
                plain.x
            );
            kept += p.kept();
        }
    }
    // Not vacuous: rows were kept.
    assert!(kept > 0);
}

/// `min (x₀ − 2)² + (x₁ − 1)²  s.t.  1 − ‖x‖² ≥ 0` (active at the solution `(2, 1)/√5`),
/// `9 − (x₀ − 1)² − (x₁ + 1)² ≥ 0` and `x₀ + 5 ≥ 0` (both far from active throughout).
struct DiskWithFarRows;

impl Problem for DiskWithFarRows {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        3
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok((x[0] - 2.0).powi(2) + (x[1] - 1.0).powi(2))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 2.0);
        g[1] = 2.0 * (x[1] - 1.0);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = 1.0 - x[0] * x[0] - x[1] * x[1];
        c[1] = 9.0 - (x[0] - 1.0).powi(2) - (x[1] + 1.0).powi(2);
        c[2] = x[0] + 5.0;
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -2.0 * x[0]);
        j.set(0, 1, -2.0 * x[1]);
        j.set(1, 0, -2.0 * (x[0] - 1.0));
        j.set(1, 1, -2.0 * (x[1] + 1.0));
        j.set(2, 0, 1.0);
        Ok(())
    }
}

#[test]
fn far_rows_are_evaluated_less_and_the_solution_is_unchanged() {
    let mut plain = Recorded::new(DiskWithFarRows);
    let a = solver(None).solve(&mut plain, &[0.0, 0.0]).unwrap();
    let mut reuse = Recorded::new(DiskWithFarRows);
    let b = solver(Some(0.5)).solve(&mut reuse, &[0.0, 0.0]).unwrap();
    assert_eq!(a.status, Status::Converged, "{}", a.message);
    assert_eq!(b.status, Status::Converged, "{}", b.message);
    let s = 1.0 / 5f64.sqrt();
    for x in [&a.x, &b.x] {
        assert!(
            (x[0] - 2.0 * s).abs() < 1e-7 && (x[1] - s).abs() < 1e-7,
            "{x:?}"
        );
    }
    // The far linear row only at the start (it predicts its change exactly), the far quadratic row
    // only where it did not predict its change to 10%, the near-active row once within the margin.
    assert!(plain.calls.len() > 3, "{} evaluations", plain.calls.len());
    assert_eq!(reuse.evaluations_of(2), 1, "{:?}", reuse.calls);
    assert!(
        reuse.evaluations_of(1) < plain.calls.len(),
        "{:?}",
        reuse.calls
    );
    assert!(
        reuse.evaluations_of(1) > 1,
        "{:?} vs {}",
        reuse.calls,
        plain.calls.len()
    );
    assert!(reuse.calls.last().expect("evaluated").1[0]);
    // Kept rows are inactive: their multipliers are zero to the QP's accuracy.
    assert!(b.multipliers.inequality[0] > 0.1, "{:?}", b.multipliers);
    assert!(b.multipliers.inequality[1..].iter().all(|l| l.abs() < 1e-6));
}

/// `min (x − 5)²  s.t.  4 − x − max(0, x − 1.5)² ≥ 0` (solution at the root, x = 1.5 + (√11 − 1)/2): linear up
/// to x = 1.5, so a row kept there predicted its change exactly, yet the next QP step, taken along
/// the kept row, brings its linearization below half the margin: it must be evaluated first.
struct BendsAhead;

impl Problem for BendsAhead {
    fn num_variables(&self) -> usize {
        1
    }
    fn num_inequalities(&self) -> usize {
        1
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok((x[0] - 5.0).powi(2))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        g[0] = 2.0 * (x[0] - 5.0);
        Ok(())
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = 4.0 - x[0] - (x[0] - 1.5).max(0.0).powi(2);
        Ok(())
    }
    fn inequality_jacobian(&mut self, x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -1.0 - 2.0 * (x[0] - 1.5).max(0.0));
        Ok(())
    }
}

#[test]
fn kept_row_a_step_approaches_is_evaluated_before_the_step() {
    let mut p = Recorded::new(BendsAhead);
    let sol = solver(Some(1.0)).solve(&mut p, &[0.0]).unwrap();
    assert_eq!(sol.status, Status::Converged, "{}", sol.message);
    let root = 1.5 + (11f64.sqrt() - 1.0) / 2.0;
    assert!((sol.x[0] - root).abs() < 1e-8, "{:?} vs {root}", sol.x);
    assert!(p.kept() > 0, "{:?}", p.calls);
    assert!(p.refreshes() > 0, "{:?}", p.calls);
}

/// The locally infeasible problem of `sqp.rs` (two disjoint disks) with a third, far-from-active row
/// `100 − ‖x‖² ≥ 0`, kept while the violation is reduced: the verdict is given on freshly evaluated
/// rows, and it is the plain SQP's verdict.
#[test]
fn infeasible_verdict_is_the_same_with_reuse() {
    let disks = || TwoDisks {
        far_disk: Some(100.0),
    };
    for start in [[0.2, 0.7], [0.0, 0.0], [3.0, 0.1]] {
        let plain = solver(None).solve(&mut disks(), &start).unwrap();
        let mut p = Recorded::new(disks());
        let sol = solver(Some(1.0)).solve(&mut p, &start).unwrap();
        match (sol.status, plain.status) {
            (
                Status::Infeasible { best_violation: a },
                Status::Infeasible { best_violation: b },
            ) => {
                assert!((a - b).abs() < 1e-6, "{start:?}: {a} vs {b}")
            }
            other => panic!("{start:?}: {other:?}: {}", sol.message),
        }
        assert!(p.kept() > 0, "{start:?}");
        let last = p.calls.last().expect("evaluated");
        assert!(!last.1.contains(&false), "{start:?}: verdict on kept rows");
        assert!((sol.x[0] - 1.5).abs() < 1e-3 && sol.x[1].abs() < 1e-3);
    }
}

#[test]
fn reuse_margin_is_validated() {
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(
            SqpSettings::builder()
                .jacobian_reuse_margin(Some(bad))
                .build()
                .is_err(),
            "{bad}"
        );
    }
}
