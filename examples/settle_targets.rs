//! Whether a task's targets are a state the cloth can rest in: the cloth put at its targets
//! (every particle must have one), its grippers held there (moved by `--offset`), simulated under
//! the scene's physics with zero moves; prints the largest target error and the targets within the
//! tolerance at each step. The verdict's check (`clothopt::target_check::targets_rest`), step by
//! step. A task whose targets settle beyond its tolerance asks for a state the grippers cannot
//! hold: a plan can only end at another equilibrium.
//!
//! `cargo run --release --example settle_targets -- SCENE.json [--steps 8] [--spread 1]
//! [--offset dx,dy,dz]`
//!
//! `--spread` multiplies the targets' heights above the lowest, so that layers a target set puts
//! at the self-contact thickness start apart (the verdict tries 1, 2, then 3).
use anyhow::{anyhow, bail, Context};
use cloth::{Model, Scene};
use clothopt::target_check::{start_at_targets, TargetRest, REST_STEPS};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let value = |f: &str| {
        args.iter()
            .position(|a| a == f)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let file = args.get(1).filter(|a| !a.starts_with("--"));
    let scene = Scene::load(file.ok_or_else(|| anyhow!("usage: settle_targets SCENE.json"))?)?;
    let steps: usize = value("--steps").map_or(Ok(REST_STEPS), |v| v.parse())?;
    let spread: f64 = value("--spread").map_or(Ok(1.0), |v| v.parse())?;
    let offset: Vec<f64> = match value("--offset") {
        Some(v) => v.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![0.0; 3],
    };
    if offset.len() != 3 {
        bail!("--offset takes dx,dy,dz");
    }
    let model = Model::from_scene(&scene)?;
    let mut start = start_at_targets(&model, spread)
        .context("the task needs exactly one target for every particle")?;
    for &p in model.controls.as_slice() {
        for (k, d) in offset.iter().enumerate() {
            start[p][k] += d;
        }
    }
    let placed = model.placed_at(&start, steps)?;
    let states = placed.simulate(&placed.zero_controls())?;
    let tolerance = model.task.tolerance;
    println!("step  largest error  largest rise  within {tolerance:.4}");
    for (t, x) in states.iter().enumerate() {
        let rest = TargetRest::of(&model, x, spread);
        println!(
            "{t:>4}  {:>13.4}  {:>12.4}  {} / {}",
            rest.largest_error, rest.largest_rise, rest.reached, rest.targets
        );
    }
    Ok(())
}
