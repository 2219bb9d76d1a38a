//! Feasibility restoration at a run's end (`SqpSettings::restoration_steps`), by problem class:
//! a run on a rough objective that stops just outside an exact (linear) row ends on the row; a
//! row whose own noise no correction can remove is left as it was; smooth problems never reach it.

mod rough;

use optim::test_problems::{hock_schittkowski, rosenbrock_start};
use optim::{EvalError, Jacobian, Problem, Solution, SqpSettings, SqpSolver, Status};
use rough::{RoughEquality, RoughRosenbrock};

fn solve<P: Problem>(p: &mut P, x0: &[f64], restoration_steps: usize) -> Solution {
    let settings = SqpSettings::builder()
        .restoration_steps(restoration_steps)
        .build()
        .expect("valid settings");
    SqpSolver::new(settings).unwrap().solve(p, x0).unwrap()
}

/// The rough Rosenbrock function in two variables (its noise ignored by the gradient) plus a
/// hidden slope `−s·x₀` the gradient ignores too, subject to the linear rows `x₀ + x₁ ≤ b` and
/// `x₀ ≤ a`.
struct RoughLinear {
    rough: RoughRosenbrock,
    a: f64,
    b: f64,
    s: f64,
}

impl Problem for RoughLinear {
    fn num_variables(&self) -> usize {
        2
    }
    fn num_inequalities(&self) -> usize {
        2
    }
    fn objective(&mut self, x: &[f64]) -> Result<f64, EvalError> {
        Ok(self.rough.objective(x)? - self.s * x[0])
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) -> Result<(), EvalError> {
        self.rough.gradient(x, g)
    }
    fn inequalities(&mut self, x: &[f64], c: &mut [f64]) -> Result<(), EvalError> {
        c[0] = self.b - x[0] - x[1];
        c[1] = self.a - x[0];
        Ok(())
    }
    fn inequality_jacobian(&mut self, _x: &[f64], j: &mut Jacobian) -> Result<(), EvalError> {
        j.set(0, 0, -1.0);
        j.set(0, 1, -1.0);
        j.set(1, 0, -1.0);
        Ok(())
    }
}

/// A run and its counterpart without restoration are the same run, bit for bit.
fn same_run(a: &Solution, b: &Solution) -> bool {
    a.status == b.status
        && a.x == b.x
        && a.iterations == b.iterations
        && a.function_evaluations == b.function_evaluations
        && a.message == b.message
}

#[test]
fn a_run_stalled_outside_an_exact_row_ends_on_it() {
    // The hidden slope (an inexact gradient, as a simulator's) raises the objective along every
    // step towards x₀ ≤ 0.5 by more than the merit's penalty weight lowers the violation: the
    // line search rejects them all, and the run stalls 0.26 outside the rows.
    let rough = || RoughLinear {
        rough: RoughRosenbrock {
            n: 2,
            eps: 0.0,
            h: 1e-9,
            constrained: false,
        },
        a: 0.5,
        b: 0.7,
        s: 100.0,
    };
    let x0 = [0.6, 0.36];
    let off = solve(&mut rough(), &x0, 0);
    assert_eq!(off.status, Status::Stalled, "{}", off.message);
    assert!(
        off.constraint_violation > 0.2,
        "{}",
        off.constraint_violation
    );
    let on = solve(&mut rough(), &x0, 3);
    // One correction puts it on the rows; the status and the stall's message stay, the
    // correction is said, with the objective it costs.
    assert_eq!(on.status, Status::Stalled, "{}", on.message);
    assert!(
        on.constraint_violation <= 1e-8,
        "{}",
        on.constraint_violation
    );
    assert!(
        on.message.starts_with(&off.message)
            && on.message.contains("a feasibility correction (1 step"),
        "{}",
        on.message
    );
    let (mut c, mut p) = ([0.0; 2], rough());
    p.inequalities(&on.x, &mut c).unwrap();
    assert!(c.iter().all(|&v| v >= -1e-8), "{c:?}");
    assert_eq!(on.objective, p.objective(&on.x).unwrap());
    assert!(on.objective > off.objective);
    assert!(on.kkt_residual.is_nan());
    assert_eq!(on.function_evaluations, off.function_evaluations + 1);
}

#[test]
fn a_row_whose_own_noise_no_correction_removes_is_left_as_it_was() {
    let rough = || {
        RoughEquality(RoughRosenbrock {
            n: 2,
            eps: 1e-4,
            h: 1e-8,
            constrained: false,
        })
    };
    let x0 = rosenbrock_start(2);
    let (off, on) = (solve(&mut rough(), &x0, 0), solve(&mut rough(), &x0, 3));
    assert_eq!(on.status, Status::NoProgress, "{}", on.message);
    assert!(
        on.constraint_violation > 1e-8,
        "{}",
        on.constraint_violation
    );
    // Its point, violation and message are the run's own; the corrections tried cost evaluations.
    assert_eq!((on.x.clone(), on.message.clone()), (off.x, off.message));
    assert_eq!(on.constraint_violation, off.constraint_violation);
    assert!(on.function_evaluations > off.function_evaluations);
}

#[test]
fn runs_that_converge_never_reach_it() {
    for mut p in hock_schittkowski() {
        let x0 = p.x0.clone();
        let (off, on) = (solve(&mut p, &x0, 0), solve(&mut p, &x0, 3));
        assert_eq!(on.status, Status::Converged, "{}", p.name);
        assert!(same_run(&on, &off), "{}: {}", p.name, on.message);
    }
    assert_eq!(SqpSettings::default().restoration_steps, 3);
}
