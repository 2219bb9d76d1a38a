//! The `clothopt` command line: list scenes, simulate, differentiate, optimize, export.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use cloth::{Controls, Model, Scene};
use clothopt::error_chain;
use clothopt::figures::{self, top_view_path, RolloutFigure};
use clothopt::plan::{
    self, controls_from_nested, ensure_iterations, ensure_non_negative, initial_controls,
    SolverKind,
};
use clothopt::problem::SafetyForm;
use clothopt::request::OptimizeRequest;
use clothopt::search::{plan_with_search, SearchMode};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

mod cli_progress;
mod cli_summary;
use cli_progress::Reporter;
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "clothopt",
    version,
    about = "Safe, physics-aware cloth manipulation planning"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the built-in scenes.
    Scenes,
    /// Simulate a control sequence and report the metrics.
    Simulate {
        /// A built-in scene name or a scene JSON file.
        scene: String,
        /// Controls file `{"controls": [[[x,y,z], …] …]}` (default: the scene's initial guess).
        #[arg(long)]
        controls: Option<PathBuf>,
        /// Write the rollout (metrics, controls, states) as JSON.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Draw the rollout: a 3-D view here and a top view beside it (`*_top.png`).
        #[arg(long)]
        png: Option<PathBuf>,
        #[command(flatten)]
        watch: WatchArgs,
        /// Solver sweeps per time step (default: the scene's `physics.iterations`).
        #[arg(long)]
        sweeps: Option<usize>,
        #[command(flatten)]
        physics: PhysicsArgs,
    },
    /// Print L, its terms, C and their gradients with respect to the controls as one JSON object.
    Grad {
        /// A built-in scene name or a scene JSON file.
        scene: String,
        /// Controls file (default: the scene's initial guess).
        #[arg(long)]
        controls: Option<PathBuf>,
        /// Safety margin δ (default: the scene's).
        #[arg(long, allow_negative_numbers = true)]
        delta: Option<f64>,
        /// Solver sweeps per time step (default: the scene's `physics.iterations`; the old
        /// spelling `--iterations` is still accepted here).
        #[arg(long, alias = "iterations")]
        sweeps: Option<usize>,
        #[command(flatten)]
        physics: PhysicsArgs,
    },
    /// Optimize the control sequence of a scene's task.
    #[command(
        after_help = "Exit codes: 0 the task is achieved (every target within \
task.tolerance, plan safe); 1 error or bad input; 3 a safe plan was written but the task is not \
achieved (the first line says why); 4 no safe plan was found (the result is still written)."
    )]
    Optimize {
        /// A built-in scene name or a scene JSON file.
        scene: String,
        /// Safety margin δ (default: the scene's).
        #[arg(long, allow_negative_numbers = true)]
        delta: Option<f64>,
        /// Weight α of the trajectory irregularity (default: the scene's).
        #[arg(long, allow_negative_numbers = true)]
        alpha: Option<f64>,
        /// Weight β of the elastic energy (default: the scene's).
        #[arg(long, allow_negative_numbers = true)]
        beta: Option<f64>,
        /// Optimizer iteration limit, per κ stage (the soft safety forms first solve at κ = 200)
        #[arg(long, default_value_t = 200)]
        iterations: usize,
        /// Solver sweeps per time step of the simulation (default: the scene's
        /// `physics.iterations`).
        #[arg(long)]
        sweeps: Option<usize>,
        /// Form of the safety constraint.
        #[arg(long, value_enum, default_value_t = SafetyForm::PerStep)]
        safety: SafetyForm,
        /// Also keep the straight paths between steps at least δ away.
        #[arg(long)]
        swept: bool,
        /// Sharpness κ (1/length) of the soft minimum in the per-step and aggregate forms (default
        /// 3000); above 200 the planner first solves at κ = 200 and refines from that plan.
        #[arg(long, allow_negative_numbers = true)]
        kappa: Option<f64>,
        /// Safety rows farther than this above their margin keep their last gradient instead of
        /// a backward pass per iterate while it predicts their change (length units; default off).
        #[arg(long, allow_negative_numbers = true)]
        reuse_band: Option<f64>,
        /// The solver.
        #[arg(long, value_enum, default_value_t = SolverKind::Sqp)]
        solver: SolverKind,
        /// Route search: `auto` plans other routes (detours over, beside or under the obstacles
        /// the first plan runs into, and seeded perturbations) only when the plan from the start
        /// does not achieve the task; `always` also when it does; `off` never.
        #[arg(long, value_enum, default_value_t = SearchMode::Auto)]
        search: SearchMode,
        /// Most candidate routes the search plans (from 4 on, 2 of them seeded random
        /// perturbations).
        #[arg(long, default_value_t = 6)]
        starts: usize,
        /// Write the result JSON here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Start from these controls: a controls file or a previous result (default: the scene's
        /// initial guess).
        #[arg(long)]
        start: Option<PathBuf>,
        /// Scaled KKT tolerance for `converged`.
        #[arg(long, default_value_t = 1e-4, allow_negative_numbers = true)]
        tol: f64,
        /// Largest violation (length units) of the optimizer's rows (safety rows, collider rows)
        /// at which a plan still counts as feasible; a plan violating them by more ends `no safe
        /// plan` (exit 4) and says by how much.
        #[arg(long, default_value_t = clothopt::plan::FEASIBILITY_TOLERANCE, allow_negative_numbers = true)]
        feasibility_tol: f64,
        /// Plan even when the cloth starts inside an obstacle (an error otherwise): step 0 is
        /// fixed by the scene, so no plan can make it safe.
        #[arg(long)]
        allow_unsafe_start: bool,
        /// Draw the result: a 3-D view here and a top view beside it (`*_top.png`).
        #[arg(long)]
        png: Option<PathBuf>,
        #[command(flatten)]
        watch: WatchArgs,
        /// Print one line per optimizer iteration to stderr.
        #[arg(long)]
        verbose: bool,
        /// Stop after this many seconds and return the best safe plan found so far (status
        /// `time_limit`); the route search stops too.
        #[arg(long, allow_negative_numbers = true)]
        time_limit: Option<f64>,
        /// Leave the wall-clock time out of the result JSON and the summary, so that the same
        /// command writes byte-identical results (any thread count).
        #[arg(long)]
        no_timing: bool,
        #[command(flatten)]
        physics: PhysicsArgs,
    },
    /// Export a result: dense way-points of the control points (CSV) and/or one OBJ mesh per step.
    Export {
        /// A result JSON written by `optimize --out` (or `simulate --out`).
        result: PathBuf,
        /// Write the control points' way-points here (CSV).
        #[arg(long)]
        waypoints: Option<PathBuf>,
        /// Way-points per step (linear interpolation between steps).
        #[arg(long, default_value_t = 10)]
        per_step: usize,
        /// Write one OBJ mesh per step into this directory.
        #[arg(long)]
        obj: Option<PathBuf>,
    },
}

