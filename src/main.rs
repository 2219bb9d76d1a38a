//! The `clothopt` command line: list scenes, simulate, differentiate, optimize, export.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use cloth::{Controls, Model, Scene};
use clothopt::plan::{self, controls_from_nested, initial_controls, PlanOptions, SolverKind};
use clothopt::problem::SafetyForm;
use indicatif::{ProgressBar, ProgressStyle};
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
    },
    /// Print L, its terms, C and their gradients with respect to the controls as one JSON object.
    Grad {
        /// A built-in scene name or a scene JSON file.
        scene: String,
        /// Controls file (default: the scene's initial guess).
        #[arg(long)]
        controls: Option<PathBuf>,
        /// Safety margin δ (default: the scene's).
        #[arg(long)]
        delta: Option<f64>,
        /// Solver iterations per step (default: the scene's).
        #[arg(long)]
        iterations: Option<usize>,
    },
    /// Optimize the control sequence of a scene's task.
    Optimize {
        /// A built-in scene name or a scene JSON file.
        scene: String,
        /// Safety margin δ (default: the scene's).
        #[arg(long)]
        delta: Option<f64>,
        /// Weight α of the trajectory irregularity (default: the scene's).
        #[arg(long)]
        alpha: Option<f64>,
        /// Weight β of the elastic energy (default: the scene's).
        #[arg(long)]
        beta: Option<f64>,
        /// Optimizer iteration limit.
        #[arg(long, default_value_t = 200)]
        iterations: usize,
        /// Form of the safety constraint.
        #[arg(long, value_enum, default_value_t = SafetyForm::PerStep)]
        safety: SafetyForm,
        /// Also keep the straight paths between steps at least δ away.
        #[arg(long)]
        swept: bool,
        /// Sharpness κ (1/length) of the soft minimum in the per-step and aggregate forms.
        #[arg(long)]
        kappa: Option<f64>,
        /// Per-step rows farther than this from active skip their gradient (length units).
        #[arg(long)]
        active_band: Option<f64>,
        /// The solver.
        #[arg(long, value_enum, default_value_t = SolverKind::Sqp)]
        solver: SolverKind,
        /// Write the result JSON here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print one line per optimizer iteration to stderr.
        #[arg(long)]
        verbose: bool,
    },
}

fn load_scene(name: &str) -> Result<Scene> {
    let path = Path::new(name);
    if path.exists() || name.ends_with(".json") {
        Ok(Scene::load(path)?)
    } else {
        Scene::builtin(name).map_err(|e| {
            let names: Vec<&str> = Scene::builtin_names().iter().map(|(n, _)| *n).collect();
            anyhow::anyhow!("{e} (built-in scenes: {})", names.join(", "))
        })
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
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
    if let Err(e) = run(Cli::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
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
        } => {
            let scene = load_scene(&scene)?;
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
                let result = serde_json::json!({
                    "scene": scene.name, "delta": scene.task.delta, "metrics": m,
                    "controls": plan::controls_to_nested(&u),
                    "states": ev.states.iter().map(plan::state_points).collect::<Vec<_>>(),
                });
                plan::write_json_atomic(&out, &result)?;
            }
        }
        Command::Grad {
            scene,
            controls,
            delta,
            iterations,
        } => {
            let mut scene = load_scene(&scene)?;
            if let Some(n) = iterations {
                scene.physics.iterations = n;
            }
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
            println!("{out}");
        }
        Command::Optimize {
            scene,
            delta,
            alpha,
            beta,
            iterations,
            safety,
            swept,
            kappa,
            active_band,
            solver,
            out,
            verbose,
        } => {
            let scene = load_scene(&scene)?;
            let model = Model::from_scene(&scene)?;
            let mut options = PlanOptions::for_model(&model);
            options.iterations = iterations;
            options.solver = solver;
            if let Some(d) = delta {
                if !(d.is_finite() && d >= 0.0) {
                    bail!("--delta must be a finite number ≥ 0, got {d}");
                }
                options.task.delta = d;
            }
            options.task.alpha = alpha.unwrap_or(options.task.alpha);
            options.task.beta = beta.unwrap_or(options.task.beta);
            options.task.safety = model.safety.is_some().then_some(safety);
            options.task.swept = swept;
            options.task.kappa = kappa.unwrap_or(options.task.kappa);
            options.task.active_band = active_band.unwrap_or(options.task.active_band);
            let start = initial_controls(&scene, &model)?;
            let bar = ProgressBar::new(iterations as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            let result = plan::plan(&model, &scene.name, &start, &options, |info| {
                if verbose {
                    bar.suspend(|| {
                        eprintln!(
                            "it {:>4}  f {:>12.8}  viol {:>9.2e}  kkt {:>9.2e}  step {:>9.2e}  α {:>7.1e}  ν {:>7.1e}  evals {}",
                            info.iteration,
                            info.objective,
                            info.constraint_violation,
                            info.kkt_residual,
                            info.step_norm,
                            info.step_length,
                            info.penalty,
                            info.function_evaluations
                        )
                    });
                }
                bar.set_position(info.iteration as u64);
                bar.set_message(format!(
                    "f {:.5} viol {:.1e} kkt {:.1e}",
                    info.objective, info.constraint_violation, info.kkt_residual
                ));
            })?;
            bar.finish_and_clear();
            let m = &result.metrics;
            println!(
                "scene {}  δ = {}  status {}  ({})",
                result.scene, result.delta, result.status, result.message
            );
            println!(
                "iterations {}  simulations {}  gradients {}  wall {:.2} s",
                result.iterations, result.evaluations, result.gradient_evaluations, result.wall_s
            );
            println!("{:>10} {:>12}", "metric", "value");
            for (k, v) in [
                ("G", m.g),
                ("αT", m.alpha_t),
                ("βE", m.beta_e),
                ("L", m.l),
                ("C", m.c),
                ("min SDF", m.min_sdf),
                ("swept SDF", m.min_sdf_swept),
            ] {
                println!("{k:>10} {v:>12.6}");
            }
            if let Some(out) = out {
                plan::write_json_atomic(&out, &result)?;
            }
            if result.status == "infeasible" {
                bail!("no feasible trajectory found: {}", result.message);
            }
        }
    }
    Ok(())
}
