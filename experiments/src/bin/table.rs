//! The table set: every scene of `examples/scenes/table/` (cloth laid, placed, draped and folded
//! on a table) planned with each contact model, one row per scene and model.
//!
//! ```sh
//! cargo build --release --bin clothopt && cargo build --release -p experiments --bin table
//! target/release/table --models rigid --time-limit 300 --out table.json --results-dir results
//! target/release/table lay_flat fold_towel --models rigid,smooth   # a subset
//! ```
//!
//! Each plan is one `clothopt optimize SCENE --time-limit S --search M --out RESULT` child process
//! (the binary beside this one, or `--clothopt PATH`), so a row is exactly what a user of the
//! command line gets. A model is set as the scene's `physics.contact.model` (smooth with
//! `physics.solver` `newton`, the only solver it has) unless the scene names it already (the
//! default model depends on the solver, so a scene that names none gets it named). A model the
//! simulator rejects for a scene (the scene does not load, validate or compile with it) is a row
//! `unsupported: <its error>`; a plan whose child fails is a row `error: <its error>`. Neither is
//! skipped. That check runs in this program, on the `cloth` it was built with: build both
//! binaries from the same commit (a stale `clothopt` beside it plans with other code).

use anyhow::{ensure, Context, Result};
use clap::{Parser, ValueEnum};
use clothopt::result::{Reason, SearchMode};
use experiments::plan_set::{self, PlanFlags, PlanSet};
use experiments::report::fmt_opt;
use experiments::scene_set::SceneFile;
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(about = "The table set: every scene planned with each contact model")]
struct Cli {
    /// Only these scenes (names as in the scene files; default every scene of `--dir`).
    scenes: Vec<String>,
    /// Directory of scene files.
    #[arg(long, default_value = "examples/scenes/table")]
    dir: PathBuf,
    /// Contact models, comma-separated: each scene is planned once with each.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [ContactModel::Rigid, ContactModel::Smooth])]
    models: Vec<ContactModel>,
    /// Seconds each plan may take (`optimize --time-limit`).
    #[arg(long, default_value_t = 300.0, allow_negative_numbers = true)]
    time_limit: f64,
    #[command(flatten)]
    flags: PlanFlags,
}

/// How the cloth touches the colliders: the scene's `physics.contact.model`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
enum ContactModel {
    /// Projection onto the collider's surface (the default when a scene names no model).
    Rigid,
    /// A barrier potential in the signed distance (Newton only).
    Smooth,
}

impl ContactModel {
    /// The scene's spelling of the model.
    fn name(self) -> &'static str {
        match self {
            ContactModel::Rigid => "rigid",
            ContactModel::Smooth => "smooth",
        }
    }
}

/// The settings of a run, written with its rows.
#[derive(Serialize)]
struct Settings {
    dir: PathBuf,
    clothopt: PathBuf,
    time_limit_s: f64,
    search: SearchMode,
    models: Vec<ContactModel>,
}

/// One plan's verdict and costs, as its result JSON spells them.
#[derive(Serialize)]
struct Plan {
    /// The step solver the plan ran on (`xpbd` or `newton`).
    solver: String,
    achieved: bool,
    /// Feasible and safe at its margin (`PlanResult::is_feasible` and `is_safe`).
    safe: bool,
    reason: Reason,
    /// The solver's status (`converged`, `no_progress`, `time_limit`, …).
    status: String,
    /// The first plan's status (from the initial guess; the route search, when it ran, planned
    /// others after it).
    first_status: String,
    /// `optimize`'s exit code (0 achieved, 3 safe but not achieved, 4 no safe plan).
    exit_code: i32,
    max_target_error: f64,
    targets_reached: usize,
    targets: usize,
    tolerance: f64,
    /// Optimizer iterations of the returned plan (every κ stage).
    iterations: usize,
    /// Rollouts simulated by the whole run (the route search included).
    simulations: usize,
    /// Wall-clock seconds of the child process (load, plan, write).
    wall_s: f64,
    /// The optimization's own wall-clock seconds (the result's `wall_s`).
    plan_wall_s: f64,
    /// Where the result was kept (`--results-dir`).
    #[serde(skip_serializing_if = "Option::is_none")]
    result_file: Option<PathBuf>,
}

/// One row of the table.
type Row = plan_set::Row<ContactModel, Plan>;
type Outcome = plan_set::Outcome<Plan>;

fn main() -> Result<()> {
    let cli = Cli::parse();
    ensure!(!cli.models.is_empty(), "--models: name at least one model");
    let set = PlanSet::new("table", &cli.dir, &cli.scenes, cli.time_limit, &cli.flags)?;
    let rows = set.rows(&cli.models, ContactModel::name, |scene, model| {
        run_one(&set, scene, model)
    });
    print_table(&rows);
    let settings = Settings {
        dir: cli.dir.clone(),
        clothopt: set.clothopt.clone(),
        time_limit_s: cli.time_limit,
        search: cli.flags.search,
        models: cli.models.clone(),
    };
    plan_set::write_rows(cli.flags.out.as_deref(), &settings, &rows)
}