/// The animated outputs shared by `simulate` and `optimize`.
#[derive(clap::Args, Debug)]
struct WatchArgs {
    /// Write the rollout as one self-contained HTML page to watch (orbit with the mouse, time
    /// slider, play; the particle nearest the obstacles marked at every step).
    #[arg(long)]
    html: Option<PathBuf>,
    /// Write the rollout as an animated GIF, one 3-D view per step.
    #[arg(long)]
    gif: Option<PathBuf>,
}

impl WatchArgs {
    /// Writes the HTML page and/or the GIF of a rollout.
    fn write(
        &self,
        model: &Model,
        scene: &Scene,
        states: &[autodiff::Tensor],
        title: &str,
        delta: f64,
    ) -> Result<()> {
        let grid = (scene.cloth.rows, scene.cloth.cols);
        if let Some(path) = &self.html {
            figures::write_rollout_html(model, states, title, Some(delta), path)?;
            println!("wrote {}", path.display());
        }
        if let Some(path) = &self.gif {
            figures::draw_rollout_gif(model, grid, states, title, Some(delta), path)?;
            println!("wrote {}", path.display());
        }
        Ok(())
    }
}

/// The physics solver flags shared by `simulate`, `grad` and `optimize`.
#[derive(clap::Args, Debug)]
struct PhysicsArgs {
    /// Step solver: `xpbd` (the scene's iterations of Gauss–Seidel) or `newton` (converged;
    /// default: the scene's `physics.solver`).
    #[arg(long, value_enum)]
    physics: Option<PhysicsSolver>,
    /// Newton's relative ‖∇Φ‖ tolerance, in (0, 1) (default: the scene's, else 1e-10).
    #[arg(long)]
    physics_tolerance: Option<f64>,
    /// Newton's load steps per time step, ≥ 1 (default: the scene's, else 1).
    #[arg(long)]
    physics_load_steps: Option<usize>,
}

