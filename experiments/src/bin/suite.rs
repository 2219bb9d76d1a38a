//! The task suite: every scene of a set (default `examples/scenes/tasks/`) planned by `clothopt
//! optimize` under the physics it calls for (and, with `--physics`, under each solver named),
//! each plan then simulated again to convergence (Newton at its default tolerance) to see whether
//! its verdict holds there.
//!
//! ```sh
//! cargo build --release --bin clothopt && cargo build --release -p experiments --bin suite
//! target/release/suite --time-limit 120 --out suite.json --results-dir results
//! target/release/suite --dir examples/scenes/rule --physics xpbd,newton   # the physics rule
//! ```
//!
//! A row: the physics that ran and why, the verdict, the largest target error, the benchmarks'
//! measures (normalized coverage, mean particle distance), the counts (SQP iterations,
//! simulations), the child's wall time, how far the plan's states are from equilibrium, and the
//! converged re-simulation's largest target error and verdict (targets within tolerance, margin
//! kept, nothing inside a collider); with `--branch-check`, the same under branch following
//! (`optimize --check newton-branch`'s physics: whether the plan's end depends on which of a
//! step's equilibria one solve lands in). A solver the simulator rejects for a scene is a row
//! `unsupported: <its error>`; a plan whose child fails is a row `error: <its error>`.

use anyhow::{Context, Result};
use clap::{Parser, ValueEnum};
use cloth::scene::SolverKind;
use cloth::{Model, Scene};
use clothopt::outcome::target_errors;
use clothopt::result::{controls_from_nested, is_safe, CheckPhysics, PlanResult, BRANCH_HALVINGS};
use experiments::plan_set::{self, PlanFlags, PlanSet};
use experiments::report::fmt_opt;
use experiments::scene_set::SceneFile;
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(about = "The task suite: every scene planned, then simulated to convergence")]
struct Cli {
    /// Only these scenes (names as in the scene files; default every scene of `--dir`).
    scenes: Vec<String>,
    /// Directory of scene files.
    #[arg(long, default_value = "examples/scenes/tasks")]
    dir: PathBuf,
    /// The physics of each plan, comma-separated: `scene` (what the scene calls for), `xpbd`,
    /// `newton` (set as `physics.solver`).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Physics::Scene])]
    physics: Vec<Physics>,
    /// Seconds each plan may take (`optimize --time-limit`).
    #[arg(long, default_value_t = 120.0, allow_negative_numbers = true)]
    time_limit: f64,
    /// Also re-simulate each plan with branch following (`--check newton-branch`) and report
    /// its largest target error and verdict (costs up to 70 rollouts a plan).
    #[arg(long)]
    branch_check: bool,
    #[command(flatten)]
    flags: PlanFlags,
}

/// The physics a row plans on.
#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
enum Physics {
    /// The scene as written: the solver it names, or the one it calls for.
    Scene,
    /// `physics.solver` `"xpbd"`.
    Xpbd,
    /// `physics.solver` `"newton"`.
    Newton,
}

impl Physics {
    fn name(self) -> &'static str {
        match self {
            Physics::Scene => "scene",
            Physics::Xpbd => "xpbd",
            Physics::Newton => "newton",
        }
    }

    fn solver(self) -> Option<SolverKind> {
        match self {
            Physics::Scene => None,
            Physics::Xpbd => Some(SolverKind::Xpbd),
            Physics::Newton => Some(SolverKind::Newton),
        }
    }
}

