//! `clothopt grad`: L, its terms, C and their gradients with respect to the controls, as JSON.

use super::common::{load_controls, load_scene, PhysicsArgs};
use anyhow::Result;
use cloth::Model;
use clothopt::result::controls_to_nested;
use clothopt::validate::{ensure_iterations, ensure_non_negative};
use std::io::Write;
use std::path::PathBuf;

/// Print L, its terms, C and their gradients with respect to the controls as one JSON object.
#[derive(clap::Args)]
pub struct GradArgs {
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
}

/// Runs `grad`: evaluates with gradients and prints one JSON object on stdout.
pub fn run(args: GradArgs) -> Result<i32> {
    if let Some(delta) = args.delta {
        ensure_non_negative("--delta", delta)?;
    }
    if let Some(n) = args.sweeps {
        ensure_iterations("--sweeps", n)?;
    }
    let scene = load_scene(&args.scene, args.sweeps, &args.physics)?;
    let model = Model::from_scene(&scene)?;
    let u = load_controls(&scene, &model, args.controls.as_deref())?;
    let delta = args.delta.unwrap_or(scene.task.delta);
    let ev = model.evaluate(&u, delta, true)?;
    let m = ev.metrics;
    let nested = |g: Option<autodiff::Tensor>| g.map(|g| controls_to_nested(&g));
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
    Ok(0)
}