/// `--physics` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum PhysicsSolver {
    Xpbd,
    Newton,
}

impl PhysicsArgs {
    /// Writes the flags into the scene's `physics` (validated with the scene).
    fn apply(&self, scene: &mut Scene) -> Result<()> {
        use cloth::scene::SolverKind as Kind;
        if let Some(p) = self.physics {
            scene.physics.solver = match p {
                PhysicsSolver::Xpbd => Kind::Xpbd,
                PhysicsSolver::Newton => Kind::Newton,
            };
        }
        if let Some(tol) = self.physics_tolerance {
            if !(tol > 0.0 && tol < 1.0) {
                bail!("--physics-tolerance must be in (0, 1), got {tol}");
            }
            scene.physics.tolerance = Some(tol);
        }
        if let Some(k) = self.physics_load_steps {
            if k == 0 {
                bail!("--physics-load-steps must be at least 1, got 0");
            }
            scene.physics.load_steps = Some(k);
        }
        Ok(())
    }
}

/// The command-line spelling of a setting: `reuse_band` → `--reuse-band`.
fn flag_name(field: &str) -> String {
    format!("--{}", field.replace('_', "-"))
}

/// Applies `check` to a flag's value when the flag was given.
fn check_flag(
    flag: &str,
    value: Option<f64>,
    check: fn(&str, f64) -> clothopt::Result<()>,
) -> Result<()> {
    Ok(value.map_or(Ok(()), |v| check(flag, v))?)
}

fn load_scene(name: &str) -> Result<Scene> {
    Ok(clothopt::request::load_scene(name)?)
}

/// A controls file, or any JSON object with a `controls` key (such as a result).
#[derive(serde::Deserialize)]
struct ControlsFile {
    controls: Vec<Vec<[f64; 3]>>,
}

fn load_controls(scene: &Scene, model: &Model, file: Option<&Path>) -> Result<Controls> {
    match file {
        None => Ok(initial_controls(scene, model)?),
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let parsed: ControlsFile = serde_json::from_str(&text)
                .with_context(|| format!("{}: not a controls file", path.display()))?;
            controls_from_nested(model, &parsed.controls)
                .with_context(|| path.display().to_string())
        }
    }
}

fn main() {
    match run(Cli::parse()) {
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {}", error_chain(e.as_ref()));
            std::process::exit(1);
        }
    }
}

/// Overrides the scene's solver sweeps per step (`physics.iterations`) by `--sweeps`, if given.
fn apply_sweeps(scene: &mut Scene, sweeps: Option<usize>) -> Result<()> {
    if let Some(n) = sweeps {
        ensure_iterations("--sweeps", n)?;
        scene.physics.iterations = n;
    }
    Ok(())
}