/// One plan's physics, verdict, measures and costs, and its converged re-simulation.
#[derive(Serialize)]
struct Plan {
    /// The physics that ran (`newton (smooth contact)`, `xpbd, 100 sweeps per step`).
    physics: String,
    /// Why (the result's `physics.reason`).
    reason: String,
    achieved: bool,
    /// The verdict's reason (`achieved`, `stalled`, `no_safe_plan`, …).
    verdict: String,
    max_target_error: f64,
    targets_reached: usize,
    targets: usize,
    tolerance: f64,
    /// Normalized coverage of the final state (`measures.coverage`).
    coverage: Option<f64>,
    /// Mean particle distance to the target layout (`measures.mean_particle_distance`).
    mean_particle_distance: Option<f64>,
    /// SQP iterations of the returned plan and the whole run's simulations.
    iterations: usize,
    simulations: usize,
    /// Wall-clock seconds of the child process.
    wall_s: f64,
    /// The largest relative `‖∇Φ‖` of the plan's states (`physics.equilibrium.max_residual`).
    equilibrium: Option<f64>,
    /// The plan simulated by Newton at its default tolerance: largest target error, and whether
    /// every target is within tolerance, the margin kept and no particle inside a collider.
    converged_max_target_error: Option<f64>,
    holds_converged: Option<bool>,
    /// The same under branch following (`--branch-check`).
    #[serde(skip_serializing_if = "Option::is_none")]
    branch_max_target_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    holds_branch: Option<bool>,
    /// Why the branch-following re-simulation failed, where it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    branch_error: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    result_file: Option<PathBuf>,
}

/// One row of the table.
type Row = plan_set::Row<Physics, Plan>;
type Outcome = plan_set::Outcome<Plan>;

fn main() -> Result<()> {
    let cli = Cli::parse();
    let set = PlanSet::new("suite", &cli.dir, &cli.scenes, cli.time_limit, &cli.flags)?;
    let rows = set.rows(&cli.physics, Physics::name, |scene, physics| {
        run_one(&set, scene, physics, cli.branch_check)
    });
    print_table(&rows);
    let settings = serde_json::json!({
        "dir": cli.dir, "clothopt": set.clothopt, "time_limit_s": cli.time_limit,
        "search": cli.flags.search, "physics": cli.physics, "branch_check": cli.branch_check,
    });
    plan_set::write_rows(cli.flags.out.as_deref(), &settings, &rows)
}

/// Plans `scene` under `physics` in a `clothopt optimize` child, then simulates the plan to
/// convergence (and under branch following with `branch`); or says why the physics is
/// unsupported.
fn run_one(set: &PlanSet, scene: &SceneFile, physics: Physics, branch: bool) -> Result<Outcome> {
    let base = scene.path.parent().unwrap_or(Path::new("."));
    let mut value: Value = serde_json::from_str(&scene.text)?;
    if let Some(solver) = physics.solver() {
        value["physics"]["solver"] = Value::String(solver.name().into());
    }
    let text = serde_json::to_string_pretty(&value)?;
    let loaded = match plan_set::supported(&text, base) {
        Ok(scene) => scene,
        Err(message) => return Ok(Outcome::Unsupported { message }),
    };
    let (result, _, wall_s, result_file) = set.plan(scene, Some(value), physics.name())?;
    let mut newton = loaded.clone();
    newton.physics.solver = Some(SolverKind::Newton);
    newton.physics.tolerance = None;
    let converged = resimulated(&newton, &result).ok();
    let halvings = BRANCH_HALVINGS;
    let branched = branch.then(|| {
        resimulated(
            &CheckPhysics::NewtonBranch { halvings }.apply(&loaded),
            &result,
        )
        .map_err(|e| format!("{e:#}"))
    });
    let p = result.physics.as_ref();
    Ok(Outcome::Planned(Box::new(Plan {
        physics: p.map_or("—".into(), |p| p.name()),
        reason: p.map_or("—".into(), |p| p.reason.describe().into()),
        achieved: result.task.achieved,
        verdict: result.task.reason.name().into(),
        max_target_error: result.task.max_target_error,
        targets_reached: result.task.targets_reached,
        targets: result.task.target_errors.len(),
        tolerance: result.task.tolerance,
        coverage: result.measures.as_ref().and_then(|m| m.coverage),
        mean_particle_distance: result
            .measures
            .as_ref()
            .and_then(|m| m.mean_particle_distance),
        iterations: result.iterations,
        simulations: result
            .search
            .as_ref()
            .map_or(result.evaluations, |s| s.simulations),
        wall_s,
        equilibrium: p.and_then(|p| p.equilibrium.max_residual),
        converged_max_target_error: converged.map(|c| c.0),
        holds_converged: converged.map(|c| c.1),
        branch_max_target_error: branched.as_ref().and_then(|b| b.as_ref().ok()).map(|c| c.0),
        holds_branch: branched.as_ref().and_then(|b| b.as_ref().ok()).map(|c| c.1),
        branch_error: branched.and_then(Result::err),
        result_file,
    })))
}

