use optim::test_problems::hock_schittkowski;
use optim::{ControlFlow, SqpSettings, SqpSolver};
fn main() {
    let name = std::env::args().nth(1).unwrap_or("HS106".into());
    let mut p = hock_schittkowski()
        .into_iter()
        .find(|p| p.name == name)
        .unwrap();
    let x0 = p.x0.clone();
    let solver = SqpSolver::new(SqpSettings::default()).unwrap();
    let sol = solver.solve_with_callback(&mut p, &x0, |i| {
        println!("{:4} f={:.10e} viol={:.2e} kkt={:.2e} step={:.2e} a={:.2e} nu={:.1e} lv={:.2e} fe={}", i.iteration, i.objective, i.constraint_violation, i.kkt_residual, i.step_norm, i.step_length, i.penalty, i.linearized_violation, i.function_evaluations);
        ControlFlow::Continue(())
    }).unwrap();
    println!(
        "{:?} {} x={:?} mult={:?}",
        sol.status, sol.message, sol.x, sol.multipliers.inequality
    );
}