/// Runs a command; the exit code (0, or `optimize`'s verdict: see [`outcome::exit_code`]).
fn run(cli: Cli) -> Result<i32> {
    match cli.command {
        Command::Scenes => {
            for (name, description) in Scene::builtin_names() {
                println!("{name:<12} {description}");
            }
        }
        Command::Simulate {
            scene,
            controls,
            out,
            png,
            watch,
            sweeps,
            physics,
        } => {
            let mut scene = load_scene(&scene)?;
            apply_sweeps(&mut scene, sweeps)?;
            physics.apply(&mut scene)?;
            let model = Model::from_scene(&scene)?;
            let u = load_controls(&scene, &model, controls.as_deref())?;
            let ev = model.evaluate(&u, scene.task.delta, false)?;
            let m = ev.metrics;
            println!("scene {} — {}", scene.name, model.effects());
            println!(
                "G {:.6}  T {:.6}  E {:.6}  L {:.6}  C {:.3e}  min SDF {:.4}  swept {:.4}",
                m.g, m.t, m.e, m.l, m.c, m.min_sdf, m.min_sdf_swept
            );
            if let Some(out) = out {
                let mut result = serde_json::json!({
                    "scene": scene.name, "delta": scene.task.delta, "metrics": m,
                    "grid": [scene.cloth.rows, scene.cloth.cols],
                    "control_particles": model.controls.as_slice(),
                    "controls": plan::controls_to_nested(&u),
                    "states": ev.states.iter().map(plan::state_points).collect::<Vec<_>>(),
                });
                if let Some(t) = plan::mesh_triangles(&scene, &model) {
                    result["triangles"] = serde_json::json!(t);
                }
                plan::write_json_atomic(&out, &result)?;
            }
            let title = format!("{} (simulated)", scene.name);
            if let Some(png) = png {
                draw(&model, &scene, &ev.states, &title, scene.task.delta, &png)?;
            }
            watch.write(&model, &scene, &ev.states, &title, scene.task.delta)?;
        }
        Command::Grad {
            scene,
            controls,
            delta,
            sweeps,
            physics,
        } => {
            check_flag("--delta", delta, ensure_non_negative)?;
            if let Some(n) = sweeps {
                ensure_iterations("--sweeps", n)?;
            }
            let mut scene = load_scene(&scene)?;
            apply_sweeps(&mut scene, sweeps)?;
            physics.apply(&mut scene)?;
            let model = Model::from_scene(&scene)?;
            let u = load_controls(&scene, &model, controls.as_deref())?;
            let delta = delta.unwrap_or(scene.task.delta);
            let ev = model.evaluate(&u, delta, true)?;
            let m = ev.metrics;
            let nested = |g: Option<autodiff::Tensor>| g.map(|g| plan::controls_to_nested(&g));
            let out = serde_json::json!({
                "L": m.l, "G": m.g, "T": m.t, "E": m.e, "C": m.c, "min_sdf": m.min_sdf,
                "grad_L": nested(ev.grad_l), "grad_C": nested(ev.grad_c),
            });
            // A reader that stops early (`| head`) ends the output; that is not an error.
            let mut stdout = std::io::stdout().lock();
            if let Err(e) = writeln!(stdout, "{out}").and_then(|_| stdout.flush()) {
                if e.kind() != std::io::ErrorKind::BrokenPipe {
                    return Err(e.into());
                }
            }
        }
        Command::Optimize {
            scene,
            delta,
            alpha,
            beta,
            iterations,
            sweeps,
            safety,
            swept,
            kappa,
            reuse_band,
            solver,
            search,
            starts,
            out,
            tol,
            feasibility_tol,
            allow_unsafe_start,
            start,
            png,
            watch,
            verbose,
            no_timing,
            time_limit,
            physics,
        } => {
            let request = OptimizeRequest {
                delta,
                alpha,
                beta,
                iterations,
                safety,
                swept,
                kappa,
                reuse_band,
                solver,
                search,
                starts,
                tol,
                feasibility_tol,
                allow_unsafe_start,
                time_limit,
            };
            request.check(&flag_name)?;
            if let Some(n) = sweeps {
                ensure_iterations("--sweeps", n)?;
            }
            let mut scene = load_scene(&scene)?;
            apply_sweeps(&mut scene, sweeps)?;
            physics.apply(&mut scene)?;
            let model = Model::from_scene(&scene)?;
            let start = load_controls(&scene, &model, start.as_deref())?;
            let (mut options, search) = request.options(&model, &flag_name)?;
            let stop = Arc::new(AtomicBool::new(false));
            options.stop = Some(stop.clone());
            // First Ctrl-C: stop the optimizer and write the best plan so far; a second one quits.
            ctrlc::set_handler(move || {
                if stop.swap(true, Ordering::SeqCst) {
                    std::process::exit(130);
                }
            })
            .context("cannot install the Ctrl-C handler")?;
            let budget = iterations * (1 + usize::from(options.kappa_warmup.is_some()));
            let mut reporter = Reporter::new(budget, verbose, options.tol_feasibility);
            let mut save = |x: &[f64], violation: f64, seen: usize| {
                let Some(path) = &out else { return };
                match plan::snapshot(&model, &scene, x, violation, seen, &options) {
                    Ok(mut r) => {
                        if no_timing {
                            r.drop_timing();
                        }
                        if let Err(e) = plan::write_json_atomic(path, &r) {
                            eprintln!("warning: best-so-far file: {e:#}");
                        }
                    }
                    Err(e) => eprintln!("warning: best-so-far file: {e:#}"),
                }
            };
            let result = plan_with_search(&model, &scene, &start, &options, &search, |info| {
                reporter.iteration(info, &mut save)
            });
            reporter.finish();
            let mut result = result?;
            if no_timing {
                result.drop_timing();
            }
            if let Some(warning) = plan::strain_warning(&model, &result) {
                result.warnings.push(warning);
            }
            cli_summary::print_summary(&result, no_timing);
            if let Some(out) = &out {
                plan::write_json_atomic(out, &result)?;
            }
            if png.is_some() || watch.html.is_some() || watch.gif.is_some() {
                let states = plan::states_of(&result)?;
                let title = format!(
                    "{}  δ = {}  ({})",
                    result.scene, result.delta, result.status
                );
                if let Some(png) = png {
                    draw(&model, &scene, &states, &title, result.delta, &png)?;
                }
                watch.write(&model, &scene, &states, &title, result.delta)?;
            }
            return Ok(cli_summary::report_verdict(&result, out.as_deref()));
        }
        Command::Export {
            result,
            waypoints,
            per_step,
            obj,
        } => {
            let text = std::fs::read_to_string(&result)
                .with_context(|| format!("cannot read {}", result.display()))?;
            let parsed: ExportInput = serde_json::from_str(&text)
                .with_context(|| format!("{}: not a clothopt result", result.display()))?;
            let [rows, cols] = parsed.grid;
            if parsed.states.is_empty() {
                bail!("{}: the result has no states to export", result.display());
            }
            // A mesh cloth's particle count is its states' (every triangle index must be below it).
            let n = match &parsed.triangles {
                Some(_) => parsed.states[0].len(),
                None => rows * cols,
            };
            if let Some(bad) = parsed.states.iter().position(|s| s.len() != n) {
                bail!(
                    "{}: states[{bad}] has {} points for a {rows} × {cols} grid",
                    result.display(),
                    parsed.states[bad].len()
                );
            }
            if let Some(t) = parsed
                .triangles
                .iter()
                .flatten()
                .flatten()
                .find(|&&p| p >= n)
            {
                bail!("{}: triangle particle {t} out of range", result.display());
            }
            if let Some(&p) = parsed.control_particles.iter().find(|&&p| p >= n) {
                bail!("{}: control particle {p} out of range", result.display());
            }
            if waypoints.is_none() && obj.is_none() {
                bail!("nothing to export: give --waypoints FILE and/or --obj DIR");
            }
            if let Some(path) = waypoints {
                let paths: Vec<Vec<[f64; 3]>> = parsed
                    .control_particles
                    .iter()
                    .map(|&p| parsed.states.iter().map(|s| s[p]).collect())
                    .collect();
                plan::write_atomic(
                    &path,
                    clothopt::export::waypoints_csv(&paths, per_step).as_bytes(),
                )?;
                println!(
                    "wrote {} ({} way-points per step)",
                    path.display(),
                    per_step.max(1)
                );
            }
            if let Some(dir) = obj {
                std::fs::create_dir_all(&dir)
                    .with_context(|| format!("cannot create {}", dir.display()))?;
                for (t, state) in parsed.states.iter().enumerate() {
                    let path = dir.join(format!("step_{t:03}.obj"));
                    plan::write_atomic(
                        &path,
                        match &parsed.triangles {
                            Some(t) => clothopt::export::obj_triangles(state, t),
                            None => clothopt::export::obj_mesh(state, rows, cols),
                        }
                        .as_bytes(),
                    )?;
                }
                println!(
                    "wrote {} OBJ meshes to {}",
                    parsed.states.len(),
                    dir.display()
                );
            }
        }
    }
    Ok(0)
}

/// What `export` needs from a result file.
#[derive(serde::Deserialize)]
struct ExportInput {
    grid: [usize; 2],
    #[serde(default)]
    triangles: Option<Vec<[usize; 3]>>,
    control_particles: Vec<usize>,
    states: Vec<Vec<[f64; 3]>>,
}

/// Draws a rollout's 3-D view to `png` and its top view beside it.
fn draw(
    model: &Model,
    scene: &Scene,
    states: &[autodiff::Tensor],
    title: &str,
    delta: f64,
    png: &Path,
) -> Result<()> {
    let figure = RolloutFigure::new(
        model,
        (scene.cloth.rows, scene.cloth.cols),
        states,
        title,
        Some(delta),
    );
    figure.draw_3d(png)?;
    let top = top_view_path(png);
    figure.draw_top(&top)?;
    println!("wrote {} and {}", png.display(), top.display());
    Ok(())
}
