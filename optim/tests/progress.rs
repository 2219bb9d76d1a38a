//! The SQP's progress test (`SqpSettings::progress_window`, `tol_progress`) by problem class: it
//! never fires on the smooth test problems (Hock–Schittkowski, Rosenbrock), whose runs are the
//! same with it on or off, and it stops a run on a rough objective — piecewise-constant noise
//! below a quadratic whose gradient ignores the noise, as a simulator's gradient ignores a
//! change of contact set — once its steps stop paying, instead of letting it creep on; and it
//! ends a run of whole but tiny steps at points that meet the problem's goal
//! (`Problem::goal_reached`), never elsewhere.

mod rough;

use optim::test_problems::{hock_schittkowski, rosenbrock_start, Rosenbrock};
use optim::{DenseMatrix, EvalError, Problem, Solution, SqpSettings, SqpSolver, Status};
use rough::{RoughEquality, RoughRosenbrock};

fn solve<P: Problem>(p: &mut P, x0: &[f64], window: Option<usize>) -> Solution {
    let settings = SqpSettings::builder()
        .progress_window(window)
        .build()
        .expect("valid settings");
    SqpSolver::new(settings).unwrap().solve(p, x0).unwrap()
}

/// The run with the test on (the default) is the run with it off, bit for bit.
fn same_run(on: &Solution, off: &Solution) -> bool {
    on.status == off.status
        && on.x == off.x
        && on.iterations == off.iterations
        && on.function_evaluations == off.function_evaluations
}

#[test]
fn never_fires_on_the_smooth_test_problems() {
    assert_eq!(SqpSettings::default().progress_window, Some(10));
    for mut p in hock_schittkowski() {
        let x0 = p.x0.clone();
        let on = solve(&mut p, &x0, Some(10));
        let off = solve(&mut p, &x0, None);
        assert!(same_run(&on, &off), "{}: {}", p.name, on.message);
        // Not even a window of one iteration stops them.
        let one = solve(&mut p, &x0, Some(1));
        assert!(same_run(&one, &off), "{}: {}", p.name, one.message);
        assert_eq!(on.status, Status::Converged, "{}", p.name);
    }
    for n in [2, 10, 100] {
        let x0 = rosenbrock_start(n);
        let on = solve(&mut Rosenbrock { n }, &x0, Some(1));
        let off = solve(&mut Rosenbrock { n }, &x0, None);
        assert!(same_run(&on, &off), "Rosenbrock {n}: {}", on.message);
    }
}

/// `on` took less than `1/factor` of `off`'s evaluations.
fn assert_fewer_evaluations(on: &Solution, off: &Solution, factor: usize) {
    assert!(
        factor * on.function_evaluations < off.function_evaluations,
        "{} vs {} evaluations",
        on.function_evaluations,
        off.function_evaluations
    );
}

/// The rough Rosenbrock problem with the test on and off: (on, off).
fn rough_runs(constrained: bool) -> (Solution, Solution) {
    let mut p = RoughRosenbrock {
        n: 2,
        eps: 1e-4,
        h: 1e-8,
        constrained,
    };
    let x0 = rosenbrock_start(2);
    (solve(&mut p, &x0, Some(10)), solve(&mut p, &x0, None))
}

#[test]
fn stops_a_run_on_a_rough_objective_once_its_steps_stop_paying() {
    // Without the test the run creeps on: 200 iterations, 1456 evaluations.
    let (on, off) = rough_runs(false);
    assert_eq!(off.status, Status::IterationLimit, "{}", off.message);
    assert_eq!(on.status, Status::NoProgress, "{}", on.message);
    assert!(
        on.message.starts_with("no progress: the objective fell by"),
        "{}",
        on.message
    );
    assert!(
        on.message.contains("over the last 10 iterations"),
        "{}",
        on.message
    );
    // It stopped at the noise level (ε = 1e-4 around f* = 0), as good as the long run…
    assert!(on.objective.abs() <= 2e-4, "{}", on.objective);
    assert!(on.objective <= off.objective + 2e-4);
    // …for a small part of its evaluations (114 against 1456).
    assert_fewer_evaluations(&on, &off, 5);
}

#[test]
fn stops_a_constrained_rough_run_at_a_feasible_point() {
    // Without the test: 80 iterations, 540 evaluations, then the line search fails.
    let (on, off) = rough_runs(true);
    assert_eq!(on.status, Status::NoProgress, "{}", on.message);
    assert!(on.message.starts_with("no progress"), "{}", on.message);
    assert!(
        on.constraint_violation <= 1e-8,
        "{}",
        on.constraint_violation
    );
    // f* = 0.25 at x = (0.5, 0.25), x₀ ≤ 0.5 active.
    assert!((on.objective - 0.25).abs() <= 2e-4, "{}", on.objective);
    assert!(
        (on.x[0] - 0.5).abs() <= 1e-3 && (on.x[1] - 0.25).abs() <= 1e-2,
        "{:?}",
        on.x
    );
    assert_fewer_evaluations(&on, &off, 3);
}

