//! Plan a scene from code: load a built-in scene, change it, optimize, and look at the plan.
//!
//! `cargo run --release --example plan_from_code [-- OUT.json]`
//!
//! The built-in `u_obstacle` scene (a cloth carried through a U-shaped obstacle) with a wider
//! safety margin, planned with the default SQP. The result is what `clothopt optimize --out`
//! writes; `read_result` reads it back.

use anyhow::Result;
use cloth::{Model, Scene};
use clothopt::plan::{self, PlanOptions};

fn main() -> Result<()> {
    // A scene is plain data: load a built-in one (or `Scene::load("file.json")`) and edit it.
    let mut scene = Scene::builtin("u_obstacle")?;
    scene.task.delta = 0.3; // keep every particle 0.3 from the obstacle (default 0.2)
    scene.physics.iterations = 50; // fewer Gauss–Seidel iterations per step: faster, less stiff

    // The model is the differentiable simulator built from the scene; it checks the scene.
    let model = Model::from_scene(&scene)?;
    let start = plan::initial_controls(&scene, &model)?;

    // Options default to the scene's task (weights, margin); the solver's limits are ours to set.
    let mut options = PlanOptions::for_model(&model);
    options.iterations = 150;

    // `plan` calls back after every optimizer iteration (`IterationInfo` prints itself).
    let result = plan::plan(&model, &scene, &start, &options, |info| {
        if info.iteration % 10 == 0 {
            println!("{info}");
        }
    })?;

    let m = &result.metrics;
    println!(
        "\n{}: {} after {} iterations ({} simulations, {:.1} s)",
        result.scene, result.status, result.iterations, result.evaluations, result.wall_s
    );
    println!(
        "L = {:.4} = G {:.4} + αT {:.4} + βE {:.4}",
        m.l, m.g, m.alpha_t, m.beta_e
    );
    println!(
        "closest approach {:.4} (margin δ = {}): {}",
        m.min_sdf,
        result.delta,
        if result.is_safe() { "safe" } else { "NOT safe" }
    );
    println!("task: {}", result.task.explanation);

    if let Some(out) = std::env::args_os().nth(1) {
        clothopt::output::write_json_atomic(out.as_ref(), &result)?;
        println!("wrote {}", out.to_string_lossy());
    }
    Ok(())
}
