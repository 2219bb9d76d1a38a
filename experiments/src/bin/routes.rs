//! The blocked-path benchmark: every scene of `examples/scenes/routes/` planned with the route
//! search off and on (`--search auto`), one row per scene, a figure per scene.
//!
//! ```sh
//! cargo run --release -p experiments --bin routes -- --out routes.json --png-dir figs
//! cargo run --release -p experiments --bin routes -- --scenes slalom,target_inside   # a subset
//! ```
//!
//! Each plan runs in a fresh child process (this program, `one` mode), so its peak memory
//! (VmHWM) is its own. Every scene's description says whether it is achievable; the table
//! compares that with what the planner reports.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use cloth::{Model, Scene};
use clothopt::figures::RolloutFigure;
use clothopt::plan::{initial_controls, PlanOptions};
use clothopt::result::{states_of, PlanResult, SearchMode};
use clothopt::search::{plan_with_search, SearchOptions};
use experiments::child;
use experiments::measure::proc_status_kb;
use experiments::report::write_json;
use experiments::scene_set::load_set;
use std::path::{Path, PathBuf};

#[derive(Parser)]
struct Cli {
    #[command(subcommand)]
    mode: Option<Mode>,
    /// Directory of scene files.
    #[arg(long, default_value = "examples/scenes/routes")]
    dir: PathBuf,
    /// Only these scenes (comma-separated names; default all).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Write every row (and both plans' summaries) as JSON here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write one figure per scene (the search-on plan) into this directory.
    #[arg(long)]
    png_dir: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Mode {
    /// Internal: plan one scene in this process and print the result JSON (with peak memory).
    One {
        scene: PathBuf,
        #[arg(long, value_enum)]
        search: SearchMode,
        #[arg(long)]
        result: PathBuf,
    },
}

/// One plan as the table needs it.
#[derive(serde::Serialize, serde::Deserialize, Clone)]
struct Run {
    achieved: bool,
    safe: bool,
    reason: String,
    l: f64,
    g: f64,
    min_sdf: f64,
    max_target_error: f64,
    simulations: usize,
    wall_s: f64,
    peak_rss_mb: Option<f64>,
    route: String,
}

/// One scene's row.
#[derive(serde::Serialize)]
struct Row {
    scene: String,
    achievable: Option<bool>,
    off: Run,
    on: Run,
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(Mode::One {
        scene,
        search,
        result,
    }) = cli.mode
    {
        return plan_one(&scene, search, &result);
    }
    let mut rows = Vec::new();
    for (file, scene) in load_set(&cli.dir, &cli.scenes, "--dir")? {
        eprintln!("{}: planning with search off, then on …", scene.name);
        let off = spawn(&file, SearchMode::Off)?;
        let on = spawn(&file, SearchMode::Auto)?;
        if let Some(dir) = &cli.png_dir {
            draw(&scene, &on.1, dir)?;
        }
        rows.push(Row {
            scene: scene.name.clone(),
            achievable: achievable(&scene.description),
            off: off.0,
            on: on.0,
        });
    }
    print_table(&rows);
    if let Some(out) = &cli.out {
        write_json(out, &rows)?;
    }
    Ok(())
}

/// `Some(true)` / `Some(false)` from a description starting "Achievable: yes/no".
fn achievable(description: &str) -> Option<bool> {
    let rest = description.strip_prefix("Achievable: ")?;
    if rest.starts_with("yes") {
        Some(true)
    } else if rest.starts_with("no") {
        Some(false)
    } else {
        None
    }
}

/// Plans `file` in a fresh child process with `search`.
fn spawn(file: &Path, search: SearchMode) -> Result<(Run, PlanResult)> {
    let tmp = tempfile_path(file, search);
    let mode = match search {
        SearchMode::Off => "off",
        SearchMode::Auto => "auto",
        SearchMode::Always => "always",
    };
    let stdout = child::run(
        child::this_program()?
            .arg("one")
            .arg(file)
            .args(["--search", mode, "--result"])
            .arg(&tmp),
        &format!("planning {} (search {mode})", file.display()),
    )?;
    let text = std::fs::read_to_string(&tmp)?;
    let _ = std::fs::remove_file(&tmp);
    let result: PlanResult = serde_json::from_str(&text)?;
    let peak: Option<f64> = stdout.trim().parse().ok();
    let route = result
        .search
        .as_ref()
        .and_then(|s| s.candidates.iter().find(|c| c.kept))
        .map_or("initial guess".to_string(), |c| c.route.clone());
    let run = Run {
        achieved: result.task.achieved,
        safe: result.is_feasible() && result.is_safe(),
        reason: format!("{:?}", result.task.reason),
        l: result.metrics.l,
        g: result.metrics.g,
        min_sdf: result.metrics.min_sdf,
        max_target_error: result.task.max_target_error,
        simulations: result
            .search
            .as_ref()
            .map_or(result.evaluations, |s| s.simulations),
        wall_s: result.wall_s,
        peak_rss_mb: peak,
        route,
    };
    Ok((run, result))
}

fn tempfile_path(file: &Path, search: SearchMode) -> PathBuf {
    let stem = file
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy());
    std::env::temp_dir().join(format!(
        "clothopt-routes-{}-{stem}-{search:?}.json",
        std::process::id()
    ))
}