/// Plans `scene` under `model` in a `clothopt optimize` child, or says why the model is
/// unsupported.
fn run_one(set: &PlanSet, scene: &SceneFile, model: ContactModel) -> Result<Outcome> {
    let base = scene.path.parent().unwrap_or(Path::new("."));
    let variant = with_contact_model(&scene.text, model)?;
    let text = match &variant {
        Some(value) => serde_json::to_string_pretty(value)?,
        None => scene.text.clone(),
    };
    let solver = match plan_set::supported(&text, base) {
        Ok(scene) => scene.solver_kind(),
        Err(message) => return Ok(Outcome::Unsupported { message }),
    };
    let (result, exit_code, wall_s, result_file) = set.plan(scene, variant, model.name())?;
    Ok(Outcome::Planned(Box::new(Plan {
        solver: solver.to_string(),
        achieved: result.task.achieved,
        safe: result.is_feasible() && result.is_safe(),
        reason: result.task.reason,
        status: result.status.clone(),
        first_status: result
            .search
            .as_ref()
            .and_then(|s| s.candidates.first())
            .map_or(result.status.clone(), |c| c.status.clone()),
        exit_code,
        max_target_error: result.task.max_target_error,
        targets_reached: result.task.targets_reached,
        targets: result.task.target_errors.len(),
        tolerance: result.task.tolerance,
        iterations: result.iterations,
        simulations: result
            .search
            .as_ref()
            .map_or(result.evaluations, |s| s.simulations),
        wall_s,
        plan_wall_s: result.wall_s,
        result_file,
    })))
}

/// The scene's JSON with `physics.contact.model` set to `model`, or `None` where the scene
/// already names it. A scene that names no model gets it named: the default depends on the
/// solver and the colliders (smooth under Newton with colliders), so silence means neither.
fn with_contact_model(text: &str, model: ContactModel) -> Result<Option<Value>> {
    let mut value: Value = serde_json::from_str(text)?;
    let physics = value
        .get_mut("physics")
        .and_then(Value::as_object_mut)
        .context("the scene has no `physics` object")?;
    let named = physics
        .get("contact")
        .and_then(|c| c.get("model"))
        .and_then(Value::as_str);
    if named == Some(model.name()) {
        return Ok(None);
    }
    let contact = physics
        .entry("contact")
        .or_insert_with(|| Value::Object(Default::default()));
    let contact = contact
        .as_object_mut()
        .context("the scene's `physics.contact` is not an object")?;
    contact.insert("model".into(), Value::String(model.name().into()));
    if model == ContactModel::Smooth {
        // Smooth contact is a potential in Newton's energy: it has no XPBD form.
        physics.insert("solver".into(), Value::String("newton".into()));
    }
    Ok(Some(value))
}

/// One line of the table: the scene and model, then the plan's cells.
fn line(scene: &str, model: &str, cells: [&str; 11]) -> String {
    let [solver, verdict, safe, reason, status, first, error, targets, iters, sims, wall] = cells;
    format!(
        "{scene:<14} {model:<7} {solver:<7} {verdict:<9} {safe:<5} {reason:<15} {status:<14} \
         {first:<16} {error:>13} {targets:>7} {iters:>6} {sims:>12} {wall:>8}"
    )
}

fn print_table(rows: &[Row]) {
    let header = [
        "solver",
        "verdict",
        "safe",
        "reason",
        "status",
        "first plan",
        "largest error",
        "targets",
        "iters",
        "simulations",
        "wall s",
    ];
    println!("{}", line("scene", "model", header));
    for r in rows {
        let (scene, model) = (r.scene.as_str(), r.variant.name());
        match &r.outcome {
            Outcome::Planned(p) => {
                let reason = serde_json::to_value(p.reason)
                    .ok()
                    .and_then(|v| v.as_str().map(String::from))
                    .unwrap_or_default();
                let cells = [
                    p.solver.clone(),
                    if p.achieved { "achieved" } else { "missed" }.to_string(),
                    if p.safe { "yes" } else { "no" }.to_string(),
                    reason,
                    p.status.clone(),
                    p.first_status.clone(),
                    fmt_opt(Some(p.max_target_error), 4),
                    format!("{}/{}", p.targets_reached, p.targets),
                    p.iterations.to_string(),
                    p.simulations.to_string(),
                    fmt_opt(Some(p.wall_s), 1),
                ];
                println!(
                    "{}",
                    line(scene, model, cells.each_ref().map(String::as_str))
                );
            }
            Outcome::Unsupported { message } => {
                println!("{scene:<14} {model:<7} unsupported: {message}")
            }
            Outcome::Error { message } => println!("{scene:<14} {model:<7} error: {message}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"{"name": "s", "physics": {"dt": 0.1},
        "cloth": {"mesh": "towel.obj"}, "task": {"target_mesh": "/abs/t.obj"},
        "obstacles": [{"type": "mesh", "file": "vase.obj"}, {"type": "plane"}]}"#;

    #[test]
    fn every_model_is_named_and_a_named_one_runs_as_written() {
        let variant = |text, model| with_contact_model(text, model).unwrap();
        // No model named: rigid is named too (under Newton with colliders the default is smooth).
        let rigid = variant(SCENE, ContactModel::Rigid).unwrap();
        assert_eq!(rigid["physics"]["contact"]["model"], "rigid");
        assert!(rigid["physics"].get("solver").is_none());
        let smooth = variant(SCENE, ContactModel::Smooth).unwrap();
        assert_eq!(smooth["physics"]["contact"]["model"], "smooth");
        assert_eq!(smooth["physics"]["solver"], "newton");
        assert_eq!(smooth["physics"]["dt"], 0.1);
        // A scene that names a model keeps its other contact settings.
        let named = r#"{"physics": {"contact": {"model": "smooth", "d_hat": 0.01}}}"#;
        assert!(variant(named, ContactModel::Smooth).is_none());
        let rigid = variant(named, ContactModel::Rigid).unwrap();
        assert_eq!(rigid["physics"]["contact"]["model"], "rigid");
        assert_eq!(rigid["physics"]["contact"]["d_hat"], 0.01);
    }
}
