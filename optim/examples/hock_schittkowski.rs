//! Runs the SQP on the Hock–Schittkowski selection from the published starting points and prints a
//! table. Exits with status 1 if any problem misses its published optimum (relative error > 1e-6) or
//! does not report `converged`.
//!
//! ```sh
//! cargo run --release -p optim --example hock_schittkowski
//! ```

use optim::test_problems::{hock_schittkowski, TestProblem};
use optim::{SqpSettings, SqpSolver, Status};
use std::process::ExitCode;

fn main() -> ExitCode {
    let solver = match SqpSolver::new(SqpSettings::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let misses = run_table(&solver, hock_schittkowski());
    if misses.is_empty() {
        println!("\nall problems reached their published optimum (relative error ≤ 1e-6)");
        ExitCode::SUCCESS
    } else {
        println!("\nmissed: {}", misses.join(", "));
        ExitCode::FAILURE
    }
}

/// Runs each problem, prints one table row per problem, returns the names that missed.
fn run_table(solver: &SqpSolver, problems: Vec<TestProblem>) -> Vec<&'static str> {
    println!(
        "| problem | n | m | status | iterations | f-evals | g-evals | objective | published | rel. error | KKT | violation |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut misses = Vec::new();
    for mut p in problems {
        let x0 = p.x0.clone();
        let sol = match solver.solve(&mut p, &x0) {
            Ok(sol) => sol,
            Err(e) => {
                println!("| {} | error: {e} |", p.name);
                misses.push(p.name);
                continue;
            }
        };
        let err = p.error(sol.objective);
        let ok = sol.status == Status::Converged && err <= 1e-6;
        if !ok {
            misses.push(p.name);
        }
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.10} | {:.10} | {:.1e} | {:.1e} | {:.1e} |{}",
            p.name,
            p.n,
            p.m + p.q,
            sol.status,
            sol.iterations,
            sol.function_evaluations,
            sol.gradient_evaluations,
            sol.objective,
            p.f_star,
            err,
            sol.kkt_residual,
            sol.constraint_violation,
            if ok { "" } else { " MISS" }
        );
    }
    misses
}