/// The child: plans one scene, writes the result, prints its peak RSS in MB.
fn plan_one(file: &Path, search: SearchMode, result_path: &Path) -> Result<()> {
    let scene = Scene::load(file)?;
    let model = Model::from_scene(&scene)?;
    let options = PlanOptions::for_model(&model);
    let start = initial_controls(&scene, &model)?;
    let search = SearchOptions {
        mode: search,
        ..SearchOptions::default()
    };
    let result = plan_with_search(&model, &scene, &start, &options, &search, |_| {})?;
    clothopt::output::write_json_atomic(result_path, &result)?;
    if let Some(kb) = proc_status_kb("VmHWM") {
        println!("{:.1}", kb / 1024.0);
    }
    Ok(())
}

fn draw(scene: &Scene, result: &PlanResult, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let model = Model::from_scene(scene)?;
    let states = states_of(result)?;
    let verdict = if result.task.achieved {
        "achieved"
    } else {
        "not achieved"
    };
    let title = format!("{}: {verdict} ({})", scene.name, result.status);
    let figure = RolloutFigure::new(
        &model,
        (scene.cloth.rows, scene.cloth.cols),
        &states,
        &title,
        Some(result.delta),
    );
    let path = dir.join(format!("routes_{}.png", scene.name));
    figure.draw_3d(&path)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

fn print_table(rows: &[Row]) {
    println!(
        "{:<14} {:>10} | {:>12} {:>9} {:>8} | {:>12} {:>9} {:>8} {:>8} {:>6} {:>8} {:>7} | route kept",
        "scene",
        "achievable",
        "search off",
        "L",
        "G",
        "search on",
        "L",
        "G",
        "min SDF",
        "sims",
        "wall s",
        "MB"
    );
    let yes_no = |b: bool| if b { "achieved" } else { "missed" };
    for r in rows {
        println!(
            "{:<14} {:>10} | {:>12} {:>9.4} {:>8.4} | {:>12} {:>9.4} {:>8.4} {:>8.4} {:>6} {:>8.1} {:>7} | {}",
            r.scene,
            r.achievable.map_or("?", |a| if a { "yes" } else { "no" }),
            yes_no(r.off.achieved),
            r.off.l,
            r.off.g,
            yes_no(r.on.achieved),
            r.on.l,
            r.on.g,
            r.on.min_sdf,
            r.on.simulations,
            r.on.wall_s,
            r.on.peak_rss_mb.map_or("-".into(), |m| format!("{m:.0}")),
            r.on.route
        );
    }
    println!("(walls: search off {} s in all; search on {} s in all; each plan in a fresh process, 2 cores shared)",
        rows.iter().map(|r| r.off.wall_s).sum::<f64>().round(),
        rows.iter().map(|r| r.on.wall_s).sum::<f64>().round());
}
