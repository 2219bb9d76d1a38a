//! What a plan costs with each target model: `clothopt optimize SCENE --target-model M` for
//! every scene and model, one row each: wall-clock seconds of the whole process, SQP iterations,
//! simulations and gradients over every stage (the route search included), and the verdict.
//!
//! ```sh
//! cargo build --release --bin clothopt && cargo build --release -p experiments --bin plan_speed
//! target/release/plan_speed                                   # u_obstacle, fold, routes/ball_25
//! target/release/plan_speed u_obstacle --models bfgs --out speed.json
//! ```
//!
//! Each plan is one child process (the `clothopt` beside this program, or `--clothopt PATH`), so
//! a row is what a user of the command line waits for. Rows run one after the other; the wall
//! clock depends on the machine and its load, the counts do not.

use anyhow::{Context, Result};
use clap::Parser;
use clothopt::problem::TargetModel;
use clothopt::result::PlanResult;
use clothopt::validate::ensure_positive;
use experiments::child;
use experiments::measure::timed;
use experiments::report::write_json;
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(about = "What a plan costs with each target model")]
struct Cli {
    /// Scenes: built-in names or scene files (default: u_obstacle, fold,
    /// examples/scenes/routes/ball_25.json).
    scenes: Vec<String>,
    /// Target models, comma-separated: each scene is planned once with each.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = TargetModel::ALL)]
    models: Vec<TargetModel>,
    /// Seconds each plan may take (`optimize --time-limit`; default none).
    #[arg(long, allow_negative_numbers = true)]
    time_limit: Option<f64>,
    /// The `clothopt` binary (default: the one beside this program).
    #[arg(long)]
    clothopt: Option<PathBuf>,
    /// Write every row as JSON here (atomically).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// One plan: the command's cost and verdict.
#[derive(Serialize)]
struct Row {
    scene: String,
    model: TargetModel,
    /// Wall-clock seconds of the child process (load, plan, write).
    wall_s: f64,
    /// SQP iterations of every stage and candidate.
    iterations: usize,
    /// Rollouts simulated by the whole run.
    simulations: usize,
    /// Backward passes of the whole run.
    gradients: usize,
    achieved: bool,
    /// The verdict's reason (`achieved`, `safety_active`, …).
    reason: String,
    /// The kept plan's solver status.
    status: String,
}

const DEFAULT_SCENES: [&str; 3] = ["u_obstacle", "fold", "examples/scenes/routes/ball_25.json"];

fn main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(limit) = cli.time_limit {
        ensure_positive("--time-limit", limit)?;
    }
    anyhow::ensure!(!cli.models.is_empty(), "--models: name at least one model");
    let clothopt = child::clothopt_binary(cli.clothopt.as_deref())?;
    let scenes: Vec<String> = if cli.scenes.is_empty() {
        DEFAULT_SCENES.map(String::from).to_vec()
    } else {
        cli.scenes.clone()
    };
    let scratch = std::env::temp_dir().join(format!("clothopt-speed-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .with_context(|| format!("cannot create {}", scratch.display()))?;
    let mut rows = Vec::new();
    for scene in &scenes {
        for &model in &cli.models {
            eprintln!("{scene} ({}) …", model.name());
            let row = run_one(&cli, &clothopt, &scratch, scene, model)?;
            eprintln!("  {}", serde_json::to_string(&row)?);
            rows.push(row);
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!("| command | wall (s) | SQP iterations | simulations | gradients | verdict |");
    println!("|---|---:|---:|---:|---:|---|");
    for r in &rows {
        println!(
            "| `optimize {} --target-model {}` | {:.1} | {} | {} | {} | {} |",
            r.scene,
            r.model.name().replace('_', "-"),
            r.wall_s,
            r.iterations,
            r.simulations,
            r.gradients,
            r.reason
        );
    }
    if let Some(out) = &cli.out {
        write_json(out, &serde_json::json!({ "rows": rows }))?;
    }
    Ok(())
}

/// Plans `scene` with `model` in a `clothopt optimize` child and reads its result.
fn run_one(
    cli: &Cli,
    clothopt: &Path,
    scratch: &Path,
    scene: &str,
    model: TargetModel,
) -> Result<Row> {
    let result_path = scratch.join(format!("result-{}.json", model.name()));
    let what = format!("clothopt optimize {scene} --target-model {}", model.name());
    let mut command = std::process::Command::new(clothopt);
    command
        .args(["optimize", scene, "--target-model"])
        .arg(model.name().replace('_', "-"))
        .arg("--out")
        .arg(&result_path);
    if let Some(limit) = cli.time_limit {
        command.arg("--time-limit").arg(limit.to_string());
    }
    // `optimize` exits 3 (safe, not achieved) and 4 (no safe plan) with a result written.
    let (_, wall_s) = timed(|| child::run_accepting(&mut command, &what, &[0, 3, 4]))?;
    let text = std::fs::read_to_string(&result_path)
        .with_context(|| format!("{what}: no result at {}", result_path.display()))?;
    let _ = std::fs::remove_file(&result_path);
    let result: PlanResult =
        serde_json::from_str(&text).with_context(|| format!("{what}: unreadable result"))?;
    let search = result.search.as_ref();
    Ok(Row {
        scene: scene.to_string(),
        model,
        wall_s,
        iterations: search.map_or(result.iterations, |s| s.iterations),
        simulations: search.map_or(result.evaluations, |s| s.simulations),
        gradients: search.map_or(result.gradient_evaluations, |s| s.gradient_evaluations),
        achieved: result.task.achieved,
        reason: result.task.reason.name().to_string(),
        status: result.status.clone(),
    })
}
