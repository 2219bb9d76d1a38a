//! The SQP's progress test (`SqpSettings::progress_window`, `tol_progress`) by problem class: it
//! never fires on the smooth test problems (Hock–Schittkowski, Rosenbrock), whose runs are the
//! same with it on or off, and it stops a run on a rough objective — piecewise-constant noise
//! below a quadratic whose gradient ignores the noise, as a simulator's gradient ignores a
//! change of contact set — once its steps stop paying, instead of letting it creep on.

use optim::test_problems::{hock_schittkowski, rosenbrock_start, Rosenbrock};
use optim::{EvalError, Jacobian, Problem, Solution, SqpSettings, SqpSolver, Status};

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

/// The Rosenbrock function in `n` variables plus `ε·noise(x)`, optionally with `x₀ ≤ 0.5`
/// (active at the optimum): `noise` is constant on cells of width `h` and hashes each cell to
/// `[−1, 1]`; the gradient is Rosenbrock's alone.
struct RoughRosenbrock {
    n: usize,
    eps: f64,
    h: f64,
    constrained: bool,
}

impl RoughRosenbrock {
    fn noise(&self, x: &[f64]) -> f64 {
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
    // Without the test: 80 iterations, 605 evaluations, then the line search fails.
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

/// A rough equality: `x₀ − 0.5 + ε·noise(x) = 0` under the Rosenbrock objective, the noise (of
/// the objective too) ignored by the derivatives. Once the violation is at the noise level no
/// step the line search tries lowers it, and the iterates stay infeasible.
struct RoughEquality(RoughRosenbrock);

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
    // 30 iterations and 194 evaluations (the violation 8.7e-6 throughout its last 10) against
    // 47 and 411, where the line search fails even after a Hessian reset.
    assert_fewer_evaluations(&on, &off, 2);
    // Without noise: converged, the same run with the test on or off.
    let (on, off) = (
        solve(&mut rough(0.0), &x0, Some(10)),
        solve(&mut rough(0.0), &x0, None),
    );
    assert_eq!(on.status, Status::Converged, "{}", on.message);
    assert!(same_run(&on, &off));
}
