//! Fit a towel's material from one recorded motion, then plan a task on the fitted scene.
//!
//! `cargo run --release --example fit_then_plan`
//!
//! `examples/scenes/fit/lay.json` plays the real towel. Its rollout of a recorded motion, seen at
//! 24 particles with 1 mm noise, stands in for a tracker's output. From a scene whose stretch,
//! bending and friction are wrong by factors 2.5, 0.4 and 1.6, `fit` recovers them; the planner
//! then lays the towel's free edge on its targets in the fitted scene, and the plan's controls
//! are played on the real towel to see what the robot would see (and the same for a plan made
//! on the wrong guess).

use anyhow::Result;
use cloth::{ConstraintRegistry, Controls, Model, Parameter, Scene};
use clothopt::fit::synthetic::{synthetic, Sampling};
use clothopt::fit::{fit, FitOptions};
use clothopt::plan::{initial_controls, PlanOptions};
use clothopt::result::{controls_from_nested, target_errors};
use clothopt::search::{plan_with_search, SearchOptions};
use std::time::{Duration, Instant};

fn main() -> Result<()> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/scenes/fit");
    let real = Scene::load(format!("{dir}/lay.json"))?;
    let real_model = Model::from_scene(&real)?;

    // 1. The recording: the grippers lowered 0.25 m while drawn 0.3 m across the table, the
    //    towel seen at 24 particles every 2nd step with 1 mm of noise.
    let motion = recorded_motion(dir, &real_model)?;
    let sampling = Sampling {
        points: 24,
        every: 2,
        noise: 1e-3,
        seed: 7,
    };
    // `_file` is the same as an observation file's JSON, what `clothopt fit --observed` reads.
    let (observed, _file) = synthetic(&real_model, &motion, &sampling)?;

    // 2. The fit, from a deliberately wrong guess of the material.
    let params: Vec<Parameter> = ["stretch", "bending", "friction"]
        .iter()
        .map(|name| Parameter::parse(name))
        .collect();
    let guess = Parameter::scaled(&real, &params, [2.5, 0.4, 1.6])?;
    let registry = ConstraintRegistry::new();
    let fitted = fit(
        &guess,
        &registry,
        &observed,
        &params,
        &FitOptions::default(),
    )?;
    println!(
        "fit: {:?} after {} iterations ({} simulations, {:.1} s); tracking RMS {:.1} mm → {:.2} mm",
        fitted.status,
        fitted.iterations,
        fitted.simulations,
        fitted.wall_s,
        1e3 * fitted.rms_error_start,
        1e3 * fitted.rms_error
    );
    for p in &params {
        let f = &fitted.parameters[&p.to_string()];
        let se = f.std_error.map_or("—".into(), |s| format!("{s:.2e}"));
        println!(
            "  {:<9} start {:.3e}  fitted {:.3e} ± {se}  (truth {:.3e}){}",
            p.to_string(),
            f.start,
            f.value,
            p.value(&real)?,
            if f.identifiable {
                ""
            } else {
                "  not identifiable"
            }
        );
    }

    // 3. Plan the scene's own task on the fitted scene; play the plan on the real towel. The
    //    wrong guess, planned and played the same way, shows what the fit buys.
    plan_and_play("fitted scene", &fitted.fitted_scene, &real_model)?;
    plan_and_play("wrong guess", &guess, &real_model)?;
    Ok(())
}

/// Plans `scene`'s task (25 s at most), then plays the plan's controls on the real towel.
fn plan_and_play(name: &str, scene: &Scene, real: &Model) -> Result<()> {
    let model = Model::from_scene(scene)?;
    let mut options = PlanOptions::for_model(&model);
    options.deadline = Some(Instant::now() + Duration::from_secs(25));
    let start = initial_controls(scene, &model)?;
    let search = SearchOptions::default();
    let plan = plan_with_search(&model, scene, &start, &options, &search, |_| {})?;
    println!(
        "\nplan on the {name}: {} ({} SQP iterations, {} simulations, {:.1} s)\n  {}",
        plan.task.reason.name(),
        plan.iterations,
        plan.evaluations,
        plan.wall_s,
        plan.task.explanation
    );
    // What the robot would see: the same controls on the real towel.
    let states = real.simulate(&controls_from_nested(real, &plan.controls)?)?;
    let errors = target_errors(real, &states[states.len() - 1]);
    let mm: Vec<String> = errors.iter().map(|e| format!("{:.1}", 1e3 * e)).collect();
    println!(
        "  played on the real towel: target errors {} mm (tolerance {:.0} mm)",
        mm.join(", "),
        1e3 * real.task.tolerance
    );
    Ok(())
}

/// The recorded motion `lay_motion.json` (a controls file): the grippers lowered 0.25 m while
/// drawn 0.3 m along +y.
fn recorded_motion(dir: &str, model: &Model) -> Result<Controls> {
    let text = std::fs::read_to_string(format!("{dir}/lay_motion.json"))?;
    let file: serde_json::Value = serde_json::from_str(&text)?;
    let steps: Vec<Vec<[f64; 3]>> = serde_json::from_value(file["controls"].clone())?;
    Ok(controls_from_nested(model, &steps)?)
}
