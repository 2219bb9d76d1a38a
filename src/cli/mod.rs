//! The subcommands of `clothopt`: the argument definitions ([`Cli`], [`Command`]), one module
//! per subcommand with its `run` function, and the argument groups and loaders they share
//! ([`common`]).

mod common;
mod export;
mod fit;
mod grad;
mod optimize;
mod progress;
mod simulate;
mod summary;

use anyhow::Result;
use clap::{Parser, Subcommand};
use cloth::Scene;

/// The command line.
#[derive(Parser)]
#[command(
    name = "clothopt",
    version,
    about = "Safe, physics-aware cloth manipulation planning"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
enum Command {
    /// List the built-in scenes.
    Scenes,
    /// Simulate a control sequence and report the metrics.
    Simulate(simulate::SimulateArgs),
    /// Print L, its terms, C and their gradients with respect to the controls as one JSON object.
    Grad(grad::GradArgs),
    /// Optimize the control sequence of a scene's task.
    #[command(
        after_help = "Exit codes: 0 the task is achieved (every target within \
task.tolerance, plan safe); 1 error or bad input; 3 a safe plan was written but the task is not \
achieved (the first line says why); 4 no safe plan was found (the result is still written)."
    )]
    Optimize(optimize::OptimizeArgs),
    /// Fit material parameters (stiffness, mass, gravity, friction) to observed motion.
    #[command(
        after_help = "Exit codes: 0 the fit converged; 1 error or bad input (nothing is written); \
3 the fit stopped short of convergence (the results are still written)."
    )]
    Fit(fit::FitArgs),
    /// Export a result: dense way-points of the control points (CSV) and/or one OBJ mesh per step.
    Export(export::ExportArgs),
}

/// Runs a command; the exit code (0, or `optimize`'s verdict: see [`summary::report_verdict`]).
pub fn run(cli: Cli) -> Result<i32> {
    match cli.command {
        Command::Scenes => scenes(),
        Command::Simulate(args) => simulate::run(args),
        Command::Grad(args) => grad::run(args),
        Command::Optimize(args) => optimize::run(args),
        Command::Fit(args) => fit::run(args),
        Command::Export(args) => export::run(args),
    }
}

/// `scenes`: prints the built-in scenes' names and descriptions.
fn scenes() -> Result<i32> {
    for (name, description) in Scene::builtin_names() {
        println!("{name:<12} {description}");
    }
    Ok(0)
}