/// The plan of `result` simulated on `scene` (the plan's scene under other physics): the largest
/// target error, and whether every target is within tolerance, the margin kept and no particle
/// inside a collider (by more than the feasibility tolerance). An error where the physics cannot
/// simulate the scene or the rollout fails.
fn resimulated(scene: &Scene, result: &PlanResult) -> Result<(f64, bool)> {
    let model = Model::from_scene(scene)?;
    let controls = controls_from_nested(&model, &result.controls)?;
    let ev = model.evaluate(&controls, result.delta, false)?;
    let errors = target_errors(&model, ev.states.last().context("an empty rollout")?);
    let max = errors.iter().copied().fold(0.0, f64::max);
    let inside = ev
        .metrics
        .max_penetration
        .is_some_and(|p| p.depth > result.feasibility_tolerance);
    let holds = max <= model.task.tolerance && is_safe(&ev.metrics) && !inside;
    Ok((max, holds))
}

/// One line of the table: the scene and physics asked for, then the plan's cells.
fn line(scene: &str, physics: &str, cells: [&str; 10]) -> String {
    let [ran, verdict, error, coverage, distance, iters, sims, wall, equilibrium, converged] =
        cells;
    format!(
        "{scene:<18} {physics:<7} {ran:<34} {verdict:<16} {error:>9} {coverage:>8} {distance:>9} \
         {iters:>6} {sims:>6} {wall:>7} {equilibrium:>9} {converged}"
    )
}

fn print_table(rows: &[Row]) {
    let header = [
        "physics that ran",
        "verdict",
        "error",
        "coverage",
        "particles",
        "iters",
        "sims",
        "wall s",
        "‖∇Φ‖ rel",
        "converged: error, holds",
    ];
    println!("{}", line("scene", "asked", header));
    for r in rows {
        let (scene, physics) = (r.scene.as_str(), r.variant.name());
        match &r.outcome {
            Outcome::Planned(p) => {
                let verdict = |e: Option<f64>, h: Option<bool>| match (e, h) {
                    (Some(e), Some(h)) => format!("{e:.4}, {}", if h { "yes" } else { "no" }),
                    _ => "—".into(),
                };
                let mut converged = verdict(p.converged_max_target_error, p.holds_converged);
                if let Some(e) = &p.branch_error {
                    converged = format!("{converged}; branch failed: {e}");
                } else if p.branch_max_target_error.is_some() {
                    let b = verdict(p.branch_max_target_error, p.holds_branch);
                    converged = format!("{converged}; branch {b}");
                }
                let cells = [
                    p.physics.clone(),
                    p.verdict.clone(),
                    format!("{:.4}/{:.3}", p.max_target_error, p.tolerance),
                    fmt_opt(p.coverage, 3),
                    fmt_opt(p.mean_particle_distance, 4),
                    p.iterations.to_string(),
                    p.simulations.to_string(),
                    fmt_opt(Some(p.wall_s), 1),
                    p.equilibrium.map_or("—".into(), |r| format!("{r:.1e}")),
                    converged,
                ];
                println!(
                    "{}",
                    line(scene, physics, cells.each_ref().map(String::as_str))
                );
            }
            Outcome::Unsupported { message } => {
                println!("{scene:<18} {physics:<7} unsupported: {message}")
            }
            Outcome::Error { message } => println!("{scene:<18} {physics:<7} error: {message}"),
        }
    }
}
