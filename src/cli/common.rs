//! What several subcommands share: the physics and watch flag groups, loading a scene and its
//! controls, `--sweeps`, flag checks, and drawing a rollout.

use anyhow::{Context, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use cloth::scene::{LinearSolverKind, SolverKind};
use cloth::{Controls, Model, Scene};
use clothopt::figures::{self, top_view_path, RolloutFigure};
use clothopt::plan::initial_controls;
use clothopt::result::controls_from_nested;
use clothopt::validate::{ensure_at_most, ensure_iterations, ensure_open_unit};
use std::path::{Path, PathBuf};

/// The animated outputs shared by `simulate` and `optimize`.
#[derive(clap::Args, Debug)]
pub struct WatchArgs {
    /// Write the rollout as one self-contained HTML page to watch (orbit with the mouse, time
    /// slider, play; the particle nearest the obstacles marked at every step).
    #[arg(long)]
    pub html: Option<PathBuf>,
    /// Write the rollout as an animated GIF, one 3-D view per step.
    #[arg(long)]
    pub gif: Option<PathBuf>,
}

impl WatchArgs {
    /// Writes the HTML page and/or the GIF of a rollout.
    pub fn write(
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
pub struct PhysicsArgs {
    /// Step solver: `xpbd` (the scene's iterations of Gauss–Seidel) or `newton` (converged;
    /// default: the scene's `physics.solver`).
    #[arg(long, value_parser = physics_solver())]
    physics: Option<SolverKind>,
    /// Newton's relative ‖∇Φ‖ tolerance, in (0, 1) (default: the scene's, else 1e-10).
    #[arg(long)]
    physics_tolerance: Option<f64>,
    /// Newton's load steps per time step, ≥ 1 (default: the scene's, else 1).
    #[arg(long)]
    physics_load_steps: Option<usize>,
    /// Newton's branch following: most halvings of a load increment whose solve leaves the
    /// convex neighbourhood of a minimizer, 0–20 (default: the scene's, else 10; 0 with one
    /// load step is one solve from x̃ per step).
    #[arg(long)]
    physics_load_halvings: Option<usize>,
    /// Newton's linear solver: `direct` (a sparse Cholesky factorization per Newton matrix) or
    /// `pcg` (conjugate gradients preconditioned with a reused factorization; default: the
    /// scene's `physics.linear_solver`, else `direct`).
    #[arg(long, value_parser = linear_solver())]
    physics_linear_solver: Option<LinearSolverKind>,
}

/// `--physics-linear-solver`: `direct` or `pcg`, the scene format's names.
fn linear_solver() -> impl TypedValueParser<Value = LinearSolverKind> {
    PossibleValuesParser::new(["direct", "pcg"]).map(|name| match name.as_str() {
        "pcg" => LinearSolverKind::Pcg,
        _ => LinearSolverKind::Direct,
    })
}

/// `--physics`: one of the scene format's solver names ([`SolverKind::ALL`], listed in `--help`),
/// parsed by [`SolverKind`]'s `FromStr`.
fn physics_solver() -> impl TypedValueParser<Value = SolverKind> {
    PossibleValuesParser::new(SolverKind::ALL.map(SolverKind::name))
        .try_map(|name| name.parse::<SolverKind>())
}

impl PhysicsArgs {
    /// Writes the flags into the scene's `physics` (validated with the scene).
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(solver) = self.physics {
            scene.physics.solver = Some(solver);
        }
        if let Some(tol) = self.physics_tolerance {
            ensure_open_unit("--physics-tolerance", tol)?;
            scene.physics.tolerance = Some(tol);
        }
        if let Some(k) = self.physics_load_steps {
            ensure_iterations("--physics-load-steps", k)?;
            scene.physics.load_steps = Some(k);
        }
        if let Some(h) = self.physics_load_halvings {
            ensure_at_most(
                "--physics-load-halvings",
                h,
                cloth::scene::MAX_LOAD_HALVINGS,
            )?;
            scene.physics.load_halvings = Some(h);
        }
        if let Some(k) = self.physics_linear_solver {
            scene.physics.linear_solver = k;
        }
        Ok(())
    }
}

/// Loads a scene by built-in name or file path, applies `--sweeps` and the physics flags.
pub fn load_scene(name: &str, sweeps: Option<usize>, physics: &PhysicsArgs) -> Result<Scene> {
    let mut scene = clothopt::request::load_scene(name)?;
    if let Some(n) = sweeps {
        ensure_iterations("--sweeps", n)?;
        scene.physics.iterations = n;
    }
    physics.apply(&mut scene)?;
    for warning in clothopt::target_check::buried_target_warnings(&scene) {
        eprintln!("warning: {warning}");
    }
    Ok(scene)
}

/// A controls file, or any JSON object with a `controls` key (such as a result).
#[derive(serde::Deserialize)]
struct ControlsFile {
    controls: Vec<Vec<[f64; 3]>>,
}

/// The controls as a file may hold them: the nested array `controls[t][k] = [dx, dy, dz]` itself
/// (a text starting with `[`), or an object with a `controls` key (a controls file, a result).
fn parse_controls(text: &str) -> serde_json::Result<Vec<Vec<[f64; 3]>>> {
    if text.trim_start().starts_with('[') {
        serde_json::from_str(text)
    } else {
        serde_json::from_str::<ControlsFile>(text).map(|f| f.controls)
    }
}

/// The controls in `file` (a controls file, a result, or the bare nested array), or the scene's
/// initial guess.
pub fn load_controls(scene: &Scene, model: &Model, file: Option<&Path>) -> Result<Controls> {
    match file {
        None => Ok(initial_controls(scene, model)?),
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let parsed = parse_controls(&text).with_context(|| {
                format!(
                    "{}: not a controls file (expected the nested array [[[dx, dy, dz], …], …] with one \
                     entry per step and one [dx, dy, dz] per control point, or an object with a \
                     `controls` key holding it, such as a result)",
                    path.display()
                )
            })?;
            controls_from_nested(model, &parsed).with_context(|| path.display().to_string())
        }
    }
}

/// Draws a rollout's 3-D view to `png` and its top view beside it.
pub fn draw(
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