#[test]
fn the_same_problem_without_noise_converges_either_way() {
    for constrained in [false, true] {
        let mut p = RoughRosenbrock {
            n: 2,
            eps: 0.0,
            h: 1e-8,
            constrained,
        };
        let x0 = rosenbrock_start(2);
        let (on, off) = (solve(&mut p, &x0, Some(10)), solve(&mut p, &x0, None));
        assert_eq!(on.status, Status::Converged, "{}", on.message);
        assert!(same_run(&on, &off));
    }
}

#[test]
fn stops_a_run_whose_violation_is_stuck_at_the_noise_level() {
    let rough = |eps| {
        RoughEquality(RoughRosenbrock {
            n: 2,
            eps,
            h: 1e-8,
            constrained: false,
        })
    };
    let x0 = rosenbrock_start(2);
    let on = solve(&mut rough(1e-4), &x0, Some(10));
    let off = solve(&mut rough(1e-4), &x0, None);
    assert_eq!(on.status, Status::NoProgress, "{}", on.message);
    assert!(on.message.contains("the violation from"), "{}", on.message);
    // Stopped at the noise level: violation and objective as near the optimum (0.5, 0.25) as
    // the long run's, for a part of its evaluations.
    assert!(
        on.constraint_violation <= 3e-4,
        "{}",
        on.constraint_violation
    );
    assert!((on.objective - 0.25).abs() <= 1e-3, "{}", on.objective);
    assert_eq!(off.status, Status::Stalled, "{}", off.message);
    // 30 iterations and 195 evaluations (the violation 8.7e-6 throughout its last 10) against
    // 47 and 412, where the line search fails even after a Hessian reset (each run with one
    // feasibility correction tried at its end, which the noise defeats).
    assert_fewer_evaluations(&on, &off, 2);
    // Without noise: converged, the same run with the test on or off.
    let (on, off) = (
        solve(&mut rough(0.0), &x0, Some(10)),
        solve(&mut rough(0.0), &x0, None),
    );
    assert_eq!(on.status, Status::Converged, "{}", on.message);
    assert!(same_run(&on, &off));
}

/// `½‖x − p‖²` whose initial Hessian is `stiffness` times the true one: the SQP's steps are
/// whole but tiny, and its KKT residual stays, until damped BFGS has unlearnt the stiffness
/// (at most five-fold an iteration). Its goal: `x` within `radius` of `p`.
struct StiffStart {
    p: Vec<f64>,
    stiffness: f64,
    radius: Option<f64>,
}

impl StiffStart {
    fn distance(&self, x: &[f64]) -> f64 {
        x.iter()
            .zip(&self.p)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    }
}

impl Problem for StiffStart {
    fn num_variables(&self) -> usize {
        self.p.len()
    }
    fn initial_hessian(&self) -> Option<DenseMatrix> {
        let n = self.p.len();
        let data = (0..n * n)
            .map(|k| {
                if k % (n + 1) == 0 {
                    self.stiffness
                } else {
                    0.0
                }
            })
            .collect();
        DenseMatrix::from_row_major(n, n, data)
    }
    fn goal_reached(&mut self, x: &[f64]) -> bool {
        self.radius.is_some_and(|r| self.distance(x) <= r)
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(0.5 * self.distance(x).powi(2))
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        for ((gi, xi), pi) in g.iter_mut().zip(x).zip(&self.p) {
            *gi = xi - pi;
        }
        Ok(())
    }
}

#[test]
fn ends_whole_tiny_steps_only_where_the_goal_is_met() {
    let stiff = |radius| StiffStart {
        p: vec![1.0, -2.0, 0.5],
        stiffness: 1e8,
        radius,
    };
    let x0 = [1.1, -2.1, 0.4];
    // The planner's tolerance: the crawl's first 10 steps lower f by 7e-4 of its 0.015.
    let solve = |p: &mut StiffStart, window| {
        let settings = SqpSettings::builder()
            .progress_window(window)
            .tol_progress(1e-3)
            .build()
            .expect("valid settings");
        SqpSolver::new(settings).unwrap().solve(p, &x0).unwrap()
    };
    // No goal: the run unlearns the stiffness, five-fold an iteration, and converges (13
    // iterations).
    let free = solve(&mut stiff(None), Some(10));
    assert_eq!(free.status, Status::Converged, "{}", free.message);
    // A goal the crawl never meets (x₀ is 0.17 from p): the same run, bit for bit.
    let unmet = solve(&mut stiff(Some(0.1)), Some(10));
    assert!(same_run(&unmet, &free), "{}", unmet.message);
    // A goal met from the start: the crawl ends after one window of whole steps.
    let met = solve(&mut stiff(Some(0.5)), Some(10));
    assert_eq!(met.status, Status::NoProgress, "{}", met.message);
    assert!(
        met.message.contains("whole steps among them"),
        "{}",
        met.message
    );
    assert_eq!(met.iterations, 10, "{}", met.message);
    assert!(met.iterations < free.iterations);
    assert!(stiff(None).distance(&met.x) <= 0.5);
    // With the test off it runs as without a goal.
    let off = solve(&mut stiff(Some(0.5)), None);
    assert!(same_run(&off, &free), "{}", off.message);
}
