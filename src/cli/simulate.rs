//! `clothopt simulate`: roll a control sequence out and report the metrics.

use super::common::{draw, load_controls, load_scene, PhysicsArgs, WatchArgs};
use anyhow::Result;
use cloth::Model;
use clothopt::output::write_json_atomic;
use clothopt::result::{controls_to_nested, mesh_triangles, state_points, PhysicsReport};
use clothopt::start_check::start_warning;
use std::path::PathBuf;

/// Simulate a control sequence and report the metrics.
#[derive(clap::Args)]
pub struct SimulateArgs {
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
}

/// Runs `simulate`: prints the metrics, writes the rollout JSON and the figures asked for.
pub fn run(args: SimulateArgs) -> Result<i32> {
    let scene = load_scene(&args.scene, args.sweeps, &args.physics)?;
    let model = Model::from_scene(&scene)?;
    let u = load_controls(&scene, &model, args.controls.as_deref())?;
    if let Some(w) = model.start_report.as_ref().and_then(start_warning) {
        eprintln!("warning: {w}");
    }
    let ev = model.evaluate(&u, scene.task.delta, false)?;
    let m = ev.metrics;
    println!("scene {} — {}", scene.name, model.effects());
    println!(
        "{}",
        PhysicsReport::of(&scene, &model, &ev.states, &u).summary_line()
    );
    println!(
        "G {:.6}  T {:.6}  E {:.6}  L {:.6}  C {:.3e}  min SDF {:.4}  swept {:.4}",
        m.g, m.t, m.e, m.l, m.c, m.min_sdf, m.min_sdf_swept
    );
    if let Some(out) = args.out {
        let mut result = serde_json::json!({
            "scene": scene.name, "delta": scene.task.delta, "metrics": m,
            "grid": [scene.cloth.rows, scene.cloth.cols],
            "control_particles": model.controls.as_slice(),
            "controls": controls_to_nested(&u),
            "states": ev.states.iter().map(state_points).collect::<Vec<_>>(),
        });
        if let Some(t) = mesh_triangles(&scene, &model) {
            result["triangles"] = serde_json::json!(t);
        }
        write_json_atomic(&out, &result)?;
    }
    let title = format!("{} (simulated)", scene.name);
    if let Some(png) = args.png {
        draw(&model, &scene, &ev.states, &title, scene.task.delta, &png)?;
    }
    args.watch
        .write(&model, &scene, &ev.states, &title, scene.task.delta)?;
    Ok(0)
}
