//! What `clothopt optimize` prints when it ends: the verdict line, the summary table, the route
//! search's candidates, warnings, and the exit code.

use clothopt::outcome;
use clothopt::plan::PlanResult;
use std::path::Path;

/// Prints the verdict line, the run's counts, the search's candidates and the metrics.
pub fn print_summary(result: &PlanResult, no_timing: bool) {
    let m = &result.metrics;
    let verdict = if result.task.achieved {
        "task achieved".to_string()
    } else {
        format!("task NOT achieved ({:?})", result.task.reason)
    };
    println!("{verdict}: {}", result.task.explanation);
    println!(
        "scene {}  δ = {}  status {}  ({})",
        result.scene, result.delta, result.status, result.message
    );
    let wall = if no_timing {
        String::new()
    } else {
        format!("  wall {:.2} s", result.wall_s)
    };
    let per_stage = result
        .stages
        .iter()
        .map(|s| match s.kappa {
            Some(k) => format!("κ = {k}: {} {}", s.iterations, s.status),
            None => format!("{} {}", s.iterations, s.status),
        })
        .collect::<Vec<_>>()
        .join(", ");
    println!(
        "iterations {} ({per_stage})  simulations {}  gradients {}{wall}",
        result.iterations, result.evaluations, result.gradient_evaluations
    );
    if let Some(search) = &result.search {
        println!(
            "route search ({} stages after the first plan, {} simulations in all):",
            search.candidates.len() - 1,
            search.simulations
        );
        for c in &search.candidates {
            println!(
                "  {} {:<9} {:<16} safe {:<5} achieved {:<5} L {:>10.5} G {:>9.5}  {}",
                if c.kept { "*" } else { " " },
                c.stage,
                c.status,
                c.safe,
                c.achieved,
                c.l,
                c.g,
                c.route
            );
        }
    }
    println!("{:>10} {:>12}", "metric", "value");
    for (k, v) in [
        ("G", m.g),
        ("αT", m.alpha_t),
        ("βE", m.beta_e),
        ("L", m.l),
        ("C", m.c),
        ("min SDF", m.min_sdf),
        ("swept SDF", m.min_sdf_swept),
        ("max strain", result.strain.max),
    ] {
        println!("{k:>10} {v:>12.6}");
    }
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
