//! What `clothopt optimize` prints when it ends: the plan's summary (`PlanResult::summary`),
//! warnings, and the exit code.

use clothopt::outcome;
use clothopt::result::PlanResult;
use std::path::Path;

/// Prints the verdict line, the run's counts, the search's candidates and the metrics
/// ([`PlanResult::summary`]).
pub fn print_summary(result: &PlanResult, no_timing: bool) {
    print!("{}", result.summary(!no_timing));
}

/// Prints the warnings and, unless the task was achieved, one line saying why (stderr); returns
/// the exit code: [`outcome::exit_code`], or 130 for an interrupted run.
pub fn report_verdict(result: &PlanResult, out: Option<&Path>) -> i32 {
    let m = &result.metrics;
    for w in &result.warnings {
        eprintln!("warning: {w}");
    }
    let code = outcome::exit_code(&result.task);
    let written = out
        .map(|p| format!("; the plan is in {}", p.display()))
        .unwrap_or_default();
    if !result.is_feasible() {
        eprintln!(
            "no safe plan: no feasible trajectory found (status {}: {}): constraint violation {:.3e} at the returned controls{written}",
            result.status,
            result.message,
            result.constraint_violation
        );
    } else if code == 4 && result.check.as_ref().is_some_and(|c| !c.last().safe) {
        eprintln!("no safe plan: {}{written}", result.task.explanation);
    } else if code == 4 && !result.safety.failures.is_empty() {
        eprintln!(
            "no safe plan: {}{written}",
            result.safety.failures.join("; ")
        );
    } else if code == 4 {
        eprintln!(
            "no safe plan: the returned plan violates the safety margin (C = {:.3e}){written}",
            m.c
        );
    } else if code == 3 {
        eprintln!("task not achieved: {}{written}", result.task.explanation);
    }
    if result.status == "interrupted" {
        eprintln!("interrupted: the best plan so far is the result");
        return 130;
    }
    code
}
