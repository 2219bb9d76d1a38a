//! Read a result: what a plan's JSON file says and how to use it from Rust.
//!
//! `cargo run --release --example read_result -- r.json`
//!
//! `r.json` is written by `clothopt optimize SCENE --out r.json` (or the `plan_from_code`
//! example). Every field is documented on [`clothopt::result::PlanResult`].

use anyhow::{Context, Result};
use clothopt::result::{self, PlanResult};

fn main() -> Result<()> {
    let path = std::env::args_os().nth(1).context(
        "usage: read_result RESULT.json (from `clothopt optimize SCENE --out RESULT.json`)",
    )?;
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.to_string_lossy()))?;
    let result: PlanResult = serde_json::from_str(&text).context("not a plan result")?;

    // The verdict: the solver's status, whether the plan may be executed, whether it did the task.
    println!(
        "scene {}: {} — {}",
        result.scene, result.status, result.message
    );
    println!(
        "feasible: {}, safe at δ = {}: {}, task achieved: {} ({:?})",
        result.is_feasible(),
        result.delta,
        result.is_safe(),
        result.task.achieved,
        result.task.reason
    );
    for warning in &result.warnings {
        println!("warning: {warning}");
    }

    // The plan: one displacement per gripper and step, and where the grippers are at each step.
    let (steps, grippers) = (result.controls.len(), result.control_particles.len());
    println!("{steps} steps × {grippers} grippers; gripper paths:");
    for (g, particle) in result.control_particles.iter().enumerate() {
        let path: Vec<[f64; 3]> = result.gripper_positions.iter().map(|p| p[g]).collect();
        let length: f64 = path.windows(2).map(|w| dist(&w[0], &w[1])).sum();
        let (a, b) = (path[0], path[path.len() - 1]);
        println!(
            "  particle {particle}: ({:.2}, {:.2}, {:.2}) → ({:.2}, {:.2}, {:.2}), length {length:.3}",
            a[0], a[1], a[2], b[0], b[1], b[2]
        );
    }

    // The rollout, when the file holds it (the experiments drop it to keep their files small).
    match result.states {
        Some(_) => {
            let states = result::states_of(&result)?;
            let last = &states[states.len() - 1];
            let lowest = (0..last.rows())
                .map(|p| last.get(p, 2))
                .fold(f64::INFINITY, f64::min);
            println!(
                "{} states of {} particles; lowest final z {lowest:.3}",
                states.len(),
                last.rows()
            );
        }
        None => println!("no states in this file"),
    }
    Ok(())
}

/// Euclidean distance of two points.
fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
